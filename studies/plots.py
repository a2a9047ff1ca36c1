"""Plots for Plumage studies. Run by the plumage binary with Debian's /usr/bin/python3.

  plots.py spectra CSV PNG       reflectance spectra (Huang 2022 Fig. 5 style)
  plots.py chart H5 PNG          thin-film colour chart with axes (Huang 2022 Fig. 3 style)
  plots.py convergence CSV PNG   estimated and true error against wall time, log-log
  plots.py curves CSV PNG        BRDF against an angle: columns x, then name, name_err pairs
  plots.py brdf_wavelengths CSV PNG  a BRDF at many wavelengths (the curves CSV): curves at a
                                 few wavelengths beside a map of all, both on log scales
  plots.py contact_sheet CSV PNG rows of images: columns label, simulation, model (PNG paths
                                 relative to the CSV's folder), note
  plots.py sweep_error CSV PNG   model error against a swept parameter: x, error, noise floor, is_base
  plots.py energy_bars CSV PNG   largest energy per case and scatterer: label, energy, error, status
  plots.py luminance CSV PNG     in-plane L* per species (Filip 2024 Fig. 6a): x, then name, name error, name fit
  plots.py masking H5 PNG         masking study: fractions against angle (analytic, MC +- sigma) and z
  plots.py spongy_spectra H5 PNG spongy study: R(lambda) of every slab, Monte Carlo and single scattering
  plots.py spongy_map H5 PNG     spongy study: peak wavelength and colour over length scale x fraction
  plots.py spongy_angles H5 PNG  spongy study: the base slab's spectrum at several incidence angles
  plots.py scatterogram_comparison H5 PNG  simulation | model | signed difference (figure/ group)
  plots.py scatterogram H5 PNG   one scatterogram (the comparison's figure/ group) on hemisphere axes
  plots.py scatterogram_levels H5 PNG  scatterograms of one instrument by several scatterers:
                                 colour at one exposure, luminance on one log scale (figure/ group)
  plots.py fingerprints H5 PNG   Filip 2024 Fig. 7 fingerprints at one exposure, with log luminance
                                 and each panel's signed difference from the first
  plots.py btf_tiles H5 PNG      BTF images of a few geometries (Filip 2024 Fig. 9), one exposure
  plots.py geometry_preview H5 PNG  a cut through built geometry in um: phases, legend, scale bar
  plots.py wave_validity_map H5 PNG  PO vs GO relative L1 (%) over width x one parameter, 5 % contour
  plots.py level_spectra H5 PNG  R(lambda) of one scene by full wave (two grids), physical and ray optics
  plots.py fit_residuals H5 PNG  a fit's (model - data)/sigma per wavelength on the data's grid
  plots.py batch CSV PNG         every plot a CSV lists (columns kind, input, png; PNG unused)
"""
import csv
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def numeric_csv(csv_path):
    """The header and the rows (as floats) of a CSV whose every value is a number."""
    with open(csv_path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        rows = [[float(v) for v in r] for r in reader]
    return header, rows


def build_spectra(csv_path):
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
        ax.set_ylabel("reflectance")
        ax.grid(alpha=0.3)
    axes[0].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    return fig


def build_chart(h5_path):
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        rgb = np.asarray(f["chart/srgb8"])
        thickness = np.asarray(f["chart/thickness_nm"])
        angle = np.asarray(f["chart/incidence_deg"])
        exposure = float(f["chart"].attrs["exposure"]) if "exposure" in f["chart"].attrs else None
    fig, ax = plt.subplots(figsize=(9, 4.4))
    ax.imshow(rgb, origin="lower", aspect="auto", interpolation="nearest",
              extent=(thickness[0], thickness[-1], angle[0], angle[-1]))
    for d in (530, 595):
        ax.axvline(d, color="white", lw=0.8, ls="--")
        ax.text(d, angle[-1] * 0.97, f"{d} nm", color="white", ha="center", va="top",
                fontsize=8, bbox=dict(facecolor="black", alpha=0.4, lw=0))
    ax.set_xlabel("keratin film thickness (nm)")
    ax.set_ylabel("incidence angle (deg)")
    stated = "" if exposure is None else \
        f"\none exposure (×{exposure:.3g}): the chart's largest sRGB component → 1, none clipped"
    ax.set_title("Thin keratin film in air, reflected colour under D65" + stated, fontsize=11)
    fig.tight_layout()
    return fig


def _label_log_ticks(axis, low, high):
    """At least three labelled ticks on a logarithmic axis spanning [low, high]: decades when the
    span holds three, else 1-2-5, 1-2-3-5-7 or every integer mantissa, written as plain numbers
    (a span inside one decade otherwise shows a single 10^k label or none)."""
    import math

    from matplotlib.ticker import FixedLocator, NullFormatter, StrMethodFormatter

    ticks = []
    for mantissas in ((1,), (1, 2, 5), (1, 2, 3, 5, 7), tuple(range(1, 10)),
                      tuple(m / 2 for m in range(2, 20))):
        ticks = [m * 10.0 ** k for k in range(math.floor(math.log10(low)) - 1,
                                              math.ceil(math.log10(high)) + 1)
                 for m in mantissas if low <= m * 10.0 ** k <= high]
        if len(ticks) >= 3:
            break
    axis.set_major_locator(FixedLocator(ticks))
    axis.set_major_formatter(StrMethodFormatter("{x:g}"))
    axis.set_minor_formatter(NullFormatter())


def build_convergence(csv_path):
    """Error against wall time on log-log axes, at least three labelled ticks per axis, the
    legend beneath the axes so it covers no point."""
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    fig, ax = plt.subplots(figsize=(6.5, 5.6))
    series = [k for k in ("estimated_error", "true_error", "reference_floor") if k in rows[0]]
    labels = sorted(set(r["label"] for r in rows))
    xs, ys = [], []
    for label in labels:
        sel = [r for r in rows if r["label"] == label]
        t = [float(r["wall_time_s"]) for r in sel]
        for key, style in zip(series, ("o-", "s--", "^:")):
            y = [float(r[key]) for r in sel]
            if all(v > 0 for v in y):
                ax.loglog(t, y, style, label=f"{label}: {key.replace('_', ' ')}")
                xs += t
                ys += y
    # 1/sqrt(t) reference through the first point of the first series
    first = [r for r in rows if r["label"] == labels[0]]
    t0, e0 = float(first[0]["wall_time_s"]), float(first[0][series[0]])
    tt = [float(r["wall_time_s"]) for r in first]
    ax.loglog(tt, [e0 * (t0 / x) ** 0.5 for x in tt], "k:", label="slope -1/2")
    # Limits a little beyond the points (a factor, as the axes are logarithmic), then ticks.
    ax.set_xlim(min(xs) / 1.15, max(xs) * 1.15)
    ax.set_ylim(min(ys) / 1.3, max(ys) * 1.3)
    _label_log_ticks(ax.xaxis, *ax.get_xlim())
    _label_log_ticks(ax.yaxis, *ax.get_ylim())
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("relative RMS error")
    ax.set_title("Error against wall time (log-log)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=2)
    fig.tight_layout()
    return fig


def build_curves(csv_path):
    header, rows = numeric_csv(csv_path)
    x = [r[0] for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for i in range(1, len(header), 2):
        y = [r[i] for r in rows]
        err = [r[i + 1] for r in rows]
        ax.errorbar(x, y, yerr=err, fmt="o-" if i == 1 else "s--", ms=3, capsize=2, label=header[i])
    ax.set_xlabel(header[0])
    ax.set_ylabel("BRDF (1/sr)")
    ax.set_title(f"BRDF against {header[0]}")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def _wavelength_colour(nm):
    """An approximate display colour of a monochromatic wavelength (380-780 nm), darkened a
    little so that a yellow line stays visible on white."""
    stops = ((380, (0.4, 0.0, 0.6)), (440, (0.2, 0.0, 1.0)), (490, (0.0, 0.6, 0.9)),
             (510, (0.0, 0.7, 0.2)), (580, (0.8, 0.7, 0.0)), (645, (0.9, 0.1, 0.0)),
             (780, (0.5, 0.0, 0.0)))
    nm = min(max(nm, stops[0][0]), stops[-1][0])
    for (a, ca), (b, cb) in zip(stops, stops[1:]):
        if a <= nm <= b:
            w = (nm - a) / (b - a)
            return tuple((1 - w) * x + w * y for x, y in zip(ca, cb))
    return stops[-1][1]


def build_brdf_wavelengths(csv_path):
    """A measured BRDF at many wavelengths (columns x, then `λ nm` and `λ nm error` pairs):
    curves against x at no more than four wavelengths (log scale, error bars, each in its
    wavelength's colour) beside a map of every wavelength on one logarithmic colour scale; all
    wavelengths as curves in one panel would overlap beyond reading."""
    import numpy as np
    from matplotlib.colors import LogNorm

    header, rows = numeric_csv(csv_path)
    data = np.asarray(rows, dtype=float).reshape(len(rows), len(header))
    x = data[:, 0]
    names = header[1::2]
    values, errors = data[:, 1::2], data[:, 2::2]
    nm = [float(n.split()[0]) for n in names]
    shown = sorted(set(int(round(i)) for i in np.linspace(0, len(names) - 1, min(4, len(names)))))
    positive = values[values > 0]
    floor = float(positive.min()) if positive.size else 1.0
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.6),
                                      gridspec_kw={"width_ratios": (1.1, 1)})
    for i in shown:
        left.errorbar(x, values[:, i], yerr=errors[:, i], fmt="o-", ms=3, capsize=2,
                      color=_wavelength_colour(nm[i]), label=names[i])
    if positive.size == values.size:
        left.set_yscale("log")
        low, high = left.get_ylim()
        _label_log_ticks(left.yaxis, low, high)
    left.set_xlabel(header[0])
    left.set_ylabel("BRDF (1/sr)")
    left.set_title(f"BRDF against {header[0]}\nat {len(shown)} of {len(names)} wavelengths "
                   "(error bars: 1σ)", fontsize=10)
    left.grid(alpha=0.3, which="both")
    left.legend(fontsize=8, title="wavelength")
    image = right.imshow(np.clip(values.T, floor, None), origin="lower", aspect="auto",
                         interpolation="nearest", cmap="viridis",
                         norm=LogNorm(vmin=floor, vmax=max(float(values.max()), floor * 1.01)))
    right.set_xticks(range(len(x)), [f"{v:g}" for v in x], fontsize=8)
    right.set_yticks(range(len(nm)), [f"{v:g}" for v in nm], fontsize=8)
    right.set_xlabel(header[0])
    right.set_ylabel("wavelength (nm)")
    right.set_title(f"BRDF at every wavelength ({len(names)}), log scale", fontsize=10)
    bar = fig.colorbar(image, ax=right)
    bar.set_label("BRDF (1/sr)")
    fig.tight_layout()
    return fig


def build_contact_sheet(csv_path):
    import textwrap

    import matplotlib.image as mpimg

    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    fig, axes = plt.subplots(len(rows), 2, figsize=(5.2, 2.5 * len(rows)), squeeze=False)
    for row, (a, b) in zip(rows, axes):
        for ax, key, title in ((a, "simulation", "simulation"), (b, "model", "Huang model")):
            ax.set_xticks([])
            ax.set_yticks([])
            if row[key]:  # relative to the sheet's folder
                image = os.path.join(os.path.dirname(os.path.abspath(csv_path)), row[key])
                ax.imshow(mpimg.imread(image), interpolation="nearest")
            else:
                for side in ax.spines.values():
                    side.set_visible(False)
            if row is rows[0]:
                ax.set_title(title, fontsize=9)
        a.set_ylabel(row["label"], fontsize=9)
        note = row["note"] if row["simulation"] else "\n".join(textwrap.wrap(row["note"], 60))
        if row["simulation"]:
            b.set_xlabel(note, fontsize=8)
        else:
            a.text(0.02, 0.5, note, transform=a.transAxes, fontsize=7, va="center", ha="left", wrap=True)
    fig.tight_layout()
    return fig


def build_sweep_error(csv_path):
    header, rows = numeric_csv(csv_path)
    skipped = [r[0] for r in rows if r[1] != r[1]]  # NaN: the value was rejected
    rows = [r for r in rows if r[1] == r[1]]
    x = [r[0] for r in rows]
    fig, ax = plt.subplots(figsize=(6, 3.8))
    ax.plot(x, [r[1] for r in rows], "o-", label="model error e (simulation as reference)")
    ax.plot(x, [r[2] for r in rows], "s--", color="grey", ms=3, label="noise floor (perfect model)")
    if skipped:
        ax.plot(skipped, [0.0] * len(skipped), "x", color="tab:red", ms=9, mew=2, clip_on=False,
                label="skipped (geometry or model rejects it)")
    for r in rows:
        if r[3] > 0:
            ax.axvline(r[0], color="k", ls=":", lw=0.8, label="base value")
    ax.set_xlabel(header[0])
    ax.set_ylabel("power-weighted relative L1")
    ax.set_title(f"Model error against {header[0]}")
    ax.set_ylim(bottom=0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


def build_energy_bars(csv_path):
    with open(csv_path, newline="") as f:
        rows = list(csv.DictReader(f))
    colours = {"ok": "tab:blue", "by construction": "tab:orange", "violation": "tab:red"}
    fig, ax = plt.subplots(figsize=(8, 0.22 * len(rows) + 1.2))
    y = list(range(len(rows)))[::-1]
    ax.barh(y, [float(r["energy"]) for r in rows], xerr=[float(r["error"]) for r in rows],
            color=[colours.get(r["status"], "grey") for r in rows], height=0.7, capsize=2)
    ax.axvline(1.0, color="k", lw=1)
    ax.set_yticks(y)
    ax.set_yticklabels([r["label"] for r in rows], fontsize=6)
    ax.set_xlabel("largest energy, reflected + transmitted (error bars: 4 sigma or quadrature error)")
    ax.set_ylabel("case and scatterer")
    ax.set_title("Energy conservation: largest energy per case and scatterer")
    from matplotlib.patches import Patch

    ax.legend(handles=[Patch(color=c, label=s) for s, c in colours.items()], fontsize=7, loc="lower right")
    ax.grid(alpha=0.3, axis="x")
    fig.tight_layout()
    return fig


def build_luminance(csv_path):
    header, rows = numeric_csv(csv_path)
    x = [r[0] for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4.2))
    colours = {"parrot": "tab:blue", "rooster": "tab:green", "flamingo": "tab:pink", "stork": "0.45"}
    for i in range(1, len(header), 3):
        name = header[i]
        c = colours.get(name, None)
        ax.errorbar(x, [r[i] for r in rows], yerr=[r[i + 1] for r in rows], fmt="o-", ms=3, capsize=2,
                    color=c, label=name + " (simulation)")
        ax.plot(x, [r[i + 2] for r in rows], "--", color=c, lw=1, label=name + " (fitted Filip model)")
    # L* = 100: a white Lambertian standard; a highlight reflects more than it towards the view.
    ax.axhline(100.0, color="k", lw=0.6, ls="--")
    ax.text(x[0], 100.0, " white standard (L* = 100)", va="bottom", fontsize=7)
    for angle, text in ((-45, "specular"), (45, "retro")):
        ax.axvline(angle, color="k", lw=0.6, ls=":")
        ax.text(angle, ax.get_ylim()[1], text, ha="center", va="bottom", fontsize=8)
    ax.set_xlabel(header[0])
    ax.set_ylabel("CIE L* (D65)")
    ax.set_title("In-plane luminance across the barbs (Filip 2024 Fig. 6a)", pad=16)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    return fig


def build_masking(h5_path):
    """One row per configuration: barb, barbule and gap fractions against the in-plane angle
    (analytic lines, Monte Carlo points with +-sigma bars); the residuals z in sigma with the
    Sidak bound of the whole comparison; and |MC - analytic| on a log scale beside sigma and the
    deterministic bound of stratified sampling (studies/masking_study.h)."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        angles = np.asarray(f["angles_deg"])
        analytic = np.asarray(f["analytic"])
        mc = np.asarray(f["mc"])
        se = np.asarray(f["mc_standard_error"])
        z = np.asarray(f["z"])
        bound = np.asarray(f["stratified_bound"])
        names = f.attrs["configurations"]
        z_bound = float(f.attrs["z_bound"])
    names = (names.decode() if hasattr(names, "decode") else str(names)).split(",")
    colours = ("tab:brown", "tab:blue", "0.45")
    labels = ("barb", "barbule", "gap")
    fig, axes = plt.subplots(len(names), 3, figsize=(15, 2.6 * len(names) + 0.4), squeeze=False,
                             gridspec_kw={"width_ratios": (3, 2, 2)})
    zmax = max(1.15 * z_bound, 1.1 * float(np.nanmax(np.abs(z))))
    floor = 0.3 / max(1.0, float(np.nanmax(1.0 / se)))  # below one ray's worth: drawn at the axis
    for k, name in enumerate(names):
        left, middle, right = axes[k]
        for c in range(3):
            left.plot(angles, analytic[k, :, c], "-", color=colours[c], lw=1.2,
                      label=f"{labels[c]}: analytic")
            left.errorbar(angles, mc[k, :, c], yerr=se[k, :, c], fmt="o", ms=2.4, mfc="none",
                          mew=0.6, elinewidth=0.6, color=colours[c], label=f"{labels[c]}: MC +- sigma")
            middle.plot(angles, z[k, :, c], "o", ms=2.2, color=colours[c], label=labels[c])
            diff = np.maximum(np.abs(mc[k, :, c] - analytic[k, :, c]), floor)
            right.semilogy(angles, diff, "o", ms=2.2, color=colours[c], label=labels[c])
        right.semilogy(angles, se[k].max(axis=1), "-", color="tab:green", lw=0.8, label="largest sigma")
        right.semilogy(angles, bound[k], "--", color="tab:red", lw=0.8, label="stratified bound")
        left.set_ylim(-0.03, 1.03)
        left.set_ylabel("fraction")
        left.set_title(name, fontsize=9, loc="left")
        for sign in (-1, 1):
            middle.axhline(sign * z_bound, color="tab:red", ls="--", lw=0.8,
                           label="Sidak bound" if sign > 0 else None)
        middle.axhline(0.0, color="k", lw=0.5)
        middle.set_ylim(-zmax, zmax)
        middle.set_ylabel("z = (MC - analytic) / sigma", fontsize=8)
        middle.set_title(f"{name}: residuals in sigma", fontsize=9, loc="left")
        right.set_ylim(bottom=0.8 * floor)
        right.set_ylabel("|MC - analytic|", fontsize=8)
        right.set_title(f"{name}: |MC - analytic| and bounds", fontsize=9, loc="left")
        for ax in axes[k]:
            ax.grid(alpha=0.3)
        if k == 0:
            left.legend(fontsize=6, ncol=3, loc="upper center")
            middle.legend(fontsize=6, ncol=4, loc="lower center")
            right.legend(fontsize=6, ncol=3, loc="upper center")
    for ax in axes[-1]:
        ax.set_xlabel("in-plane view angle (deg from +z towards +y)")
    fig.tight_layout()
    return fig


def _spongy_records(h5_path):
    """The spongy study's record (studies/spongy_study.cpp): top-level datasets, the angle group
    (or None) and the slab thickness."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        d = {k: np.asarray(f[k]) for k in f if not isinstance(f[k], h5py.Group)}
        ang = {k: np.asarray(f["angles"][k]) for k in f["angles"]} if "angles" in f else None
        thick = float(f.attrs["slab_thickness_um"])
    return d, ang, thick


def _spongy_kind(h5_path):
    """What the record's second axis and medium are: (symbol, axis label, route's name, the other
    route's R [f][a][wavelength] or None). Records from before the sphere route: channel, Born."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        spheres = _text(f.attrs.get("morphology", "channel")) == "spheres"
        sphere_route = _text(f.attrs.get("medium_route", "born")) == "sphere"
        other = np.asarray(f["other_route/reflectance"]) if "other_route" in f else None
    names = ("sphere-route (Mie × S(q))", "first-Born")
    return ("a" if spheres else "Λ",
            "air-sphere radius a (nm)" if spheres else "channel length scale Λ (nm)",
            names[0] if sphere_route else names[1],
            (other, names[1] if sphere_route else names[0]) if other is not None else None)


def _spongy_baseline(h5_path):
    """The geometric-optics baseline (R, its standard error, slab thickness) or None."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        if "baseline" not in f:
            return None
        g = f["baseline"]
        return (np.asarray(g["reflectance"]), np.asarray(g["reflectance_standard_error"]),
                float(g.attrs["thickness_um"]))


def build_spongy_spectra(h5_path):
    """Reflectance spectra of every slab: Monte Carlo with a +-2 sigma band, the
    single-scattering closed form dotted, each curve's peak marked; the geometric-optics
    baseline of the base volume dashed grey."""
    d, _, thick = _spongy_records(h5_path)
    symbol, _, route, other = _spongy_kind(h5_path)
    wl, fs, ls = d["wavelength_nm"], d["keratin_fraction"], d["length_scale_um"]
    fig, ax = plt.subplots(figsize=(8, 6.2))
    for i, fr in enumerate(fs):
        for j, lam in enumerate(ls):
            r, e, s1 = d["reflectance"][i, j], d["reflectance_standard_error"][i, j], \
                d["single_scattering_reflectance"][i, j]
            line = ax.plot(wl, r, "-", lw=1.6,
                           label=f"f = {fr:.2f}, {symbol} = {lam * 1e3:.0f} nm")[0]
            if other is not None:
                ax.plot(wl, other[0][i, j], "-.", color=line.get_color(), lw=1.2)
            ax.fill_between(wl, r - 2 * e, r + 2 * e, color=line.get_color(), alpha=0.25, lw=0)
            ax.plot(wl, s1, ":", color=line.get_color(), lw=1.2)
            ax.plot([d["peak_wavelength_nm"][i, j]], [d["reflectance_at_peak"][i, j]], "v",
                    color=line.get_color(), ms=6)
    ax.plot([], [], "k-", label="Monte Carlo (band: ±2σ)")
    ax.plot([], [], "k:", label="single scattering (closed form)")
    if other is not None:
        ax.plot([], [], "k-.", label=f"Monte Carlo, {other[1]} medium (the other route)")
    base = _spongy_baseline(h5_path)
    if base is not None:
        r, e, t = base
        ax.plot(wl, r, "--", color="0.45", lw=1.6,
                label=f"geometric optics: f = {fs[0]:.2f}, {symbol} = {ls[0] * 1e3:.0f} nm volume "
                      f"as interfaces ({t:.1f} µm)")
        ax.fill_between(wl, r - 2 * e, r + 2 * e, color="0.45", alpha=0.2, lw=0)
    ax.set_ylim(0.0, 1.0)
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("reflectance at normal incidence")
    ax.set_title(f"Spongy keratin slabs ({thick:g} µm), {route} medium from the volume")
    ax.grid(alpha=0.3)
    # Beneath the axes: inside, every corner holds a curve.
    ax.legend(fontsize=8, ncol=2, loc="upper center", bbox_to_anchor=(0.5, -0.13))
    fig.tight_layout()
    return fig


def build_spongy_map(h5_path):
    """Peak wavelength (Monte Carlo, single scattering, 2 n_eff Lambda) and colour of each slab
    over the length scale x keratin fraction grid."""
    import numpy as np

    d, _, _ = _spongy_records(h5_path)
    _, axis_label, _, _ = _spongy_kind(h5_path)
    fs, ls = d["keratin_fraction"], d["length_scale_um"]
    # The map's axes in ascending order (the lists start with the base case).
    fi, li = np.argsort(fs), np.argsort(ls)
    for k in ("peak_wavelength_nm", "peak_wavelength_sigma_nm", "bragg_wavelength_nm",
              "single_scattering_peak_wavelength_nm",
              "peak_at_spectrum_edge", "hue_deg", "luminance_Y", "srgb8"):
        d[k] = d[k][fi][:, li]
    fs, ls = fs[fi], ls[li]
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6))
    peak = d["peak_wavelength_nm"]
    ax = axes[0]
    # Coloured by the single-scattering peak: the Monte Carlo peak often sits at the spectrum's
    # edge, where a colour scale would say nothing; all three numbers are written in each cell.
    im = ax.imshow(d["single_scattering_peak_wavelength_nm"], origin="lower", cmap="viridis",
                   aspect="auto")
    for i in range(len(fs)):
        for j in range(len(ls)):
            edge = d["peak_at_spectrum_edge"][i, j] > 0
            where = f"≤ {peak[i, j]:.0f} (edge)" if edge else \
                f"{peak[i, j]:.0f} ± {d['peak_wavelength_sigma_nm'][i, j]:.0f}"
            ax.text(j, i, f"MC {where}\n"
                    f"single {d['single_scattering_peak_wavelength_nm'][i, j]:.0f}\n"
                    f"2 n_eff Λ {d['bragg_wavelength_nm'][i, j]:.0f}", ha="center",
                    va="center", fontsize=8, color="white",
                    bbox=dict(facecolor="black", alpha=0.45, lw=0))
    ax.set_xticks(range(len(ls)), [f"{v * 1e3:.0f}" for v in ls])
    ax.set_yticks(range(len(fs)), [f"{v:.2f}" for v in fs])
    ax.set_xlabel(axis_label)
    ax.set_ylabel("keratin fraction f")
    ax.set_title("peak λ of R (nm): Monte Carlo, single scattering, 2 n_eff Λ", fontsize=10)
    fig.colorbar(im, ax=ax, label="single-scattering peak wavelength (nm)")
    ax = axes[1]
    ax.imshow(d["srgb8"].astype(np.uint8), origin="lower", aspect="auto")
    for i in range(len(fs)):
        for j in range(len(ls)):
            ax.text(j, i, f"hue {d['hue_deg'][i, j]:.0f}°\nY {d['luminance_Y'][i, j]:.3f}",
                    ha="center", va="center", fontsize=8, color="white",
                    bbox=dict(facecolor="black", alpha=0.45, lw=0))
    ax.set_xticks(range(len(ls)), [f"{v * 1e3:.0f}" for v in ls])
    ax.set_yticks(range(len(fs)), [f"{v:.2f}" for v in fs])
    ax.set_xlabel(axis_label)
    ax.set_ylabel("keratin fraction f")
    ax.set_title("colour of each slab (sRGB, D65)")
    fig.tight_layout()
    return fig


