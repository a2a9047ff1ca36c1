#!/usr/bin/python3
"""SIGINT at every stage of every quick study: plumage exits 130 within 2 s, leaves no staging
folder and no half-written results (issue 13, acceptance 3).

    interrupt_test.py --plumage BUILD/studies/plumage --source REPO

For each quick study one uninterrupted reference run records its stage lines
("plumage: [  1.2 s] <stage>") with their times. Then, per stage, a fresh run gets SIGINT the
moment that stage's line appears on stderr, and, for stages that lasted over a second, another
run gets it halfway through the stage. A study with more than 20 stages (the extremes study's
cases, the species study's four feathers) is interrupted at its first 10 stages, every k-th
after and its last: the later stages repeat the same code on other cases. Subcommands without
stage lines (geometry, thin-film) are interrupted at 10/30/60/90 % of their reference time. The
last line, "done: ...", comes after the results are committed and is not a stage.
Also: SIGTERM exits 143, and an interrupted rerun leaves an earlier complete result untouched.
"""
import argparse
import hashlib
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

LIMIT_S = 2.0
STAGE = re.compile(r"^plumage: \[\s*[0-9.]+ s\] (.*)$")


def command(plumage, source, study, out):
    common = ["--out", str(out), "--threads", "2", "--no-plots"]
    if study == "geometry":
        return [plumage, "geometry", str(source / "studies/geometry/spongy_channel.toml")] + common
    if study == "thin-film":
        return [plumage, "thin-film", "--thickness-step-nm", "2", "--angle-step-deg", "2"] + common
    return [plumage, "run", str(source / "studies" / f"{study}.toml")] + common


def run(cmd, stop_at_line=None, stop_after_s=None, sig=signal.SIGINT):
    """Runs cmd; sends `sig` when stderr line number `stop_at_line` (0-based, stage lines only)
    appears, `stop_after_s` later (or at once); without a line, `stop_after_s` after the start.
    Returns (exit code, stage lines with times, seconds from the signal to the exit or None)."""
    start = time.monotonic()
    proc = subprocess.Popen(cmd, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True, bufsize=1)
    stages, sent = [], [None]

    def send():
        if proc.poll() is None and sent[0] is None:
            sent[0] = time.monotonic()
            proc.send_signal(sig)

    timer = threading.Timer(stop_after_s, send) if stop_after_s is not None and stop_at_line is None else None
    if timer:
        timer.start()
    for line in proc.stderr:
        m = STAGE.match(line.rstrip("\n"))
        # "done: ..." follows the commit: the results are complete, a signal then changes nothing.
        if m and not m.group(1).startswith("done: "):
            stages.append((time.monotonic() - start, m.group(1)))
            if stop_at_line is not None and len(stages) - 1 == stop_at_line:
                if stop_after_s:
                    timer = threading.Timer(stop_after_s, send)
                    timer.start()
                else:
                    send()
    code = proc.wait()
    end = time.monotonic()
    if timer:
        timer.cancel()
    return code, stages, (end - sent[0]) if sent[0] is not None else None


def seconds(latency):
    return f"{latency:.3f}" if latency is not None else "-"


def leftovers(out):
    if not out.exists():
        return []
    return sorted(p.name for p in out.iterdir() if ".partial-" in p.name or ".previous-" in p.name)


def complete_results(out):
    """Result folders in out: each must be complete (marker and report)."""
    bad = []
    for p in out.iterdir() if out.exists() else []:
        if p.name.startswith(".") or not p.is_dir():
            continue
        if not (p / ".plumage-results").exists() or not (p / "report.md").exists():
            bad.append(p.name)
    return bad


