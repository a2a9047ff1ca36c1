#!/usr/bin/env python3
"""Huang 2022 over 10⁶ random direction pairs from Python, 1 and 2 threads (bench/README.md,
"Huang 2022 over random pairs from Python"; issue 41: ≤ 10 s on 2 cores).

Every pair has its own ω_i and ω_o, each uniform over the upper hemisphere, at 550 nm, in one
eval() call: the case a renderer or a user's own sampling gives, and the slow one, since the model
builds its visibility intervals and TRT rule per ω_i (a sweep with ω_i fixed is
bench/python_models_bench.py). Prints wall and CPU seconds per thread count, the load average
before and after, and a checksum of the values (the same for every thread count and every build
that keeps the values). Needs Debian's python and a build's package:

    PYTHONPATH=build/python /usr/bin/python3 bench/python_huang_pairs_bench.py [--pairs N]
        [--threads 1,2] [--repeat R] [--label TEXT]

A line per run: label, threads, pairs, wall s, CPU s, pairs per wall second, checksum. To compare
two builds in one session, alternate them (PYTHONPATH and LD_LIBRARY_PATH of each) and keep the
label apart.
"""

import argparse
import os
import time

import numpy as np

import plumage


def hemisphere(n: int, rng: np.random.Generator) -> np.ndarray:
    z, phi = rng.uniform(0, 1, n), rng.uniform(0, 2 * np.pi, n)
    s = np.sqrt(1 - z * z)
    return np.stack([s * np.cos(phi), s * np.sin(phi), z], axis=1)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pairs", type=int, default=1_000_000)
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--repeat", type=int, default=1)
    parser.add_argument("--label", default="")
    args = parser.parse_args()
    rng = np.random.default_rng(20261128)
    wi, wo = hemisphere(args.pairs, rng), hemisphere(args.pairs, rng)
    model = plumage.models.Huang2022()
    model.eval(wi[:100], wo[:100], 550.0)  # the wavelength's film table, pages, OpenMP's pool
    print(f"# load average before: {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    print("# label | threads | pairs | wall s | CPU s | pairs/s (wall) | checksum")
    for _ in range(args.repeat):
        for threads in (int(t) for t in args.threads.split(",")):
            wall, cpu = time.perf_counter(), time.process_time()
            f = model.eval(wi, wo, 550.0, threads=threads)
            wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
            assert f.shape == (args.pairs,) and np.all(np.isfinite(f))
            print(f"{args.label} | {threads} | {args.pairs} | {wall:.2f} | {cpu:.2f} | "
                  f"{args.pairs / wall:.4g} | {np.sum(f):.17g}", flush=True)
    print(f"# load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