def build_spongy_angles(h5_path):
    """The base slab's spectrum at several incidence angles."""
    d, ang, _ = _spongy_records(h5_path)
    wl = d["wavelength_nm"]
    base_f, base_l = d["keratin_fraction"][0], d["length_scale_um"][0]
    symbol = _spongy_kind(h5_path)[0]
    if ang is None:
        return None
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for a, deg in enumerate(ang["incidence_deg"]):
        r, e = ang["reflectance"][a], ang["reflectance_standard_error"][a]
        p, sp = ang["peak_wavelength_nm"][a], ang["peak_wavelength_sigma_nm"][a]
        at_edge = p <= wl[0] or p >= wl[-1]
        label = f"{deg:g}° (peak at the {p:.0f}-nm edge)" if at_edge else \
            f"{deg:g}° (peak {p:.0f} ± {sp:.0f} nm)"
        line = ax.plot(wl, r, lw=1.6, label=label)[0]
        ax.fill_between(wl, r - 2 * e, r + 2 * e, color=line.get_color(), alpha=0.25, lw=0)
        ax.plot(wl, ang["single_scattering_reflectance"][a], ":", color=line.get_color(), lw=1.2)
    ax.plot([], [], "k:", label="single scattering (closed form)")
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("reflectance (all upward directions)")
    ax.set_title(f"Angle dependence, f = {base_f:.2f}, {symbol} = {base_l * 1e3:.0f} nm "
                 "(band: ±2σ)")
    ax.grid(alpha=0.3)
    ax.legend(title="incidence", fontsize=8)
    fig.tight_layout()
    return fig


