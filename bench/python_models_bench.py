#!/usr/bin/env python3
"""The models from Python against the C++ benchmark, in one run (bench/README.md, "Python").

Runs plumage_bench_models for the C++ rates (one thread, a table of 1024 directions), then
evaluates the same model from Python over 10⁶ directions in one eval() call: ω_i fixed at
θ_i = 0.6 rad in the x–z plane, 550 nm, as BM_Huang2022EvalStatedIncident (Huang's rate depends
on ω_i), ω_o uniform over the upper hemisphere (as the benchmark's table). Reports evaluations
per second for both, per wall second and per CPU second, with 1 thread (the C++ benchmark's
count) and with every core. Needs Debian's python and the build's package:

    PYTHONPATH=build/python /usr/bin/python3 bench/python_models_bench.py [BUILD_DIR]
"""

import json
import os
import pathlib
import subprocess
import sys
import time

import numpy as np

import plumage

N = 1_000_000
CASES = [  # (C++ benchmark, Python model)
    ("BM_Huang2022EvalStatedIncident", lambda: plumage.models.Huang2022()),
    ("BM_Filip2024Eval", lambda: plumage.models.Filip2024(preset="parrot")),
]


def cpp_rates(build: pathlib.Path) -> dict:
    names = "|".join(name for name, _ in CASES)
    out = subprocess.run(
        [str(build / "bench/plumage_bench_models"), f"--benchmark_filter=^({names})$",
         "--benchmark_min_time=1", "--benchmark_format=json"],
        check=True, capture_output=True, text=True).stdout
    rates = {}
    for b in json.loads(out)["benchmarks"]:
        scale = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3}[b["time_unit"]]
        rates[b["name"]] = (1 / (b["real_time"] * scale), 1 / (b["cpu_time"] * scale))
    return rates


def python_rate(model, wi, wo, lam, threads):
    model.eval(wi, wo[:1000], lam, threads=threads)  # warm: per-thread caches, pages
    wall, cpu = time.perf_counter(), time.process_time()
    f = model.eval(wi, wo, lam, threads=threads)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    assert f.shape == (N,) and np.all(np.isfinite(f))
    return N / wall, N / cpu, wall


def main():
    build = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "build")
    rng = np.random.default_rng(20221122)
    z, phi = rng.uniform(0, 1, N), rng.uniform(0, 2 * np.pi, N)
    s = np.sqrt(1 - z * z)
    wo = np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)
    wi = np.array([np.sin(0.6), 0.0, np.cos(0.6)])
    lam = 550.0
    cores = os.cpu_count()
    print(f"load average before: {os.getloadavg()[0]:.2f} on {cores} cores")
    before = cpp_rates(build)
    rows = []
    for name, make in CASES:
        model = make()
        one = python_rate(model, wi, wo, lam, 1)
        every = python_rate(model, wi, wo, lam, cores)
        rows.append((name, one, every))
    after = cpp_rates(build)  # C++ again after Python: the load may have changed meanwhile
    print(f"load average after: {os.getloadavg()[0]:.2f}")
    print("| model | C++ (1 thread, wall / CPU) | Python 10⁶ in one call, 1 thread (wall / CPU)"
          f" | C++ / Python (wall, CPU) | Python, {cores} threads (wall) |")
    print("|---|---|---|---|---|")
    for name, one, every in rows:
        cpp_wall = 0.5 * (before[name][0] + after[name][0])
        cpp_cpu = 0.5 * (before[name][1] + after[name][1])
        print(f"| `{name}` | {cpp_wall:.4g} / {cpp_cpu:.4g} /s | {one[0]:.4g} / {one[1]:.4g} /s "
              f"({one[2]:.2f} s) | {cpp_wall / one[0]:.2f}, {cpp_cpu / one[1]:.2f} "
              f"| {every[0]:.4g} /s ({every[2]:.2f} s) |")


if __name__ == "__main__":
    main()
