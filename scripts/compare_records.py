#!/usr/bin/python3
"""Compares two results folders record by record: every HDF5 file (groups, datasets bit for
bit including NaN positions, dtypes, shapes, attributes) and every CSV, with run-time values
aside. Exit 0 when identical, 1 with one line per difference.

    scripts/compare_records.py RESULTS_A RESULTS_B

What is set aside, and why: values that measure the run rather than the scene (wall time,
CPU time and CPU/wall, the wave-validity map's per-cell times (RUN_DATASETS), thread count,
the version string, and /provenance's date, host and git commit: a resumed run, or the same code on another day, machine or commit, writes the same
numbers; the compiler and library versions are compared), the wall-time column of convergence
tables, and CSV columns whose header names a time (a study's stages.csv: its wall, CPU and
CPU/wall columns; the stage names are compared).
"""
import csv
import io
import pathlib
import sys

import h5py
import numpy as np

RUN_ATTRIBUTES = {"wall_time_s", "wall_seconds", "compute_wall_time_s", "cpu_time_s", "cpu_per_wall",
                  "threads", "plumage_version", "date", "host", "git_commit"}
# Datasets that are clocks themselves (the wave-validity map's per-cell wall and CPU times of
# each level): by the last part of their name.
RUN_DATASETS = {"po_wall_s", "po_cpu_s", "go_wall_s", "go_cpu_s"}
# Convergence tables: [pass, wall time (s), quanta, estimated error]; column 1 is the clock.
CONVERGENCE_TIME_COLUMN = 1


def same_array(a, b):
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind == "f":
        return np.array_equal(a, b, equal_nan=True)
    return np.array_equal(a, b)


def compare_attributes(where, a, b, problems):
    for name in sorted(set(a.attrs) | set(b.attrs)):
        if name in RUN_ATTRIBUTES:
            continue
        if name not in a.attrs or name not in b.attrs:
            problems.append(f"{where} @{name}: only in one record")
            continue
        x, y = np.asarray(a.attrs[name]), np.asarray(b.attrs[name])
        if not same_array(x, y):
            problems.append(f"{where} @{name}: {a.attrs[name]!r} != {b.attrs[name]!r}")


def compare_h5(path_a, path_b, label, problems):
    with h5py.File(path_a, "r") as a, h5py.File(path_b, "r") as b:
        names_a, names_b = [], []
        a.visit(names_a.append)
        b.visit(names_b.append)
        for name in sorted(set(names_a) ^ set(names_b)):
            problems.append(f"{label}:/{name}: only in one record")
        compare_attributes(f"{label}:/", a, b, problems)
        for name in sorted(set(names_a) & set(names_b)):
            x, y = a[name], b[name]
            compare_attributes(f"{label}:/{name}", x, y, problems)
            if isinstance(x, h5py.Dataset) and isinstance(y, h5py.Dataset):
                if name.split("/")[-1] in RUN_DATASETS:
                    if x.shape != y.shape:
                        problems.append(f"{label}:/{name}: shapes differ")
                    continue
                u, v = x[()], y[()]
                if name.split("/")[-1] == "convergence" and np.ndim(u) == 2 and np.shape(u) == np.shape(v):
                    u, v = np.array(u), np.array(v)
                    u[:, CONVERGENCE_TIME_COLUMN] = 0
                    v[:, CONVERGENCE_TIME_COLUMN] = 0
                if not same_array(np.asarray(u), np.asarray(v)):
                    diff = ""
                    if np.asarray(u).dtype.kind == "f" and np.shape(u) == np.shape(v):
                        diff = f" (max |difference| {np.nanmax(np.abs(np.asarray(u) - np.asarray(v))):.3g})"
                    problems.append(f"{label}:/{name}: values differ{diff}")


def timed_columns(header):
    """Columns that measure the run: "wall time (s)", "cpu time (s)", "cpu/wall", "seconds"..."""
    return {i for i, h in enumerate(header)
            if "wall" in h or "time (s)" in h or h.strip() in {"seconds"} | RUN_DATASETS}


def compare_csv(path_a, path_b, label, problems):
    # csv.reader, not split(","): a quoted field (a stage name) may hold commas.
    rows_a = list(csv.reader(io.StringIO(path_a.read_text())))
    rows_b = list(csv.reader(io.StringIO(path_b.read_text())))
    if not rows_a or not rows_b:
        if rows_a != rows_b:
            problems.append(f"{label}: one is empty")
        return
    timed = timed_columns(rows_a[0])
    if len(rows_a) != len(rows_b):
        problems.append(f"{label}: {len(rows_a)} != {len(rows_b)} rows")
        return
    for n, (u, v) in enumerate(zip(rows_a, rows_b), start=1):
        if [c for i, c in enumerate(u) if i not in timed] != [c for i, c in enumerate(v) if i not in timed]:
            problems.append(f"{label}:{n}: {u!r} != {v!r}")
            return


def main():
    a, b = map(pathlib.Path, sys.argv[1:3])
    problems = []
    files_a = {p.relative_to(a) for p in a.rglob("*") if p.suffix in (".h5", ".csv")}
    files_b = {p.relative_to(b) for p in b.rglob("*") if p.suffix in (".h5", ".csv")}
    for f in sorted(files_a ^ files_b):
        problems.append(f"{f}: only in {'A' if f in files_a else 'B'}")
    for f in sorted(files_a & files_b):
        if f.name == "plots.csv":  # the plot job list names the staging folder
            continue
        (compare_h5 if f.suffix == ".h5" else compare_csv)(a / f, b / f, str(f), problems)
    for p in problems:
        print(p)
    print(f"compared {len(files_a & files_b)} files: {'identical' if not problems else f'{len(problems)} differences'}")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
