#!/usr/bin/python3
"""SIGKILL at random points, rerun, and the records equal an uninterrupted run's bit for bit
(wall-time values aside); no staging folder survives (issue 13).

    kill_resume_test.py --plumage BUILD/studies/plumage --source REPO [--kills 20]

The study is rock_dove_quick with its BRDF on the 61 × 60 set in 6 checkpointed passes, so
that kills land in every stage, including mid-measurement where the rerun resumes from the
checkpoint. Kill times are drawn from a fixed-seed generator: half over the reference run's
duration, half within its checkpointed BRDF stage (from the reference's own stage times), so
that reruns resume from a checkpoint part-way through the passes. Each kill is followed by a rerun to completion in the same results root; one chain
kills 5 times in a row in one root before the final rerun. Records are compared by
scripts/compare_records.py (every HDF5 dataset and attribute, every CSV).
"""
import argparse
import pathlib
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time


def study_text(source):
    text = (source / "studies/rock_dove_quick.toml").read_text()
    text = re.sub(r'direction_set = "filip2024_in_plane"', 'direction_set = "filip2024_btf"', text)
    text = re.sub(r"(\[goniometer\][^\[]*?)quanta_per_pass = 3000\npasses = 1",
                  r"\1quanta_per_pass = 100\npasses = 6", text, flags=re.S)
    assert "passes = 6" in text, "rock_dove_quick.toml changed: update the kill test's edit"
    return text


def run(plumage, study, out, kill_after=None):
    cmd = [plumage, "run", str(study), "--out", str(out), "--threads", "2", "--no-plots"]
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    if kill_after is None:
        _, err = proc.communicate()
        return proc.returncode, err, time.monotonic() - start
    try:
        _, err = proc.communicate(timeout=kill_after)
        return proc.returncode, err, time.monotonic() - start  # finished first
    except subprocess.TimeoutExpired:
        proc.send_signal(signal.SIGKILL)
        _, err = proc.communicate()
        return proc.returncode, err, time.monotonic() - start


STAGE_TIME = re.compile(r"^plumage: \[\s*([0-9.]+) s\] (.*)$", re.M)


def brdf_window(err):
    """The checkpointed BRDF stage of the reference run: (start, end) in seconds."""
    times = [(float(t), text) for t, text in STAGE_TIME.findall(err)]
    start = next(t for t, text in times if text.startswith("BRDF on"))
    end = next(t for t, text in times if t > start)
    return start, end


def last_stage(err):
    stages = [l for l in err.splitlines() if l.startswith("plumage: [")]
    return stages[-1].split("] ", 1)[1][:50] if stages else "(start-up)"


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plumage", required=True)
    parser.add_argument("--source", required=True, type=pathlib.Path)
    parser.add_argument("--kills", type=int, default=20)
    args = parser.parse_args()
    compare = args.source / "scripts/compare_records.py"
    work = pathlib.Path(tempfile.mkdtemp(prefix="plumage_kill_"))
    began, failures, rows = time.monotonic(), [], []
    try:
        study = work / "rock_dove_quick.toml"
        study.write_text(study_text(args.source))
        code, err, duration = run(args.plumage, study, work / "reference")
        if code != 0:
            print(err)
            return 1
        rng = random.Random(20221122)
        first, last = brdf_window(err)
        half = args.kills // 2
        points = sorted([rng.uniform(0.05, 0.95) * duration for _ in range(args.kills - half)] +
                        [rng.uniform(first, last) for _ in range(half)])
        plans = [[t] for t in points] + [sorted(rng.uniform(0.05, 0.95) * duration for _ in range(5))]
        for n, kills in enumerate(plans):
            out = work / f"run{n}"
            stages = []
            for t in kills:
                code, err, _ = run(args.plumage, study, out, t)
                stages.append(f"{t:.2f} s: {last_stage(err)}" if code == -9 else f"{t:.2f} s: finished first")
            code, err, _ = run(args.plumage, study, out)
            m = re.search(r"resuming after (\d+) completed passes", err)
            resumed = f"pass {m.group(1)}" if m else ""
            removed = err.count("left by process")
            left = sorted(p.name for p in out.iterdir() if ".partial-" in p.name or ".previous-" in p.name)
            if (out / ".checkpoints").exists():
                left.append(".checkpoints")
            diff = subprocess.run(["/usr/bin/python3", str(compare), str(work / "reference"), str(out)],
                                  capture_output=True, text=True)
            equal = diff.returncode == 0
            rows.append((" | ".join(stages), resumed, removed, ", ".join(left) or "none", "equal" if equal else "DIFFER"))
            if code != 0 or left or not equal:
                failures.append(f"kills {kills}: rerun exit {code}, left {left}, records "
                                f"{'equal' if equal else 'differ:' + diff.stdout[-400:]}")
            shutil.rmtree(out, ignore_errors=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"reference run {duration:.1f} s, checkpointed BRDF stage {first:.1f}-{last:.1f} s; "
          f"{sum(len(p) for p in plans)} kills in {len(plans)} runs")
    print(f"{'kill time: stage at the kill':72} {'resumed after':13} {'orphans removed':>15}  {'left':6} records")
    for stages, resumed, removed, left, equal in rows:
        print(f"{stages[:72]:72} {resumed:13} {removed:>15}  {left:6} {equal}")
    print(f"{time.monotonic() - began:.0f} s in all")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
