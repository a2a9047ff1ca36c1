#!/usr/bin/python3
"""Huang et al. 2022's model against a simulated rock-dove scatterogram, and fitted to it.

Notebook-style: each `# %%` cell runs on its own in VS Code, Spyder or Jupyter (jupytext), or the
whole file as a script with Debian's python:

    scripts/run.sh run studies/rock_dove_quick.toml   # makes results/rock_dove_quick/ (~15 s)
    /usr/bin/python3 examples/huang_fit.py [RECORD] [OUT_DIR]

RECORD defaults to results/rock_dove_quick/fit/simulation.h5: the explicit barbules (keratin
film 0.59 µm) under a beam at θ_i = 20°, imaged by the virtual scatterometer. The figure goes to
OUT_DIR (default: the record's folder) as huang_fit.png.
"""

# %% Load the record: numpy arrays with units and standard errors
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")  # files only; remove in a notebook to see the figures inline
import matplotlib.pyplot as plt
import numpy as np

import plumage

path = pathlib.Path(sys.argv[1] if len(sys.argv) > 1
                    else "results/rock_dove_quick/fit/simulation.h5")
out_dir = pathlib.Path(sys.argv[2]) if len(sys.argv) > 2 else path.parent
if not path.exists():
    sys.exit(f"{path}: no record; make one with: scripts/run.sh run studies/rock_dove_quick.toml")
rec = plumage.read_record(path)
print(rec)
print("illumination:", rec.instrument["illumination"], "from", rec.instrument["beam_direction"])
print("wavelengths:", rec.wavelength_nm, rec.wavelength_nm.units)
print("image:", rec.image.value.shape, rec.image.units, "lobes:", list(rec.image.lobes))
print("measured by", rec.provenance["scatterer"], "seed", rec.provenance["seed"],
      "in", round(rec.provenance["wall_time_s"], 2), "s")

# %% The model with the published rock-dove parameters, by the fit's forward model
published = plumage.models.Huang2022()
print("published:", published.params)
model_image = plumage.models.huang2022_scatterogram(published, rec)

# %% Fit Huang's parameters to the simulation (C++ Levenberg–Marquardt, analysis/fits/huang2022_fit.h)
# Start from a film 7 % too thin; the arc's ends (phi0, phi1) are hidden under the neighbouring
# barbules at these parameters, so they cannot be fitted and are held.
start = dict(published.params, d_um=0.55)
fit = plumage.models.fit_huang2022(rec, start=start, fixed=["phi0", "phi1"])
print(f"fit: {fit['termination']}, reduced chi-square {fit['reduced_chi_square']:.2f} "
      f"over {fit['observations']} observations, {fit['wall_time_s']:.1f} s")
for name in fit["free_parameters"]:
    print(f"  {name:8s} {fit['params'][name]:+.5f} ± {fit['standard_errors'][name]:.5f}"
          f"   (published {published.params[name]:+.5f})")
fitted = plumage.models.Huang2022(**fit["params"])
fitted_image = plumage.models.huang2022_scatterogram(fitted, rec)

# %% Overlay: the cut through the plane of incidence (the image's middle row), per wavelength
rows = rec.image.value.shape[0]
row = rows // 2
theta_deg = np.degrees(np.arccos(rec.datasets["/image/directions"][row, :, 2]))
signed = np.where(rec.datasets["/image/directions"][row, :, 0] < 0, -theta_deg, theta_deg)
fig, axes = plt.subplots(1, len(rec.wavelength_nm), figsize=(4.2 * len(rec.wavelength_nm), 3.6),
                         sharey=True)
for k, (ax, lam) in enumerate(zip(np.atleast_1d(axes), rec.wavelength_nm)):
    ax.errorbar(signed, rec.image.value[row, :, k], yerr=rec.image.standard_error[row, :, k],
                fmt="o", ms=3, color="k", label="simulation ± σ")
    ax.plot(signed, model_image[row, :, k], "-", color="tab:blue", label="Huang, published")
    ax.plot(signed, fitted_image[row, :, k], "--", color="tab:red", label="Huang, fitted")
    ax.set_title(f"{lam:.0f} nm")
    ax.set_xlabel("view θ in the plane of incidence (deg, − towards −x)")
axes[0].set_ylabel(f"radiant intensity per incident power ({rec.image.units})")
axes[0].legend(fontsize=8)
fig.tight_layout()
figure = out_dir / "huang_fit.png"
fig.savefig(figure, dpi=120)
print("figure:", figure)

# %% How far apart, in standard errors, over the pixels with signal
signal = rec.image.value > 4 * rec.image.standard_error
for label, image in (("published", model_image), ("fitted", fitted_image)):
    z = (rec.image.value - image)[signal] / rec.image.standard_error[signal]
    print(f"{label:9s}: median |simulation − model| / σ = {np.median(np.abs(z)):.2f}")
