"""plumage.models: the C++ models over numpy arrays (python/models_binding.cpp)."""

import numpy as np
import pytest

import plumage
from plumage import models


def hemisphere(n, seed):
    """n unit vectors uniform over the upper hemisphere (z > 0)."""
    rng = np.random.default_rng(seed)
    z = rng.uniform(0.05, 1.0, n)
    phi = rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def test_lambertian_is_albedo_over_pi():
    wi, wo = hemisphere(100, 1), hemisphere(100, 2)
    f = models.Lambertian(albedo=0.37).eval(wi, wo, np.linspace(400, 700, 100))
    np.testing.assert_allclose(f, 0.37 / np.pi, rtol=1e-15)
    assert f.shape == (100,) and f.dtype == np.float64


def filip_reference(p, wi, wo, lam):
    """Filip et al. 2024, Eqs. 1–6 as analysis/models/filip2024.h reads them, written in numpy."""
    channel = np.where(lam < 490, 2, np.where(lam < 580, 1, 0))  # R, G, B = 0, 1, 2
    pick = lambda rgb: np.asarray(rgb)[channel]
    h = wi + wo
    h /= np.linalg.norm(h, axis=1)[:, None]
    u = np.array([np.sin(p["phi_a_rad"]), np.cos(p["phi_a_rad"]), 0.0])
    x = 1 - np.abs(h @ u)
    y = np.clip((x - p["w"] + p["d_w"]) / (2 * p["d_w"]), 0, 1)
    mask = y * y * (3 - 2 * y)
    theta_i, theta_o = np.arccos(wi[:, 2]), np.arccos(wo[:, 2])
    e = 1.1 - wi[:, 2] * wo[:, 2]
    phi_i, phi_o = np.arctan2(wi[:, 1], wi[:, 0]), np.arctan2(wo[:, 1], wo[:, 0])
    wrap = lambda a: np.abs((a + np.pi) % (2 * np.pi) - np.pi) / (2 * np.pi)
    d0, dpi = wrap(phi_i - phi_o), wrap(phi_i - phi_o - np.pi)
    f_term = np.maximum(0, 1 - np.abs(theta_i - theta_o) / p["theta_max_rad"])
    total = ((1 - mask) * pick(p["c_b"]) + mask * pick(p["c_a"])
             + (1 - mask) * pick(p["c_s"]) * e * d0 * f_term
             + (1 - mask) * pick(p["c_r"]) * e * dpi ** p["gamma"] * f_term
             + mask * p["alpha"] * e ** p["beta"] * d0)
    return p["brdf_scale_per_sr"] * total


@pytest.mark.parametrize("preset", ["parrot", "rooster", "flamingo", "stork"])
def test_filip2024_matches_the_equations(preset):
    m = models.Filip2024(preset=preset)
    wi, wo = hemisphere(5000, 3), hemisphere(5000, 4)
    lam = np.random.default_rng(5).uniform(380, 780, 5000)
    np.testing.assert_allclose(m.eval(wi, wo, lam), filip_reference(m.params, wi, wo, lam),
                               rtol=1e-12, atol=1e-15)


@pytest.mark.parametrize("make", [models.Huang2022, models.Filip2024, models.PadronGriffe2024,
                                  models.Lambertian])
def test_vectorised_equals_one_call_per_direction_and_lobes_sum(make):
    m = make()
    n = 40
    wi, wo = hemisphere(n, 6), hemisphere(n, 7)
    lam = np.linspace(400, 700, n)
    f = m.eval(wi, wo, lam)
    one_by_one = np.array([m.eval(wi[k], wo[k], lam[k], threads=1) for k in range(n)])
    np.testing.assert_array_equal(f, one_by_one)
    parts = m.eval(wi, wo, lam, lobes=True)
    assert list(parts) == ["total"] + m.lobe_names
    np.testing.assert_array_equal(parts["total"], f)
    np.testing.assert_allclose(sum(parts[k] for k in m.lobe_names), f, rtol=1e-12, atol=1e-300)
    assert np.all(f >= 0) and np.any(f > 0)


def test_broadcasting():
    m = models.Huang2022()
    wo = hemisphere(50, 8)
    wi = np.array([0.3, 0.1, np.sqrt(0.9)])
    full = m.eval(np.tile(wi, (50, 1)), wo, np.full(50, 550.0))
    np.testing.assert_array_equal(m.eval(wi, wo, 550.0), full)
    np.testing.assert_array_equal(m.eval(wi.tolist(), wo.tolist(), 550), full)  # lists, ints
    with pytest.raises(ValueError, match="broadcast"):
        m.eval(hemisphere(3, 1), wo, 550.0)
    with pytest.raises(ValueError, match=r"wo: expected shape \(\.\.\., 3\)"):
        m.eval(wi, np.zeros((4, 2)), 550.0)


