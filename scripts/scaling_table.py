#!/usr/bin/env python3
"""How each study's run time scales with threads, as a markdown table.

    scripts/scaling_table.py PLUMAGE STUDY_FILE... [--threads 1,2] [--out DIR]

Runs every study file at every thread count (one after the other, never two at once) and
prints, per study, the wall time at each count, the speed-up against the first count, and the
stage with the lowest CPU/wall at the highest count among those taking at least 5 % of the
run: the stage that will stop the study scaling on more cores. The figures come from each
run's stages.csv (studies/study_progress.h), so they are the report's own.
"""
import argparse
import csv
import pathlib
import subprocess
import sys
import tempfile
import tomllib


def run(plumage, study, threads, out):
    name = tomllib.loads(pathlib.Path(study).read_text())["name"]
    subprocess.run([plumage, "run", study, "--out", str(out), "--threads", str(threads),
                    "--no-plots"], check=True, stdout=subprocess.DEVNULL,
                   stderr=subprocess.DEVNULL)
    with open(out / name / "stages.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    return name, [(r["stage"], float(r["wall time (s)"]), float(r["cpu time (s)"])) for r in rows]


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("plumage")
    parser.add_argument("studies", nargs="+")
    parser.add_argument("--threads", default="1,2")
    parser.add_argument("--out", type=pathlib.Path)
    args = parser.parse_args()
    counts = [int(t) for t in args.threads.split(",")]
    out = args.out or pathlib.Path(tempfile.mkdtemp(prefix="plumage-scaling-"))
    header = " | ".join(f"{t} thread{'s' if t > 1 else ''} (s)" for t in counts)
    print(f"| study | {header} | speed-up {counts[0]} → {counts[-1]} | least parallel stage at "
          f"{counts[-1]} threads (share of the run, CPU/wall) |")
    print("|---|" + "---|" * (len(counts) + 2))
    for study in args.studies:
        totals, last = [], None
        for t in counts:
            name, stages = run(args.plumage, study, t, out / f"t{t}")
            totals.append(sum(w for _, w, _ in stages))
            last = stages
        total = totals[-1]
        candidates = [(c / w, s, w) for s, w, c in last if w >= 0.05 * total and w > 0]
        ratio, stage, wall = min(candidates) if candidates else (float("nan"), "—", 0.0)
        cells = " | ".join(f"{x:.1f}" for x in totals)
        print(f"| {name} | {cells} | {totals[0] / totals[-1]:.2f}× | {stage} "
              f"({100 * wall / total:.0f} %, {ratio:.2f}) |")
        sys.stdout.flush()


if __name__ == "__main__":
    main()