# ---- Instrument figures. The C++ studies write what these draw (studies/figure_data.h):
# display sRGB at one stated exposure, luminance in 1/sr, angles in degrees; Python draws.

def _text(value):
    """An HDF5 string attribute as str."""
    return value.decode() if isinstance(value, bytes) else str(value)


def _hemisphere_frame(ax, dark):
    """Axes of an azimuthal equidistant map in degrees (x = theta cos phi, y = theta sin phi):
    theta rings at 30, 60, 90 deg with labels, azimuth ticks on the rim, the barb axis arrow."""
    import numpy as np

    t = np.linspace(0.0, 2.0 * np.pi, 361)
    ring_colour, box = ("0.8", "black") if dark else ("0.3", "white")
    for ring in (30, 60, 90):
        ax.plot(ring * np.cos(t), ring * np.sin(t), color=ring_colour if ring < 90 else "k",
                lw=0.6 if ring < 90 else 0.8, ls="--" if ring < 90 else "-")
        a = np.radians(125.0)
        r = ring - 6 if ring == 90 else ring
        ax.text(r * np.cos(a), r * np.sin(a), f"ϑ {ring}°", color="white" if dark else "k",
                fontsize=7, ha="center", va="center",
                bbox=dict(facecolor=box, alpha=0.55, lw=0, pad=0.8))
    for phi in range(0, 360, 30):
        a = np.radians(phi)
        ax.plot([90 * np.cos(a), 96 * np.cos(a)], [90 * np.sin(a), 96 * np.sin(a)], color="k",
                lw=0.8)
        if phi % 90 == 0:
            ax.text(104 * np.cos(a), 104 * np.sin(a), f"φ {phi}°", fontsize=7, ha="center",
                    va="center")
    ax.annotate("", xy=(45, -112), xytext=(-45, -112),
                arrowprops=dict(arrowstyle="->", lw=1.2, color="k"), annotation_clip=False)
    ax.text(0, -118, "barb axis (+x, φ = 0°)", ha="center", va="top", fontsize=7)
    ax.set_xlim(-122, 122)
    ax.set_ylim(-126, 114)
    ax.set_aspect("equal")
    ax.set_xticks([-90, -60, -30, 0, 30, 60, 90])
    ax.set_yticks([-90, -60, -30, 0, 30, 60, 90])
    ax.tick_params(labelsize=6)
    ax.set_xlabel("ϑ cos φ (deg)", fontsize=8)
    ax.set_ylabel("ϑ sin φ (deg)", fontsize=8)
    for side in ax.spines.values():
        side.set_visible(False)


