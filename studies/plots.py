"""Plots for Plumage studies. Run by the plumage binary with Debian's /usr/bin/python3.

  plots.py spectra CSV PNG       reflectance spectra (Huang 2022 Fig. 5 style)
  plots.py chart H5 PNG          thin-film colour chart with axes (Huang 2022 Fig. 3 style)
  plots.py convergence CSV PNG   estimated and true error against wall time, log-log
  plots.py curves CSV PNG        BRDF against an angle: columns x, then name, name_err pairs
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


def convergence(csv_path, png_path):
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    series = [k for k in rows[0].keys() if k not in ("label", "wall_time_s")]
    labels = sorted(set(r["label"] for r in rows))
    for label in labels:
        sel = [r for r in rows if r["label"] == label]
        t = [float(r["wall_time_s"]) for r in sel]
        for key, style in zip(series, ("o-", "s--")):
            y = [float(r[key]) for r in sel]
            if all(v > 0 for v in y):
                ax.loglog(t, y, style, label=f"{label}: {key.replace('_', ' ')}")
    # 1/sqrt(t) reference through the first point of the first series
    first = [r for r in rows if r["label"] == labels[0]]
    t0, e0 = float(first[0]["wall_time_s"]), float(first[0][series[0]])
    tt = [float(r["wall_time_s"]) for r in first]
    ax.loglog(tt, [e0 * (t0 / x) ** 0.5 for x in tt], "k:", label="slope -1/2")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("relative RMS error")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)


def curves(csv_path, png_path):
    with open(csv_path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [[float(v) for v in r] for r in reader]
    x = [r[0] for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for i in range(1, len(header), 2):
        y = [r[i] for r in rows]
        err = [r[i + 1] for r in rows]
        ax.errorbar(x, y, yerr=err, fmt="o-" if i == 1 else "s--", ms=3, capsize=2, label=header[i])
    ax.set_xlabel(header[0])
    ax.set_ylabel("BRDF (1/sr)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png_path, dpi=120)


if __name__ == "__main__":
    kinds = {"spectra": spectra, "chart": chart, "convergence": convergence, "curves": curves}
    if len(sys.argv) != 4 or sys.argv[1] not in kinds:
        sys.exit("usage: plots.py " + "|".join(kinds) + " INPUT PNG")
    kinds[sys.argv[1]](sys.argv[2], sys.argv[3])