def test_scalar_call_gives_a_scalar():
    m = models.Huang2022()
    wi, wo = hemisphere(2, 20)
    f = m.eval(wi, wo, 550.0)
    assert isinstance(f, np.float64) and np.shape(f) == ()
    assert f == m.eval(wi[None], wo[None], [550.0])[0]
    parts = m.eval(wi, wo, 550.0, lobes=True)
    assert all(np.shape(v) == () for v in parts.values()) and parts["total"] == f


def test_direction_arrays_of_any_shape_broadcast_as_numpy_does():
    """(..., 3) arrays: one ω_i against a (1000, 1000, 3) grid, and an outer product of tables."""
    t, p = np.meshgrid(np.linspace(0, 1.5, 1000), np.linspace(0, 2 * np.pi, 1000), indexing="ij")
    grid = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=-1)
    wi = np.array([0.3, 0.1, np.sqrt(0.9)])
    m = models.Filip2024()
    f = m.eval(wi, grid, 550.0)
    assert f.shape == (1000, 1000)
    np.testing.assert_array_equal(f.ravel(), m.eval(wi, grid.reshape(-1, 3), 550.0))
    h = models.Huang2022()
    small = grid[::25, ::20]  # (40, 50, 3)
    g = h.eval(wi, small, np.full(50, 550.0), lobes=True)  # λ broadcasts over the last axis
    assert g["TRT"].shape == (40, 50)
    np.testing.assert_array_equal(g["total"].ravel(), h.eval(wi, small.reshape(-1, 3), 550.0))
    a, b = hemisphere(7, 21), hemisphere(5, 22)
    table = h.eval(a[:, None, :], b[None, :, :], 600.0)
    assert table.shape == (7, 5)
    np.testing.assert_array_equal(table[3], h.eval(a[3], b, 600.0))


@pytest.mark.parametrize("make", [models.Huang2022, models.Filip2024, models.PadronGriffe2024,
                                  models.Lambertian])
def test_below_the_horizon_is_zero_not_an_error(make):
    m = make()
    up, down = np.array([0.3, 0.1, np.sqrt(0.9)]), np.array([0.3, 0.1, -np.sqrt(0.9)])
    flat = np.array([1.0, 0.0, 0.0])
    wi = np.array([up, down, flat, up, down])
    wo = np.array([down, up, up, flat, down])
    np.testing.assert_array_equal(m.eval(wi, wo, 550.0), 0.0)
    parts = m.eval(wi, wo, 550.0, lobes=True)
    assert all(np.all(v == 0.0) for v in parts.values())
    assert m.eval(down, up, 550.0) == 0.0  # light from below: 0 even with transmission
    assert m.eval(down, up, 550.0, transmission=True) == 0.0


def test_transmission_keeps_the_bsdf_below_the_patch():
    """Padrón-Griffe's fibres transmit: transmission=True gives the C++ BSDF below the patch."""
    m = models.PadronGriffe2024(fibre_offsets=64)
    wi = np.array([0.3, 0.1, np.sqrt(0.9)])
    below = hemisphere(200, 23) * np.array([1, 1, -1])
    assert np.all(m.eval(wi, below, 550.0) == 0.0)
    assert np.any(m.eval(wi, below, 550.0, transmission=True) > 0.0)


@pytest.mark.parametrize("cls", [models.Huang2022, models.Filip2024, models.PadronGriffe2024,
                                 models.Lambertian])
def test_eval_documents_units_frames_and_shapes(cls):
    import pydoc

    # Paragraphs are wrapped again per model, so a phrase may break over lines: compare words.
    text = " ".join(pydoc.render_doc(cls.eval, renderer=pydoc.plaintext).split())
    for phrase in ("1/sr", "nm", "LOCAL frame", "barb-plane) normal", "AWAY from the surface",
                   "(..., 3)", "broadcast", "z <= 0", "threads", "lobes"):
        assert phrase in text, (cls.__name__, phrase)
    assert cls.eval.__doc__ != models.Model.eval.__doc__ or cls is models.Model


def test_huang_values_are_those_before_the_speed_up():
    """Issue 41's speed-up (visibility copies, shared sines, unclipped θ supports) moves no value
    beyond rounding: 3000 random pairs at five wavelengths (the grazing resonances 471 and
    694 nm among them) against the values of commit 7812627, stored in data/."""
    import pathlib

    ref = np.load(pathlib.Path(__file__).parent / "data" / "huang2022_eval_before.npz")
    parts = models.Huang2022().eval(ref["wi"], ref["wo"], ref["wavelength_nm"], lobes=True)
    for lobe in ("R", "TRT"):
        np.testing.assert_allclose(parts[lobe], ref[lobe], rtol=1e-12, atol=0, err_msg=lobe)