def _clip_to_disc(ax, image):
    """Clips a hemisphere image to the disc ϑ <= 90°: a rim pixel's centre lies inside the disc
    but its square reaches past it, and nothing is measured there."""
    from matplotlib.patches import Circle

    image.set_clip_path(Circle((0.0, 0.0), 90.0, transform=ax.transData))


def build_scatterogram(h5_path):
    """One scatterogram (the `figure/` group of build_scatterogram_comparison's input, its
    simulation image) on the hemisphere's axes, with its exposure stated."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        g = f["figure"]
        rgb = np.asarray(g["simulation_srgb"], dtype=float)
        theta = np.asarray(g["theta_deg"], dtype=float)
        white = float(g.attrs["white_luminance_per_sr"])
        title = _text(g.attrs.get("title", ""))
    inside = np.isfinite(theta)
    fig, ax = plt.subplots(figsize=(6.2, 6.4))
    rgba = np.concatenate([np.clip(rgb, 0, 1), inside[..., None].astype(float)], axis=2)
    image = ax.imshow(rgba, extent=(-90.0, 90.0, -90.0, 90.0), origin="upper",
                      interpolation="nearest")
    _clip_to_disc(ax, image)
    _hemisphere_frame(ax, True)
    ax.set_title(f"Scatterogram, {title}\nradiant intensity per unit incident power under D65;\n"
                 f"white = luminance {white:.3g} 1/sr", fontsize=9)
    fig.tight_layout()
    return fig


def build_scatterogram_comparison(h5_path):
    """Simulation | Huang model at one exposure | signed luminance difference (diverging map
    symmetric about 0, scaled to its own range, colour bar in 1/sr)."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        g = f["figure"]
        sim = np.asarray(g["simulation_srgb"], dtype=float)
        mod = np.asarray(g["model_srgb"], dtype=float)
        diff = np.asarray(g["difference_luminance"], dtype=float)
        theta = np.asarray(g["theta_deg"], dtype=float)
        white = float(g.attrs["white_luminance_per_sr"])
        title = _text(g.attrs.get("title", ""))
        errors = np.asarray(f["relative_error"]) if "relative_error" in f else None
    inside = np.isfinite(theta)
    extent = (-90.0, 90.0, -90.0, 90.0)  # pixel edges: the disc's rim is theta = 90 deg
    fig, axes = plt.subplots(1, 4, figsize=(15, 5.4),
                             gridspec_kw={"width_ratios": (1, 1, 1, 0.045)})
    cax = axes[3]
    for ax, rgb, name in ((axes[0], sim, "simulation"), (axes[1], mod, "Huang 2022 model")):
        rgba = np.concatenate([np.clip(rgb, 0, 1), inside[..., None].astype(float)], axis=2)
        _clip_to_disc(ax, ax.imshow(rgba, extent=extent, origin="upper", interpolation="nearest"))
        _hemisphere_frame(ax, True)
        ax.set_title(name, fontsize=10)
    ax = axes[2]
    lim = float(np.nanmax(np.abs(diff))) if np.any(np.isfinite(diff)) else 0.0
    lim = lim if lim > 0 else 1.0
    im = ax.imshow(np.ma.masked_invalid(diff), extent=extent, origin="upper",
                   interpolation="nearest", cmap="RdBu_r", vmin=-lim, vmax=lim)
    _clip_to_disc(ax, im)
    _hemisphere_frame(ax, False)
    err = f" (relative L1 {errors[0]:.3f})" if errors is not None and len(errors) else ""
    ax.set_title("simulation − model" + err, fontsize=10)
    bar = fig.colorbar(im, cax=cax)
    bar.set_label("luminance difference Y_sim − Y_model (1/sr)", fontsize=8)
    bar.ax.tick_params(labelsize=7)
    fig.suptitle(f"Scatterograms, {title}: radiant intensity per unit incident power under D65; "
                 f"one exposure for both, white = luminance {white:.3g} 1/sr", fontsize=10)
    fig.tight_layout()
    return fig


