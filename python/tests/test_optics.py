"""plumage.optics: sim/optics over numpy arrays (python/optics_binding.cpp)."""

import numpy as np
import pytest

from plumage import optics


def airy_reference(n_film, d_um, lam_nm, cos_theta, pol):
    """Airy reflectance of a film in air, written out (Born & Wolf §7.6.1)."""
    sin_t = np.sqrt(1 - cos_theta**2)
    cos_f = np.sqrt(1 - (sin_t / n_film) ** 2)
    if pol == "s":
        r01 = (cos_theta - n_film * cos_f) / (cos_theta + n_film * cos_f)
    else:
        r01 = (n_film * cos_theta - cos_f) / (n_film * cos_theta + cos_f)
    r12 = -r01
    phase = np.exp(2j * (2 * np.pi / (lam_nm * 1e-3)) * n_film * d_um * cos_f)
    r = (r01 + r12 * phase) / (1 + r01 * r12 * phase)
    return np.abs(r) ** 2


def test_materials_are_the_published_dispersions():
    lam = np.array([400.0, 550.0, 700.0])
    np.testing.assert_allclose(optics.keratin(lam), 1.532 + 5890 / lam**2, rtol=1e-15)
    np.testing.assert_allclose(optics.melanin(lam),
                               1.648 + 23700 / lam**2 + 0.56j * np.exp(-lam / 270), rtol=1e-15)
    np.testing.assert_array_equal(optics.index("air", lam), np.ones(3))
    assert optics.index(1.5 + 0.1j, [500.0]) == pytest.approx(1.5 + 0.1j)
    with pytest.raises(ValueError, match="unknown material 'gold'"):
        optics.index("gold", lam)


@pytest.mark.parametrize("pol", ["s", "p"])
def test_thin_film_equals_airy_closed_form(pol):
    lam = np.linspace(380, 780, 81)[None, :]
    theta = np.radians(np.array([0.0, 20.0, 45.0, 70.0]))[:, None]
    r = optics.thin_film_reflectance(0.595, lam, theta, polarisation=pol)
    assert r.shape == (4, 81)
    reference = airy_reference(1.532 + 5890 / lam**2, 0.595, lam, np.cos(theta), pol)
    np.testing.assert_allclose(r, reference, rtol=1e-9, atol=1e-14)


def test_unpolarised_is_the_mean_and_energy_is_conserved():
    lam = np.linspace(400, 700, 31)
    theta = 0.6
    s = optics.thin_film(0.53, lam, theta, polarisation="s")
    p = optics.thin_film(0.53, lam, theta, polarisation="p")
    u = optics.thin_film(0.53, lam, theta)
    np.testing.assert_allclose(u.reflectance, 0.5 * (s.reflectance + p.reflectance), rtol=1e-12)
    np.testing.assert_allclose(u.reflectance + u.transmittance, 1.0, atol=1e-12)  # lossless
    # A keratin film absorbs nothing (A = 1 − R − T is the film's own); melanin below changes R.
    on_melanin = optics.thin_film(0.53, lam, theta, below="melanin")
    np.testing.assert_allclose(on_melanin.absorptance, 0.0, atol=1e-12)
    assert np.all(np.abs(on_melanin.reflectance - u.reflectance) > 1e-3)


def test_transfer_matrix_agrees_with_the_film_and_fresnel():
    lam = np.linspace(400, 700, 61)
    theta = np.radians(30.0)
    film = optics.thin_film(0.2, lam, theta, below="melanin")
    stack = optics.transfer_matrix([("keratin", 0.2)], lam, theta, substrate="melanin")
    for a, b in zip(film, stack):
        np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-12)
    bare = optics.transfer_matrix([], lam, 0.0, substrate=1.5)  # a bare interface
    np.testing.assert_allclose(bare.reflectance, 0.04, rtol=1e-12)
    thick = optics.transfer_matrix([("keratin", 50.0, "incoherent"), ("melanin", 0.1)], lam,
                                   theta)
    assert np.all(np.isfinite(thick.reflectance))


def test_thread_count_does_not_change_a_bit():
    lam = np.linspace(380, 780, 4001)
    layers = [("keratin", 0.3), ("melanin", 0.08), ("keratin", 0.3)]
    one = optics.transfer_matrix(layers, lam, 0.4, threads=1)
    two = optics.transfer_matrix(layers, lam, 0.4, threads=2)
    for a, b in zip(one, two):
        np.testing.assert_array_equal(a, b)


def test_invalid_input_raises_the_cpp_message():
    with pytest.raises(ValueError, match="element 1: .*thickness"):
        optics.thin_film_reflectance([0.5, -1.0], 500.0)
    with pytest.raises(ValueError, match="polarisation 'x'"):
        optics.thin_film(0.5, 500.0, polarisation="x")
    with pytest.raises(ValueError, match="incoherent"):
        optics.transfer_matrix([("keratin", 0.1, "partly")], 500.0)