def chosen_stages(n):
    if n <= 20:
        return list(range(n))
    step = max(1, (n - 11) // 9)
    return sorted(set(list(range(10)) + list(range(10, n - 1, step)) + [n - 1]))


def digest(folder):
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(folder)).encode())
            h.update(p.read_bytes())
    return h.hexdigest()


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plumage", required=True)
    parser.add_argument("--source", required=True, type=pathlib.Path)
    parser.add_argument("--studies", nargs="*", default=[
        "rock_dove_quick", "ablation_quick", "extremes_quick", "species_quick", "masking_quick",
        "calibration", "geometry", "thin-film"])
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="plumage_interrupt_"))
    failures, rows, began = [], [], time.monotonic()
    try:
        for study in args.studies:
            ref_out = work / f"{study}_reference"
            t0 = time.monotonic()
            code, stages, _ = run(command(args.plumage, args.source, study, ref_out))
            duration = time.monotonic() - t0
            if code != 0:
                failures.append(f"{study}: reference run exited {code}")
                continue
            plans = []  # (label, stop_at_line, stop_after_s)
            if stages:
                for i in chosen_stages(len(stages)):
                    plans.append((f"at '{stages[i][1][:60]}'", i, None))
                    length = (stages[i + 1][0] if i + 1 < len(stages) else duration) - stages[i][0]
                    if length > 1.0 and sum(1 for p in plans if p[0].startswith("mid")) < 5:
                        plans.append((f"mid '{stages[i][1][:56]}'", i, 0.5 * length))
            else:
                plans = [(f"at {int(100 * f)} %", None, f * duration) for f in (0.1, 0.3, 0.6, 0.9)]
            for n, (label, line, after) in enumerate(plans):
                out = work / f"{study}_{n}"
                code, _, latency = run(command(args.plumage, args.source, study, out), line, after)
                left = leftovers(out)
                # Exit 0: the run committed its results before it reached a check of the flag
                # (the signal came during its last instants). Then the results must be complete.
                if code == 0:
                    rows.append((study, label, seconds(latency), code, "finished first"))
                    if complete_results(out) or left:
                        failures.append(f"{study} {label}: exit 0 but left {left + complete_results(out)}")
                    # A line-triggered signal cannot come after the end unless the stage is
                    # the last; a mid-stage one can, when the stage runs faster than it did in
                    # the reference run.
                    if label.startswith("at ") and n < len(plans) - 2:
                        failures.append(f"{study} {label}: finished before the signal")
                    continue
                ok = code == 130 and latency is not None and latency <= LIMIT_S and not left and not complete_results(out)
                rows.append((study, label, seconds(latency), code,
                             ", ".join(left + complete_results(out)) or "none"))
                if not ok:
                    failures.append(f"{study} {label}: exit {code}, {latency} s, left {left + complete_results(out)}")
                shutil.rmtree(out, ignore_errors=True)
        # SIGTERM, and an earlier complete result that an interrupted rerun must not touch.
        out = work / "sigterm"
        code, _, latency = run(command(args.plumage, args.source, "rock_dove_quick", out), 2, None, signal.SIGTERM)
        rows.append(("rock_dove_quick", "SIGTERM at stage 3", seconds(latency), code, ", ".join(leftovers(out)) or "none"))
        if code != 143 or latency is None or latency > LIMIT_S or leftovers(out):
            failures.append(f"SIGTERM: exit {code}, {latency} s")
        out = work / "rock_dove_quick_reference"
        before = digest(out / "rock_dove_quick")
        code, _, latency = run(command(args.plumage, args.source, "rock_dove_quick", out), 4)
        after = digest(out / "rock_dove_quick")
        rows.append(("rock_dove_quick", "rerun over a result, SIGINT at stage 5", seconds(latency), code,
                     "earlier result " + ("unchanged" if before == after else "CHANGED")))
        if code != 130 or before != after or leftovers(out):
            failures.append(f"rerun over a result: exit {code}, result {'unchanged' if before == after else 'changed'}")
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(f"{'study':16} {'signal':66} {'to exit (s)':>11} {'exit':>5}  left behind")
    for study, label, latency, code, left in rows:
        print(f"{study:16} {label:66} {latency:>11} {code:>5}  {left}")
    latencies = [float(r[2]) for r in rows if r[2] != "-"] or [0.0]
    print(f"{len(rows)} runs, largest signal-to-exit {max(latencies):.3f} s (limit {LIMIT_S} s), "
          f"{time.monotonic() - began:.0f} s in all")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