def build_scatterogram_levels(h5_path):
    """Scatterograms of one instrument by several scatterers (figure/panel<k>/): colour at one
    exposure for every panel (top row) and luminance on one logarithmic scale with a colour bar
    (bottom row), each on the hemisphere's axes."""
    import h5py
    import numpy as np
    from matplotlib.colors import LogNorm

    with h5py.File(h5_path, "r") as f:
        g = f["figure"]
        count = int(g.attrs["panels"])
        panels = [(np.asarray(g[f"panel{k}/srgb"], dtype=float),
                   np.asarray(g[f"panel{k}/luminance"], dtype=float),
                   _text(g[f"panel{k}"].attrs["title"]),
                   float(g[f"panel{k}"].attrs["peak_luminance_per_sr"])) for k in range(count)]
        theta = np.asarray(g["theta_deg"], dtype=float)
        white = float(g.attrs["white_luminance_per_sr"])
        title = _text(g.attrs.get("title", ""))
        note = _text(g.attrs.get("note", ""))
    inside = np.isfinite(theta)
    extent = (-90.0, 90.0, -90.0, 90.0)
    fig, axes = plt.subplots(2, count + 1, figsize=(5.0 * count + 0.6, 10.6), squeeze=False,
                             gridspec_kw={"width_ratios": (1,) * count + (0.045,)})
    axes[0, -1].set_visible(False)
    top = max(white, 1e-300)
    norm = LogNorm(vmin=top * 1e-4, vmax=top)
    image = None
    for k, (rgb, y, name, peak) in enumerate(panels):
        ax = axes[0, k]
        rgba = np.concatenate([np.clip(rgb, 0, 1), inside[..., None].astype(float)], axis=2)
        _clip_to_disc(ax, ax.imshow(rgba, extent=extent, origin="upper", interpolation="nearest"))
        _hemisphere_frame(ax, True)
        ax.set_title(f"{name}\npeak {peak:.3g} 1/sr ({peak / top:.2f} of white)", fontsize=9)
        ax = axes[1, k]
        image = ax.imshow(np.ma.masked_invalid(np.clip(y, top * 1e-4, None)), norm=norm,
                          cmap="viridis", extent=extent, origin="upper", interpolation="nearest")
        _clip_to_disc(ax, image)
        _hemisphere_frame(ax, True)
        ax.set_title(f"{name}: luminance (log scale)", fontsize=9)
    bar = fig.colorbar(image, cax=axes[1, -1])
    bar.set_label("luminance Y of the radiant intensity per unit incident power (1/sr)",
                  fontsize=8)
    bar.ax.tick_params(labelsize=7)
    fig.suptitle(f"Scatterograms, {title}: radiant intensity per unit incident power under D65; "
                 f"one exposure for every panel, white = luminance {white:.3g} 1/sr"
                 + (f"\n{note}" if note else ""), fontsize=10)
    fig.tight_layout()
    return fig


def _ring_ticks(angles):
    """Each polar-angle ring of a direction list: the first indices (where a separator goes),
    the tick positions (the ring's middle) and the labels."""
    starts, labels = [], []
    for i, t in enumerate(angles[:, 0]):
        ring = round(float(t))
        if not labels or labels[-1] != f"{ring}°":
            starts.append(i)
            labels.append(f"{ring}°")
    ends = starts[1:] + [len(angles)]
    return starts, [0.5 * (a + b - 1) for a, b in zip(starts, ends)], labels


def _fingerprint_axes(ax, views, lights):
    """Ring separators, ring ticks and axis labels of one fingerprint panel."""
    xs, xt, xl = _ring_ticks(views)
    ys, yt, yl = _ring_ticks(lights)
    for t in xs[1:]:
        ax.axvline(t - 0.5, color="0.5", lw=0.4, alpha=0.6)
    for t in ys[1:]:
        ax.axhline(t - 0.5, color="0.5", lw=0.4, alpha=0.6)
    ax.set_xticks(xt, xl, fontsize=7)
    ax.set_yticks(yt, yl, fontsize=7)
    ax.set_xlabel("view θ_o ring (φ_o 0°…330° within each)", fontsize=8)
    ax.set_ylabel("light θ_i ring (φ_i 0°…330° within each)", fontsize=8)


