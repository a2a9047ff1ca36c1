"""plumage.fit_filip2024 / plumage.fit_huang2022 on the user's own data (docs/user_data.md): numpy
arrays, the CSV layout and records; known parameters recovered within their stated σ from data
with seeded noise of known σ; the fitted-parameters JSON."""

import json

import numpy as np
import pytest

import plumage
from plumage import models

FILIP_FREE = ["phi_a", "C_b[R]", "C_b[G]", "C_b[B]", "C_a[R]", "C_a[G]", "C_a[B]", "C_s[R]",
              "C_s[G]", "C_s[B]", "C_r[R]", "C_r[G]", "C_r[B]", "alpha", "beta", "gamma", "w",
              "d_w"]


def _directions(theta_deg, phi_deg):
    t, p = np.radians(theta_deg), np.radians(phi_deg)
    return np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], axis=1)


def _filip_data(seed):
    """The parrot preset on the 61 x 60 BTF set x 450/550/650 nm, σ = 3 % of f + 0.002 1/sr."""
    rows = [(ti, pi, to, po, lam)
            for ti in range(0, 76, 15) for pi in ([0] if ti == 0 else range(0, 360, 30))
            for to in range(15, 76, 15) for po in range(0, 360, 30)
            for lam in (450.0, 550.0, 650.0)]
    ti, pi, to, po, lam = (np.array(c, dtype=float) for c in zip(*rows))
    f = models.Filip2024("parrot").eval(_directions(ti, pi), _directions(to, po), lam)
    sigma = 0.03 * f + 0.002
    value = f + sigma * np.random.default_rng(seed).standard_normal(f.size)
    return dict(theta_i_deg=ti, phi_i_deg=pi, theta_o_deg=to, phi_o_deg=po, wavelength_nm=lam,
                value=value, sigma=sigma)


def _filip_truth():
    """The parrot preset by the fit's parameter names (analysis/models/filip2024.h's table)."""
    p = models.Filip2024("parrot").params
    rgb = {"C_b": p["c_b"], "C_a": p["c_a"], "C_s": p["c_s"], "C_r": p["c_r"]}
    truth = {"phi_a": p["phi_a_rad"], "alpha": p["alpha"], "beta": p["beta"],
             "gamma": p["gamma"], "w": p["w"], "d_w": p["d_w"]}
    for name, values in rgb.items():
        for channel, v in zip("RGB", values):
            truth[f"{name}[{channel}]"] = v
    return truth


def test_filip_from_arrays_recovers_the_truth_with_honest_sigma():
    truth = _filip_truth()
    start = {k: (v + 0.05 if k == "phi_a" else 1.05 * v) for k, v in truth.items()}
    pulls = []
    for seed in (1, 2):
        fit = plumage.fit_filip2024(_filip_data(seed), start=start)
        assert fit["converged"], fit["termination"]
        assert sorted(fit["free_parameters"]) == sorted(FILIP_FREE)
        assert abs(fit["reduced_chi_square"] - 1.0) < 5 * np.sqrt(2 / fit["degrees_of_freedom"])
        for name in FILIP_FREE:
            diff = fit["params"][name] - truth[name]
            if name == "phi_a":  # periodic in π
                diff -= np.pi * np.round(diff / np.pi)
            pulls.append(diff / fit["standard_errors"][name])
        assert fit["residuals"].shape == fit["model_per_sr"].shape == (10980,)
    pulls = np.array(pulls)
    assert np.all(np.abs(pulls) < 3.0), pulls
    assert 0.5 < np.sqrt(np.mean(pulls ** 2)) < 2.0  # the stated σ are neither absurd nor tiny


