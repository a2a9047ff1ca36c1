"""Plots for Plumage studies. Run by the plumage binary with Debian's /usr/bin/python3.

  plots.py spectra CSV PNG   reflectance spectra (Huang 2022 Fig. 5 style)
  plots.py chart H5 PNG      thin-film colour chart with axes (Huang 2022 Fig. 3 style)
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def spectra(csv_path, png_path):
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    wl = [float(r["wavelength_nm"]) for r in rows]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    for ax, d in zip(axes, ("530", "595")):
        r = [float(x[f"R_{d}nm"]) for x in rows]
        total = [float(x[f"R_plus_TRT_{d}nm"]) for x in rows]
        ax.plot(wl, total, color="tab:blue", label="R + TRT (with melanin background)")
        ax.plot(wl, r, color="tab:green", label="R (film only)")
        ax.set_title(f"keratin film {d} nm, normal incidence")
        ax.set_xlabel("wavelength (nm)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("reflectance")
    axes[0].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)


def chart(h5_path, png_path):
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        rgb = np.asarray(f["chart/srgb8"])
        thickness = np.asarray(f["chart/thickness_nm"])
        angle = np.asarray(f["chart/incidence_deg"])
    fig, ax = plt.subplots(figsize=(9, 4.2))
    ax.imshow(rgb, origin="lower", aspect="auto", interpolation="nearest",
              extent=(thickness[0], thickness[-1], angle[0], angle[-1]))
    for d in (530, 595):
        ax.axvline(d, color="white", lw=0.8, ls="--")
        ax.text(d, angle[-1] * 0.97, f"{d} nm", color="white", ha="center", va="top",
                fontsize=8, bbox=dict(facecolor="black", alpha=0.4, lw=0))
    ax.set_xlabel("keratin film thickness (nm)")
    ax.set_ylabel("incidence angle (deg)")
    ax.set_title("Thin keratin film in air, reflected colour under D65")
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)


if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[1] not in ("spectra", "chart"):
        sys.exit("usage: plots.py spectra|chart INPUT PNG")
    {"spectra": spectra, "chart": chart}[sys.argv[1]](sys.argv[2], sys.argv[3])