def _fingerprint_differences(fig, axes, panels, white):
    """Bottom row: each panel's luminance minus the first's (the simulation's), under it, on
    one diverging scale symmetric about 0 shared by every difference panel. Symmetric log,
    linear within a thousandth of white: the BRDF spans decades, and a linear scale would show
    only the specular peak's difference."""
    import numpy as np
    from matplotlib.colors import SymLogNorm

    reference, reference_name = panels[0][1], panels[0][2]
    diffs = [reference - y for _, y, _, _ in panels[1:]]
    lim = max(float(np.nanmax(np.abs(d))) if np.any(np.isfinite(d)) else 0.0 for d in diffs)
    linear = max(white, 1e-300) * 1e-3
    lim = max(lim, 10.0 * linear)
    norm = SymLogNorm(linthresh=linear, vmin=-lim, vmax=lim, base=10)
    axes[2, 0].set_visible(False)
    image = None
    for k, d in enumerate(diffs, start=1):
        ax = axes[2, k]
        image = ax.imshow(d, norm=norm, cmap="RdBu_r", interpolation="nearest", aspect="auto")
        ax.set_title(f"{reference_name} − {panels[k][2]}\n(red: {reference_name} brighter)",
                     fontsize=9)
    box = axes[2, -1].get_position()
    cax = fig.add_axes([0.9, box.y0, 0.015, box.height])
    bar = fig.colorbar(image, cax=cax)
    bar.set_label(f"luminance difference (1/sr), symmetric log,\nlinear within ±{linear:.2g}",
                  fontsize=8)


def build_fingerprints(h5_path):
    """Filip 2024 Fig. 7 fingerprints: colour at one exposure for every panel (top row), the
    luminance on one logarithmic scale with a colour bar (middle row) and, when there is more
    than one panel, each one's signed luminance difference from the first (bottom row)."""
    import h5py
    import numpy as np
    from matplotlib.colors import LogNorm

    with h5py.File(h5_path, "r") as f:
        count = int(f.attrs["panels"])
        panels = [(np.asarray(f[f"panel{k}/srgb"], dtype=float),
                   np.asarray(f[f"panel{k}/luminance"], dtype=float),
                   _text(f[f"panel{k}"].attrs["title"]),
                   float(f[f"panel{k}"].attrs["peak_luminance_per_sr"])) for k in range(count)]
        lights = np.asarray(f["light_angles_deg"])
        views = np.asarray(f["view_angles_deg"])
        white = float(f.attrs["white_luminance_per_sr"])
        title = _text(f.attrs["title"])
    rows = 3 if count > 1 else 2
    fig, axes = plt.subplots(rows, count, figsize=(4.3 * count + 0.8, 4.3 * rows),
                             squeeze=False)
    top = max(white, 1e-300)
    norm = LogNorm(vmin=top * 1e-4, vmax=top)
    image = None
    for k, (rgb, y, name, peak) in enumerate(panels):
        ax = axes[0, k]
        ax.imshow(np.clip(rgb, 0, 1), interpolation="nearest", aspect="auto")
        ax.set_title(f"{name}\npeak {peak:.3g} 1/sr ({peak / top:.2f} of white)", fontsize=9)
        ax = axes[1, k]
        image = ax.imshow(np.clip(y, top * 1e-4, None), norm=norm, cmap="viridis",
                          interpolation="nearest", aspect="auto")
        ax.set_title(f"{name}: luminance (log scale)", fontsize=9)
    fig.suptitle(f"{title}\nrows: light directions, columns: view directions; colour: one "
                 f"exposure for all panels, white = luminance {white:.3g} 1/sr", fontsize=10)
    height = 4.3 * rows  # inches: 1.2 for the suptitle, 0.6 for the bottom labels
    fig.subplots_adjust(left=0.07, right=0.88, top=1.0 - 1.2 / height, bottom=0.6 / height,
                        hspace=0.42, wspace=0.3)
    box = axes[1, -1].get_position()
    cax = fig.add_axes([0.9, box.y0, 0.015, box.height])
    bar = fig.colorbar(image, cax=cax)
    bar.set_label("luminance Y of the BRDF (1/sr)", fontsize=8)
    if count > 1:
        _fingerprint_differences(fig, axes, panels, white)
    for ax in axes.flat:
        if ax.get_visible():
            _fingerprint_axes(ax, views, lights)
    return fig


def build_btf_tiles(h5_path):
    """Filip 2024 Fig. 9 analogue: BTF images of the patch, one exposure for all tiles, each
    titled with its light and view angles; axes in micrometres."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        rgb = np.asarray(f["srgb"], dtype=float)
        angles = np.asarray(f["angles_deg"])
        size = float(f.attrs["patch_size_um"])
        pixels = int(f.attrs["pixels"])
        white = float(f.attrs["white_luminance_per_sr"])
        title = _text(f.attrs["title"])
    tiles = rgb.shape[0]
    cols = min(6, tiles)
    rows = (tiles + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(2.1 * cols + 0.4, 2.35 * rows + 0.9),
                             squeeze=False, sharex=True, sharey=True)
    h = 0.5 * size
    for k, ax in enumerate(axes.flat):
        if k >= tiles:
            ax.set_visible(False)
            continue
        ax.imshow(np.clip(rgb[k], 0, 1), extent=(-h, h, -h, h), origin="upper",
                  interpolation="nearest")
        ti, pi, to, po = angles[k]
        ax.set_title(f"θi {ti:.0f}° φi {pi % 360:.0f}°\nθo {to:.0f}° φo {po % 360:.0f}°",
                     fontsize=7)
        ax.tick_params(labelsize=6)
        if k % cols == 0:
            ax.set_ylabel("y (µm)", fontsize=7)
        if k // cols == rows - 1:
            ax.set_xlabel("x (µm)", fontsize=7)
    fig.suptitle(f"{title}: {pixels} × {pixels} pixels over {size:.0f} µm; one exposure for all "
                 f"tiles, white = luminance {white:.3g} 1/sr", fontsize=9)
    fig.subplots_adjust(left=0.06, right=0.99, top=0.82, bottom=0.1, wspace=0.08, hspace=0.42)
    return fig


def _loops(segments, tolerance):
    """Chains 2D segments [n, 4] into polylines; returns (closed loops, open chains)."""
    from collections import defaultdict

    def key(x, y):
        return (round(x / tolerance), round(y / tolerance))

    ends = defaultdict(list)
    for i, (x0, y0, x1, y1) in enumerate(segments):
        ends[key(x0, y0)].append(i)
        ends[key(x1, y1)].append(i)
    used = [False] * len(segments)
    closed, chains = [], []
    for start in range(len(segments)):
        if used[start]:
            continue
        used[start] = True
        x0, y0, x1, y1 = segments[start]
        pts = [(x0, y0), (x1, y1)]
        for forward in (True, False):
            while True:
                tip = pts[-1] if forward else pts[0]
                nxt = None
                for j in ends[key(*tip)]:
                    if not used[j]:
                        nxt = j
                        break
                if nxt is None:
                    break
                used[nxt] = True
                a = (segments[nxt][0], segments[nxt][1])
                b = (segments[nxt][2], segments[nxt][3])
                other = b if key(*a) == key(*tip) else a
                if forward:
                    pts.append(other)
                else:
                    pts.insert(0, other)
        if len(pts) > 3 and key(*pts[0]) == key(*pts[-1]):
            closed.append(pts[:-1])
        else:
            chains.append(pts)
    return closed, chains


def _read_preview(h5_path):
    """The preview record: phase names, colours, fill flags, caption, axis labels, cut segments
    with their phase, and polygons (vertices, phase)."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        d = {
            "names": _text(f.attrs["phase_names"]).split("|"),
            "colours": _text(f.attrs["phase_colours"]).split("|"),
            "filled": [c == "1" for c in _text(f.attrs["phase_filled"]).split("|")],
            "caption": _text(f.attrs["caption"]),
            "labels": (_text(f.attrs["x_label"]), _text(f.attrs["y_label"])),
            "segments": np.asarray(f["segments"]).reshape(-1, 4) if "segments" in f
            else np.zeros((0, 4)),
            "segment_phase": np.asarray(f["segment_phase"]).astype(int) if "segments" in f else [],
            "polygons": [],
        }
        if "polygon_vertices" in f:
            vertices = np.asarray(f["polygon_vertices"]).reshape(-1, 2)
            offsets = np.asarray(f["polygon_offsets"]).astype(int)
            phase = np.asarray(f["polygon_phase"]).astype(int)
            d["polygons"] = [(vertices[offsets[i]:offsets[i + 1]], phase[i])
                             for i in range(len(phase))]
    return d