def test_thread_count_does_not_change_a_bit():
    wi, wo = hemisphere(3000, 9), hemisphere(3000, 10)
    lam = np.random.default_rng(11).uniform(400, 700, 3000)
    for m in (models.Huang2022(), models.PadronGriffe2024(fibre_offsets=64)):
        one = m.eval(wi, wo, lam, threads=1)
        for t in (2, 3, 7):
            np.testing.assert_array_equal(m.eval(wi, wo, lam, threads=t), one)


def test_parameters_are_the_cpp_fields():
    m = models.Huang2022(d_um=0.45, mu=-0.3)
    assert m.params == {"b": 0.25, "phi0": -0.37, "phi1": 2.64, "H": 1.25, "d_um": 0.45,
                        "theta_d": 0.0785, "mu": -0.3}
    assert models.Filip2024(preset="stork", gamma=2).params["gamma"] == 2
    assert models.PadronGriffe2024(barb_width_um=40).params["barb_width_um"] == 40
    # A thinner film moves the R lobe's colour: the parameter reaches the C++ model.
    wi = np.array([0.0, 0.0, 1.0])
    lam = np.linspace(400, 700, 31)
    thick = models.Huang2022().eval(wi, wi, lam, lobes=True)["R"]
    thin = m.eval(wi, wi, lam, lobes=True)["R"]
    assert not np.allclose(thick, thin)


def test_unknown_keyword_names_it_and_the_valid_ones():
    with pytest.raises(TypeError, match=r"unknown parameter 'd'; valid parameters: b, phi0, phi1, "
                                        r"H, d_um, theta_d, mu"):
        models.Huang2022(d=0.5)
    with pytest.raises(TypeError, match="'albedo_'.*albedo"):
        models.Lambertian(albedo_=0.5)
    with pytest.raises(TypeError, match="'b' = 'thin': expected a number"):
        models.Huang2022(b="thin")


def test_invalid_values_raise_the_cpp_message():
    with pytest.raises(ValueError, match=r"huang2022: b = 7: expected the cross-section.s semi-minor over semi-major axis in \[0.001, 1\]"):
        models.Huang2022(b=7)
    with pytest.raises(ValueError, match=r"lambertian: albedo = 1.5"):
        models.Lambertian(albedo=1.5)
    with pytest.raises(ValueError, match="parrot"):
        models.Filip2024(preset="pigeon")
    with pytest.raises(ValueError, match=r"element 1: huang2022: incident direction"):
        models.Huang2022().eval([[0, 0, 1], [0, 0, 2]], [0, 0, 1], 500.0)  # not a unit vector
    with pytest.raises(ValueError, match="threads"):
        models.Lambertian().eval([0, 0, 1], [0, 0, 1], 500.0, threads=0)


def test_eval_releases_the_gil():
    """Another Python thread runs while eval() loops in C++."""
    import threading
    import time

    wo = hemisphere(200_000, 12)
    m = models.Huang2022()
    done = threading.Event()

    def work():
        m.eval([0.3, 0.1, np.sqrt(0.9)], wo, 550.0, threads=1)
        done.set()

    worker = threading.Thread(target=work)
    ticks = 0
    worker.start()
    time.sleep(0.05)  # let the worker enter eval()
    while not done.is_set():
        ticks += 1  # Python bytecode: runs only when the worker does not hold the GIL
        time.sleep(0.005)
    worker.join()
    assert ticks >= 20  # eval takes ~1 s; with the GIL held this loop could not run at all


def test_parameter_tables_are_the_models_own():
    """The table the bindings list is the one the C++ model validates against: its names are
    the model's parameters, its defaults the model's defaults, and a value outside its range is
    refused naming that range."""
    table = plumage.models.parameter_table("huang2022")
    params = plumage.models.Huang2022().params
    assert [p["name"] for p in table] == list(params)
    for p in table:
        assert p["default"] == pytest.approx(params[p["name"]], rel=0, abs=0)
    mu = next(p for p in table if p["name"] == "mu")
    assert mu["min_open"] and mu["max_open"] and mu["range"].startswith("(")
    with pytest.raises(ValueError, match=r"huang2022: mu = 2 rad: expected a barb-plane tilt in \("):
        plumage.models.Huang2022(mu=2.0)
    filip = plumage.models.parameter_table("filip2024")
    assert len(filip) == 20 and filip[0]["name"] == "phi_a"
    with pytest.raises(ValueError, match="unknown model 'nope'"):
        plumage.models.parameter_table("nope")