def test_filip_from_csv_equals_arrays_and_writes_the_documented_json(tmp_path):
    data = _filip_data(3)
    csv = tmp_path / "parrot.csv"
    with open(csv, "w") as f:
        f.write("# docs/user_data.md layout\n"
                "theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr,"
                "sigma_per_sr\n")
        for row in zip(data["theta_i_deg"], data["phi_i_deg"], data["theta_o_deg"],
                       data["phi_o_deg"], data["wavelength_nm"], data["value"], data["sigma"]):
            f.write(",".join(repr(float(x)) for x in row) + "\n")
    from_csv = plumage.fit_filip2024(csv)
    from_arrays = plumage.fit_filip2024(data)
    for name in FILIP_FREE:
        assert from_csv["params"][name] == pytest.approx(from_arrays["params"][name], rel=1e-9)
    doc = json.loads(from_csv["json"])
    assert doc["format"] == "plumage fit" and doc["format_version"] == 1
    assert doc["model"] == "filip2024"
    assert doc["data"] == {"file": str(csv), "format": "csv", "standard_errors": True,
                           "left_out": 0, "wavelengths_nm": [450, 550, 650]}
    alpha = doc["parameters"]["alpha"]
    assert alpha["value"] == from_csv["params"]["alpha"]
    assert alpha["sigma"] == from_csv["standard_errors"]["alpha"]
    assert (alpha["unit"], alpha["min"], alpha["max"], alpha["fixed"]) == ("1", 0, 100, False)
    assert doc["parameters"]["theta_max"]["fixed"] and doc["parameters"]["theta_max"]["sigma"] is None
    assert doc["fit"]["degrees_of_freedom"] == from_csv["degrees_of_freedom"]
    assert doc["covariance"]["parameters"] == from_csv["free_parameters"]
    assert np.allclose(doc["covariance"]["matrix"], from_csv["covariance"])


def test_filip_bad_input():
    data = _filip_data(1)
    with pytest.raises(ValueError, match="unknown parameter 'alfa'"):
        plumage.fit_filip2024(data, start={"alfa": 2.0})
    data["theta_o_deg"] = data["theta_o_deg"].copy()
    data["theta_o_deg"][5] = 95.0
    with pytest.raises(ValueError, match="row 5: polar angle 95"):
        plumage.fit_filip2024(data)


def test_filip_global_starts_reach_the_fit():
    """global_starts reaches the C++ fit: 0 is a local fit from the truth (the same minimum on
    noise-free data: χ² near 0 either way), and a count outside 0..192 is refused by name."""
    data = _filip_data(2)
    data["value"] = models.Filip2024("parrot").eval(
        _directions(data["theta_i_deg"], data["phi_i_deg"]),
        _directions(data["theta_o_deg"], data["phi_o_deg"]), data["wavelength_nm"])
    local = plumage.fit_filip2024(data, start=_filip_truth(), global_starts=0)
    assert local["reduced_chi_square"] < 1e-6
    with pytest.raises(ValueError, match="global_starts = 193"):
        plumage.fit_filip2024(data, global_starts=193)


def test_filip_refusal_of_a_file_names_the_file(tmp_path):
    """The fit's own check (too few observations) knows no file: the binding adds it."""
    table = tmp_path / "two_rows.csv"
    table.write_text("theta_i_deg,phi_i_deg,theta_o_deg,phi_o_deg,wavelength_nm,value_per_sr\n"
                     "30,90,30,270,550,2.41\n30,90,45,270,550,0.83\n")
    with pytest.raises(ValueError, match=r"two_rows\.csv: Filip 2024 fit: 2 observations"):
        plumage.fit_filip2024(table)


def test_huang_from_arrays_recovers_the_truth(rock_dove_results):
    """The rock-dove record's image geometry (41 x 41 pixels, its beam) with the model's own
    image at the published parameters plus 3 % Gaussian noise, given as numpy arrays."""
    rec = plumage.read_record(rock_dove_results / "fit/simulation.h5")
    beam = np.array([float(x) for x in str(rec.instrument["beam_direction"]).split()])
    omega = np.asarray(rec.datasets["/image/solid_angle_sr"])
    n = omega.shape[0]
    geometry = dict(illumination="beam", beam_direction=beam, wavelength_nm=np.array([550.0]),
                    intensity=np.zeros((n, n, 1)), standard_error=np.zeros((n, n, 1)),
                    solid_angle_sr=omega)
    truth = models.Huang2022().params
    image = models.huang2022_scatterogram(truth, geometry)
    sigma = 0.03 * image
    data = dict(geometry, intensity=image + sigma * np.random.default_rng(4).standard_normal(
        image.shape), standard_error=sigma)
    start = dict(truth, b=0.26, H=1.2, d_um=0.6, mu=-0.33)
    fit = plumage.fit_huang2022(data, start=start, fixed=["phi0", "phi1", "theta_d"],
                                pixel_stride=2)
    assert fit["converged"], fit["termination"]
    for name in ("b", "H", "d_um", "mu"):
        assert abs(fit["params"][name] - truth[name]) < 3 * fit["standard_errors"][name], name
    doc = json.loads(fit["json"])
    assert doc["model"] == "huang2022" and doc["data"]["format"] == "arrays"
    assert doc["parameters"]["d_um"]["unit"] == "um"
    assert doc["parameters"]["theta_d"]["fixed"]
    assert doc["fit"]["observations"] == fit["observations"]
