#!/usr/bin/python3
"""Are two results folders' Monte Carlo records statistically equal? For every HDF5 record in
both that holds a value and its standard error (a goniometer's /brdf/value, a scatterogram's
/image/intensity, a BTF's /btf/value), one χ² over the cells where both σ are positive (a cell
no quantum reached reads 0 ± 0, which states no error, so it cannot be compared):
χ² = Σ (a − b)² / (σ_a² + σ_b²), its degrees of freedom, p (χ² upper tail) and the largest |z|.
For records of one code whose random streams changed (independent draws of one measurement)
p is uniform; a p below 0.001 names a record that differs beyond its noise.

    scripts/records_chi2.py RESULTS_OLD RESULTS_NEW
"""
import pathlib
import sys

import h5py
import numpy as np
import math

PAIRS = [("brdf/value", "brdf/standard_error"), ("image/intensity", "image/standard_error"),
         ("btf/value", "btf/standard_error")]


def chi2_upper_tail(chi2, dof):
    """P(χ²_dof > chi2) by Wilson and Hilferty's cube-root normal approximation (1931): within
    1e-3 of the exact tail for dof ≥ 10, and the records here have hundreds of cells."""
    if dof <= 0:
        return float("nan")
    mean = 1.0 - 2.0 / (9.0 * dof)
    z = ((chi2 / dof) ** (1.0 / 3.0) - mean) / math.sqrt(2.0 / (9.0 * dof))
    return 0.5 * math.erfc(z / math.sqrt(2.0))


def compare(path_a, path_b):
    with h5py.File(path_a, "r") as a, h5py.File(path_b, "r") as b:
        for value, error in PAIRS:
            if value in a and error in a and value in b and error in b:
                va, sa = a[value][...], a[error][...]
                vb, sb = b[value][...], b[error][...]
                if va.shape != vb.shape:
                    return f"shapes differ: {va.shape} against {vb.shape}"
                variance = sa ** 2 + sb ** 2
                use = (sa > 0) & (sb > 0)
                if not use.any():
                    return "identical" if np.array_equal(va, vb, equal_nan=True) else "differs (no σ)"
                if np.array_equal(va, vb, equal_nan=True):
                    return "identical"
                z = (va[use] - vb[use]) / np.sqrt(variance[use])
                chi2, dof = float(np.sum(z ** 2)), int(use.sum())
                p = chi2_upper_tail(chi2, dof)
                return f"χ²/dof {chi2 / dof:.3f} ({dof} cells), p {p:.3g}, max |z| {np.abs(z).max():.2f}"
    return None


def main():
    old, new = (pathlib.Path(p) for p in sys.argv[1:3])
    rows = 0
    for path in sorted(old.rglob("*.h5")):
        other = new / path.relative_to(old)
        if not other.exists():
            continue
        line = compare(path, other)
        if line:
            rows += 1
            print(f"{path.relative_to(old)}: {line}")
    if rows == 0:
        print("no Monte Carlo record in both folders")


if __name__ == "__main__":
    main()
