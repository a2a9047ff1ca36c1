#!/usr/bin/env python3
"""Error against wall time for BM_RockDoveSpectral3660 (bench/instruments_bench.cpp).

Usage: /usr/bin/python3 bench/plot_error_vs_time.py CONVERGENCE.csv OUT_STEM

CONVERGENCE.csv is what the benchmark appends with PLUMAGE_BENCH_CSV set (no header):
paths, threads, pass, wall_time_s, quanta_per_light, relative_rms_error, signal_cells, cells.
Writes OUT_STEM.csv (the same rows with a header and each curve's fitted slope) and
OUT_STEM.png: log-log, one curve per (estimator, threads): separate, shared, split (shared and
split at the first film), guided50/guided80 (split and guided diffuse reflection), branches1/
branches2 (split and guided diffuse branches), the least-squares slope of
log(error) against log(time) over the passes after the first (1/sqrt(t) is -0.5), the 1 %
target and each curve's projected time to it.
"""
import csv
import math
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def main(source, stem):
    curves = {}
    with open(source) as f:
        for row in csv.reader(f):
            if not row:
                continue
            key = (row[0], int(row[1]))
            curves.setdefault(key, []).append(
                (int(row[2]), float(row[3]), int(row[4]), float(row[5]), int(row[6]), int(row[7])))
    fig, ax = plt.subplots(figsize=(7.5, 5.0))
    out_rows = []
    colours = {"separate": "tab:red", "shared": "tab:blue", "split": "tab:orange",
               "guided50": "tab:olive", "guided80": "tab:green", "branches1": "tab:purple",
               "branches2": "tab:brown"}
    styles = {1: "-", 2: "--"}
    for (paths, threads), rows in sorted(curves.items()):
        rows.sort()
        t = np.array([r[1] for r in rows])
        e = np.array([r[3] for r in rows])
        keep = slice(1, None) if len(rows) > 2 else slice(None)
        slope, intercept = np.polyfit(np.log(t[keep]), np.log(e[keep]), 1)
        projected = t[-1] * (e[-1] / 0.01) ** 2
        label = (f"{paths} paths, {threads} thread{'s' if threads > 1 else ''}: slope {slope:.2f}, "
                 f"1 % in ~{projected:.0f} s")
        ax.loglog(t, 100.0 * e, styles.get(threads, ":"), marker="o", markersize=3,
                  color=colours.get(paths, "k"), label=label)
        for r in rows:
            out_rows.append([paths, threads, *r, f"{slope:.4f}", f"{projected:.1f}"])
    ax.axhline(1.0, color="0.4", linewidth=0.8)
    ax.text(ax.get_xlim()[0] * 1.1, 1.05, "1 % target", color="0.3", fontsize=8)
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel("relative RMS standard error over the signal cells (%)")
    ax.set_title("Explicit rock-dove patch, 3660 pairs × 7 wavelengths (400–700 nm):\n"
                 "error against time per estimator (" + ", ".join(sorted({k[0] for k in curves}))
                 + ")")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(stem + ".png", dpi=120)
    with open(stem + ".csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["paths", "threads", "pass", "wall_time_s", "quanta_per_light",
                    "relative_rms_error", "signal_cells", "cells", "fitted_slope",
                    "projected_s_to_1pct"])
        w.writerows(out_rows)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