def _fill_nested_loops(ax, closed, colour):
    """Even-odd fill of closed outlines: a loop inside an even number of others is the phase,
    inside an odd number a hole (left white)."""
    from matplotlib.patches import Polygon
    from matplotlib.path import Path
    import numpy as np

    paths = [Path(np.array(loop + [loop[0]])) for loop in closed]
    for i, loop in enumerate(closed):
        depth = sum(1 for j, p in enumerate(paths) if j != i and p.contains_point(loop[0]))
        ax.add_patch(Polygon(loop, closed=True, facecolor=colour if depth % 2 == 0 else "white",
                             lw=0))


def _add_scale_bar(ax, width):
    """A round-numbered scale bar about a quarter of the width, right of the axes."""
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    nice = [0.01, 0.02, 0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50, 100, 200, 500, 1000]
    bar = max([n for n in nice if n <= 0.25 * width] or [nice[0]])
    label = f"{bar * 1000:.0f} nm" if bar < 1 else f"{bar:g} µm"
    ax.add_artist(AnchoredSizeBar(ax.transData, bar, label, "lower left", pad=0.4, sep=3,
                                  frameon=False, size_vertical=0, bbox_to_anchor=(1.02, 0.0),
                                  bbox_transform=ax.transAxes, borderpad=0.0,
                                  fontproperties={"size": 8}))


