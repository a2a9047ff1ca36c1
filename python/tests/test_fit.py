"""plumage.models.fit_huang2022: the C++ Huang fit (analysis/fits/huang2022_fit.h) from a record."""

import numpy as np
import pytest

import plumage
from plumage import models

NAMES = ["b", "phi0", "phi1", "H", "d_um", "theta_d", "mu"]


def test_fit_reproduces_the_study_fit(rock_dove_results):
    """The rock-dove study fits its simulated scatterogram in C++ and records the result; the
    same fit from Python on the written record gives the same parameters and errors. Not to the
    bit: the record keeps @beam_direction as text with 9 decimals."""
    cpp = plumage.read_record(rock_dove_results / "fit/huang2022_fit.h5")
    start = dict(zip(NAMES, cpp.datasets["/fit/built_with"]))
    fit = models.fit_huang2022(rock_dove_results / "fit/simulation.h5", start=start,
                               fixed=["phi0", "phi1"], pixel_stride=3)  # the study's options
    assert fit["converged"] and fit["free_parameters"] == ["b", "H", "d_um", "theta_d", "mu"]
    np.testing.assert_allclose([fit["params"][n] for n in NAMES], cpp.datasets["/fit/values"],
                               rtol=1e-8)
    errors = [fit["standard_errors"][n] for n in NAMES]
    np.testing.assert_allclose(errors, cpp.datasets["/fit/standard_errors"], rtol=1e-6)
    assert fit["observations"] == cpp.attributes["/fit"]["observations"]
    assert fit["reduced_chi_square"] == pytest.approx(cpp.attributes["/fit"]["reduced_chi_square"],
                                                      rel=1e-8)
    assert fit["covariance"].shape == (5, 5)


def test_forward_model_image(rock_dove_results):
    rec = plumage.read_record(rock_dove_results / "fit/simulation.h5")
    image = models.huang2022_scatterogram(models.Huang2022(), rec, pixel_stride=3)
    assert image.shape == rec.image.value.shape
    outside = rec.datasets["/image/solid_angle_sr"] == 0
    assert np.all(image[~outside] >= 0) and np.all(image[outside] == 0)


def test_fit_errors(rock_dove_results):
    with pytest.raises(ValueError, match="goniometer record; the Huang fit needs an imaging"):
        models.fit_huang2022(rock_dove_results / "validation/model.h5")
    with pytest.raises(TypeError, match="unknown option 'stride'; valid options: .*pixel_stride"):
        models.fit_huang2022(rock_dove_results / "fit/simulation.h5", stride=2)
    with pytest.raises(ValueError, match="unknown parameter.*phi2|phi2"):
        models.fit_huang2022(rock_dove_results / "fit/simulation.h5", fixed=["phi2"])


def test_example_runs(rock_dove_results, tmp_path):
    """examples/huang_fit.py on a fresh record: it fits, overlays and writes its figure."""
    import os
    import subprocess
    import sys

    from conftest import SOURCE_DIR

    run = subprocess.run([sys.executable, str(SOURCE_DIR / "examples/huang_fit.py"),
                          str(rock_dove_results / "fit/simulation.h5"), str(tmp_path)],
                         capture_output=True, text=True, env=dict(os.environ))
    assert run.returncode == 0, run.stderr
    assert "d_um     +0.5" in run.stdout and (tmp_path / "huang_fit.png").stat().st_size > 10000
