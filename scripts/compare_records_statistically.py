#!/usr/bin/python3
"""Compares two results folders whose Monte Carlo estimates come from different random streams
(a change of the stream rule, another seed): for every record and every estimate that carries
its standard error, whether the two are draws of the same quantity.

    scripts/compare_records_statistically.py RESULTS_A RESULTS_B

Pairs an estimate with its error by name: X and X_standard_error, or value / intensity /
reflectance ... beside standard_error in the same group. Over the cells where either error is
> 0: z = (a - b) / sqrt(sa^2 + sb^2), chi^2 = sum z^2 with one degree of freedom per cell, its
p-value (Wilson-Hilferty), and max |z| against the Sidak bound of a 1 % family-wise level.
One line per estimate; exit 1 when any p < 1e-3 or max |z| beyond the bound. What it cannot
judge it leaves out: estimates without errors (fitted parameters, colours, verdicts), and
records of cubatures (/instrument @estimator = "eval", e.g. a fitted model's table), whose
errors are not noise.
Cells with few quanta have heavy-tailed errors; a failing line is a place to look, not a proof.
"""
import math
import pathlib
import sys

import h5py
import numpy as np

VALUE_NAMES = ("value", "intensity")


def error_name(name, group_names):
    """The standard-error dataset that belongs to dataset `name` in the same group, or None."""
    if name + "_standard_error" in group_names:
        return name + "_standard_error"
    if name in VALUE_NAMES and "standard_error" in group_names:
        return "standard_error"
    return None


def chi2_p(chi2, dof):
    """Upper tail of chi^2 with dof degrees of freedom (Wilson-Hilferty)."""
    if dof <= 0:
        return 1.0
    z = ((chi2 / dof) ** (1.0 / 3.0) - (1.0 - 2.0 / (9.0 * dof))) / math.sqrt(2.0 / (9.0 * dof))
    return 0.5 * math.erfc(z / math.sqrt(2.0))


def sidak_bound(n, level=0.01):
    """|z| that n independent normal cells exceed with probability `level` in all."""
    per_cell = 1.0 - (1.0 - level) ** (1.0 / max(n, 1))
    lo, hi = 0.0, 40.0
    for _ in range(200):  # bisection on erfc(z / sqrt 2) = per_cell
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if math.erfc(mid / math.sqrt(2.0)) > per_cell else (lo, mid)
    return hi


def estimates(h5):
    """(path of the estimate, path of its error) of every estimate with an error."""
    found = []

    def visit(name, obj):
        if not isinstance(obj, h5py.Group):
            return
        names = set(obj.keys())
        for child in sorted(names):
            if isinstance(obj[child], h5py.Dataset):
                e = error_name(child, names)
                if e is not None:
                    prefix = (name + "/") if name else ""
                    found.append((prefix + child, prefix + e))

    visit("", h5)
    h5.visititems(visit)
    return found


def main():
    a_root, b_root = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])
    bad = 0
    for fa in sorted(a_root.rglob("*.h5")):
        fb = b_root / fa.relative_to(a_root)
        if not fb.exists():
            print(f"{fa.relative_to(a_root)}: missing in {b_root}")
            bad += 1
            continue
        with h5py.File(fa, "r") as ha, h5py.File(fb, "r") as hb:
            if "instrument" in ha and ha["instrument"].attrs.get("estimator") == "eval":
                # A cubature of a model (e.g. a fit's): its error is not noise, and a changed
                # input moves it by more than that error; not a question for this script.
                print(f"{fa.relative_to(a_root)}: a cubature (estimator eval), not compared")
                continue
            for value, error in estimates(ha):
                if value not in hb or error not in hb:
                    print(f"{fa.relative_to(a_root)}:{value}: missing in B")
                    bad += 1
                    continue
                a, sa = ha[value][()].ravel(), ha[error][()].ravel()
                b, sb = hb[value][()].ravel(), hb[error][()].ravel()
                if a.shape != b.shape or sa.shape != a.shape:
                    print(f"{fa.relative_to(a_root)}:{value}: shapes differ")
                    bad += 1
                    continue
                var = sa ** 2 + sb ** 2
                use = np.isfinite(a) & np.isfinite(b) & (var > 0)
                n = int(use.sum())
                if n == 0:
                    continue
                z = (a[use] - b[use]) / np.sqrt(var[use])
                chi2, zmax, bound = float((z ** 2).sum()), float(np.abs(z).max()), sidak_bound(n)
                p = chi2_p(chi2, n)
                ok = p >= 1e-3 and zmax <= bound
                bad += 0 if ok else 1
                identical = bool(np.array_equal(a, b))
                print(f"{fa.relative_to(a_root)}:{value}: {n} cells, chi2/dof {chi2 / n:.3f}, "
                      f"p {p:.3g}, max |z| {zmax:.2f} (bound {bound:.2f})"
                      f"{', identical' if identical else ''}{'' if ok else '  <-- DIFFERS'}")
    print(f"{bad} estimate(s) differ beyond their Monte Carlo errors")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
