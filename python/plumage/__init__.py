"""Plumage from Python: records as numpy arrays, the analytic feather models and the film optics.

    import plumage
    rec = plumage.read_record("results/rock_dove/brdf/simulation.h5")   # records.py
    model = plumage.models.Huang2022(d_um=0.55)                           # models.py
    f = model.eval(wi, wo, 550.0)                 # wi, wo (..., 3), 1/sr: help(model.eval)
    R = plumage.optics.thin_film_reflectance(0.59, wavelengths, theta_rad=0.3)  # optics.py
    plumage.run_study({"study": "calibration", ...}, out="results")       # studies.py

Conventions are the C++ ones: lengths in µm, wavelengths in nm, angles in radians, BRDF in 1/sr,
directions unit vectors in the patch frame (+z the patch normal, +x the barb axis) pointing away
from the patch. Built by scripts/run.sh for Debian's /usr/bin/python3, or by `pip install .` for any
CPython 3.11+ (numpy, h5py); README.md "Python", docs/python.md.
"""

from . import models, optics, studies
from .models import fit_filip2024, fit_huang2022
from .records import Measurement, Quantity, Record, RecordError, read_record
from .studies import build_geometry, run_study, study_kinds

__all__ = ["read_record", "Record", "Measurement", "Quantity", "RecordError", "models", "optics",
           "studies", "run_study", "build_geometry", "study_kinds", "fit_huang2022",
           "fit_filip2024"]