def build_geometry_preview(h5_path):
    """A cut through the built geometry, in micrometres: filled phases (polygons, or the closed
    outlines of a cut, filled by nesting: keratin inside, holes blank), the outlines, a legend,
    a scale bar and the caption as title."""
    import numpy as np
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch, Polygon

    d = _read_preview(h5_path)
    names, colours, filled = d["names"], d["colours"], d["filled"]
    segments, seg_phase, polys = d["segments"], d["segment_phase"], d["polygons"]
    points = [segments[:, :2], segments[:, 2:]] + [p for p, _ in polys]
    allp = np.concatenate([p for p in points if len(p)]) if any(len(p) for p in points) else \
        np.zeros((1, 2))
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    span = np.maximum(hi - lo, 1e-9)
    aspect = span[1] / span[0]
    plot_width = 7.5  # inches of the axes; the legend and the scale bar sit to the right
    fig, ax = plt.subplots(figsize=(plot_width + 3.3, min(max(plot_width * aspect + 1.5, 2.6), 10.5)))
    for pts, ph in polys:
        ax.add_patch(Polygon(pts, closed=True, facecolor=colours[ph] if filled[ph] else "none",
                             edgecolor="k", lw=0.4))
    for ph in range(len(names)):
        sel = segments[np.asarray(seg_phase) == ph] if len(segments) else segments
        if not len(sel):
            continue
        closed, chains = _loops(sel, 1e-6 * float(np.max(span)))
        if filled[ph] and closed:
            _fill_nested_loops(ax, closed, colours[ph])
        edge = "k" if filled[ph] else colours[ph]
        for line in closed:
            line = np.array(line + [line[0]])
            ax.plot(line[:, 0], line[:, 1], color=edge, lw=0.7)
        for line in chains:
            line = np.array(line)
            ax.plot(line[:, 0], line[:, 1], color=edge, lw=0.9)
    ax.set_aspect("equal")
    pad = 0.03 * span.max()
    ax.set_xlim(lo[0] - pad, hi[0] + pad)
    ax.set_ylim(lo[1] - pad, hi[1] + pad)
    ax.set_xlabel(d["labels"][0])
    ax.set_ylabel(d["labels"][1])
    ax.set_title(d["caption"], fontsize=10)
    handles = [Patch(facecolor=colours[i], edgecolor="k", lw=0.4, label=n) if filled[i] else
               Line2D([], [], color=colours[i], lw=1.4, label=n) for i, n in enumerate(names)]
    ax.legend(handles=handles, fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    _add_scale_bar(ax, span[0])
    fig.tight_layout()
    return fig


def build_fit_residuals(h5_path):
    """A fit's residual map (studies/fit_command.h): one panel per wavelength of (model - data)/σ
    on the data's grid, one diverging colour scale for all panels, symmetric about 0."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        z = np.asarray(f["residual"])
        a = {k: _text(v) for k, v in f.attrs.items()}
    titles = a["panel_titles"].split("|")
    extent = [float(v) for v in a["extent"].split()]
    finite = z[np.isfinite(z)]
    limit = max(3.0, float(np.max(np.abs(finite)))) if finite.size else 3.0
    n = len(titles)
    cols = min(n, 3)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols + 1.2, 3.9 * rows + 0.6),
                             squeeze=False)
    image = None
    for i, ax in enumerate(axes.flat):
        if i >= n:
            ax.set_visible(False)
            continue
        image = ax.imshow(np.ma.masked_invalid(z[i]), cmap="RdBu_r", vmin=-limit, vmax=limit,
                          extent=extent, origin="upper", interpolation="nearest",
                          aspect="equal" if a.get("aspect") == "equal" else "auto")
        ax.set_facecolor("#dddddd")
        ax.set_title(titles[i], fontsize=9)
        ax.set_xlabel(a["x_label"], fontsize=8)
        ax.set_ylabel(a["y_label"], fontsize=8)
        ax.tick_params(labelsize=7)
    fig.suptitle(a["title"] + "\n(grey: no observation)", fontsize=10)
    bar = fig.colorbar(image, ax=axes.ravel().tolist(), shrink=0.85)
    bar.set_label(a["colour_label"])
    return fig


# ---- The command line: every kind is a builder (input -> Figure, or None when there is
# nothing to draw) and a resolution; the CLI saves the figure. Tests build the figures and
# query them (tests/studies/plots_figures_test.py).

def build_wave_validity_map(h5_path):
    """The wave-validity study (studies/wave_validity_study.cpp): the relative L1 of physical
    against geometric optics, in %, over barbule width (log) x one parameter, one panel per
    incidence; the threshold's contour drawn and labelled, each cell annotated with L1 and its
    noise floor."""
    import h5py
    import numpy as np
    from matplotlib.colors import LogNorm

    with h5py.File(h5_path, "r") as f:
        widths = f["widths_um"][()]
        incidence = f["incidence_deg"][()]
        values = f["map/values"][()]
        l1 = 100.0 * f["map/relative_l1"][()]  # [incidence][value][width]
        floor = 100.0 * f["map/relative_l1_noise_floor"][()]
        boundary = f["map/boundary_width_um"][()]
        label = _text(f["map"].attrs["axis_label"])
        title = _text(f.attrs["title"])
        threshold = 100.0 * float(f.attrs["threshold"])
        window = f"{float(f.attrs['window_half_angle_deg']):g}° {_text(f.attrs['window_kernel'])}"
    order = np.argsort(values)
    values, l1, floor, boundary = values[order], l1[:, order], floor[:, order], boundary[:, order]
    n_inc = len(incidence)
    fig, axes = plt.subplots(1, n_inc, figsize=(6.2 * n_inc, 4.8), squeeze=False)
    positive = l1[l1 > 0]
    low = max(0.5, float(positive.min()) if positive.size else 1.0)
    high = max(low * 10.0, float(l1.max()) if l1.size else 100.0)
    norm = LogNorm(vmin=min(low, threshold / 2.0), vmax=high)
    for i, ax in enumerate(axes[0]):
        # Cell edges halfway between samples (geometric in width).
        lw = np.log(widths)
        wx = np.exp(np.concatenate([[lw[0] - 0.5 * (lw[1] - lw[0])], 0.5 * (lw[1:] + lw[:-1]),
                                    [lw[-1] + 0.5 * (lw[-1] - lw[-2])]])) if len(widths) > 1 \
            else np.array([widths[0] / 1.2, widths[0] * 1.2])
        if len(values) > 1:
            vy = np.concatenate([[values[0] - 0.5 * (values[1] - values[0])],
                                 0.5 * (values[1:] + values[:-1]),
                                 [values[-1] + 0.5 * (values[-1] - values[-2])]])
        else:
            vy = np.array([values[0] - 0.5, values[0] + 0.5])
        mesh = ax.pcolormesh(wx, vy, l1[i], norm=norm, cmap="magma_r", shading="flat")
        if len(values) > 1 and len(widths) > 1:
            # Context levels (thin, dashed) where the map crosses them, then the threshold.
            context = [v for v in (10.0, 20.0, 50.0, 100.0)
                       if v != threshold and l1[i].min() < v < l1[i].max()]
            if context:
                cs = ax.contour(widths, values, l1[i], levels=context, colors="0.5",
                                linewidths=0.8, linestyles="dashed")
                ax.clabel(cs, fmt=lambda v: f"{v:g} %", fontsize=8)
            if l1[i].min() < threshold < l1[i].max():
                cs = ax.contour(widths, values, l1[i], levels=[threshold], colors="cyan",
                                linewidths=2.0)
                ax.clabel(cs, fmt=lambda v: f"{v:g} %", fontsize=9)
        for v in range(len(values)):
            for w in range(len(widths)):
                ax.text(widths[w], values[v], f"{l1[i, v, w]:.0f}\n±{floor[i, v, w]:.0f}",
                        ha="center", va="center", fontsize=7,
                        color="white" if l1[i, v, w] > np.sqrt(norm.vmin * norm.vmax) else "black")
        ax.set_xscale("log")
        ax.set_xticks(widths, [f"{w:g}" for w in widths])
        ax.minorticks_off()
        ax.set_xlabel("barbule width 2A (µm)")
        ax.set_ylabel(label)
        above = [b for b in boundary[i] if np.isfinite(b) and b > 0]
        state = f"{threshold:g} % contour in cyan" if len(above) else \
            f"no {threshold:g} % crossing inside the sweep"
        ax.set_title(f"θ_i = {incidence[i]:g}°: {state}", fontsize=10)
    fig.colorbar(mesh, ax=axes[0].tolist(),
                 label="relative L1, PO vs GO (%), largest over wavelengths")
    fig.suptitle(f"{title}\nwindow {window}; cells: L1 ± noise floor (%), largest floor "
                 f"{floor.max():.1f} %", fontsize=10, y=1.06)
    return fig


def build_level_spectra(h5_path):
    """One scene of the wave-validity study judged by full wave (studies/wave_validity_live.cpp):
    the reflectance of the endless row against wavelength by full wave (fine grid, the coarse one
    dashed: their gap is the reference's resolution error), physical optics, ray optics and, where
    it accepted the row, the GO–PO hybrid."""
    import h5py

    with h5py.File(h5_path, "r") as f:
        wl = f["lambda_nm"][()]
        curves = [("full_wave", "full wave (fine grid)", "black", "-", "o"),
                  ("full_wave_coarse", "full wave (coarse grid)", "0.5", "--", None),
                  ("physical_optics", "physical optics", "tab:orange", "-", "s"),
                  ("ray_optics", "ray optics + thin film", "tab:blue", "-", "^"),
                  ("hybrid", "GO–PO hybrid (gap as separate curves)", "tab:green", "-", "D")]
        curves = [c for c in curves if c[0] in f]
        data = {name: f[name][()] for name, *_ in curves}
        title = _text(f.attrs["title"])
    fig, ax = plt.subplots(figsize=(7.5, 4.5))
    for name, label, colour, style, marker in curves:
        ax.plot(wl, data[name], color=colour, ls=style, marker=marker, ms=4, label=label)
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel("reflectance R (all orders, unpolarised)")
    ax.set_ylim(bottom=0.0)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(title, fontsize=9)
    return fig


def build_instrument_curves(h5_path):
    """A registered instrument's spectra (virtual_gonio/instrument_registry.h), each with a band
    of ± one standard error."""
    import h5py
    import numpy as np

    with h5py.File(h5_path, "r") as f:
        wl = np.asarray(f["wavelength_nm"])
        curves = [(_text(f[f"curves/{k}"].attrs["label"]), np.asarray(f[f"curves/{k}/value"]),
                   np.asarray(f[f"curves/{k}/standard_error"]))
                  for k in range(int(f.attrs["curves"]))]
        title = _text(f.attrs["title"])
        quantity = _text(f.attrs["quantity"])
    fig, ax = plt.subplots(figsize=(7, 4.2))
    for label, value, error in curves:
        line, = ax.plot(wl, value, "o-", ms=3, label=label)
        ax.fill_between(wl, value - error, value + error, color=line.get_color(), alpha=0.25,
                        linewidth=0)
    ax.set_xlabel("wavelength (nm)")
    ax.set_ylabel(quantity)
    ax.set_title(f"{title}\n(bands: ± one Monte Carlo standard error)", fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    return fig


KINDS = {  # kind -> (builder, dpi)
    "spectra": (build_spectra, 120),
    "chart": (build_chart, 120),
    "convergence": (build_convergence, 120),
    "curves": (build_curves, 120),
    "brdf_wavelengths": (build_brdf_wavelengths, 110),
    "contact_sheet": (build_contact_sheet, 110),
    "sweep_error": (build_sweep_error, 120),
    "energy_bars": (build_energy_bars, 110),
    "luminance": (build_luminance, 120),
    "masking": (build_masking, 100),
    "spongy_spectra": (build_spongy_spectra, 120),
    "spongy_map": (build_spongy_map, 120),
    "spongy_angles": (build_spongy_angles, 120),
    "scatterogram_comparison": (build_scatterogram_comparison, 110),
    "scatterogram": (build_scatterogram, 110),
    "scatterogram_levels": (build_scatterogram_levels, 110),
    "fingerprints": (build_fingerprints, 100),
    "btf_tiles": (build_btf_tiles, 110),
    "geometry_preview": (build_geometry_preview, 110),
    "wave_validity_map": (build_wave_validity_map, 110),
    "level_spectra": (build_level_spectra, 120),
    "fit_residuals": (build_fit_residuals, 110),
    "instrument_curves": (build_instrument_curves, 120),
}


def draw(kind, input_path, png_path):
    """Builds one figure and saves it as png_path, trimmed to what is drawn (nothing is written
    when the builder has nothing to draw)."""
    builder, dpi = KINDS[kind]
    fig = builder(input_path)
    if fig is not None:
        fig.savefig(png_path, dpi=dpi, bbox_inches="tight", pad_inches=0.1)
        plt.close(fig)


def batch(csv_path):
    with open(csv_path, newline="") as f:
        jobs = list(csv.DictReader(f))
    for job in jobs:
        draw(job["kind"], job["input"], job["png"])
        plt.close("all")


def main(argv):
    names = list(KINDS) + ["batch"]
    if len(argv) != 4 or argv[1] not in names:
        sys.exit("usage: plots.py " + "|".join(names) + " INPUT PNG")
    if argv[1] == "batch":
        batch(argv[2])
    else:
        draw(argv[1], argv[2], argv[3])


if __name__ == "__main__":
    main(sys.argv)
