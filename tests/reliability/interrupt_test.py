#!/usr/bin/python3
"""Issue acceptance: "SIGINT at every stage of every quick study exits 130 within 2 s, with
nothing half-written."

    interrupt_test.py --plumage BUILD/studies/plumage --source REPO [--studies ...]

Studies: the six `run` quick studies and calibration, one `geometry` file (the smallest in
studies/geometry/, spongy_spheres.toml) and `thin-film` with coarse steps; all with
--threads 2 and plots on (drawing the plots is a stage too), each run in its own --out
inside a fresh temporary folder.

1. One uninterrupted reference run per study records every progress line on stderr (split at
   '\\n' and '\\r', read unbuffered) with its arrival time. The line that reports the commit
   ("done: ..." or "plumage: wrote ...") ends the list; it is kept as the last stage.
2. Stages are deduplicated by kind: numbers become '#', and a leading "label: " is dropped
   when the label is one word (a feather, a configuration: "parrot:", "sparse:") or holds a
   number or '=' (a swept value, an extreme case: "b = 0.22:", "grazing 89°:"). The first line
   of each kind is a stage, and so is the last line before the commit whatever its kind.
3. For each stage a fresh run gets SIGINT the moment that line appears (matched as the n-th
   occurrence of the same text with numbers masked), and, for stages that lasted > 1 s in the
   reference, another run gets it half-way into the stage. A study that prints no progress
   line before the commit is signalled at 10/30/50/80 % of its reference time.
4. Each interrupted run must exit 130 within LIMIT_S of the signal (measured from the
   signal to the process's exit), say "interrupted" on stderr, and leave no `*.partial-*` or
   `*.previous-*` entry in --out; the results folder is either absent or complete (report.md
   and the marker .plumage-results). Exit 0 ("finished first": the run committed before the
   signal arrived) is accepted only for the last stage. A child that still holds stderr open
   1 s after plumage exited (a plot interpreter left running) is a failure too.
5. SIGTERM once (exit 143), and once a rerun over an earlier complete result, interrupted:
   the earlier result must stay byte-identical.

Exit 0 when everything holds; prints a table and one FAIL line per broken promise. About
9 minutes on 2 idle cores (522 s in CI's run of 2026-12-01; 3 minutes on 2026-11-24).
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
MID_STAGE_MIN_S = 1.0      # stages at least this long in the reference also get a mid-stage signal
STDERR_GRACE_S = 1.0       # children must let go of stderr this soon after plumage exits
QUICK_STUDIES = ["rock_dove_quick", "ablation_quick", "extremes_quick", "species_quick",
                 "masking_quick", "calibration", "spongy_quick", "geometry", "thin-film"]
GEOMETRY_FILE = "spongy_spheres.toml"   # the smallest file in studies/geometry/
THIN_FILM_STEPS = ["--thickness-step-nm", "10", "--angle-step-deg", "5"]
TIME_FRACTIONS = (0.1, 0.3, 0.5, 0.8)

STAGE_PREFIX = re.compile(r"^plumage: \[\s*[0-9.]+ s\] ")
COMMIT_LINE = re.compile(r"^(plumage: \[\s*[0-9.]+ s\] done: |plumage: wrote )")
NUMBER = re.compile(r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?")


def command(plumage, source, study, out):
    common = ["--out", str(out), "--threads", "2"]
    if study == "geometry":
        return [plumage, "geometry", str(source / "studies/geometry" / GEOMETRY_FILE)] + common
    if study == "thin-film":
        return [plumage, "thin-film"] + THIN_FILM_STEPS + common
    return [plumage, "run", str(source / "studies" / f"{study}.toml")] + common


def masked(line):
    """The line without its clock and with every number masked: the same in every run."""
    return NUMBER.sub("#", STAGE_PREFIX.sub("", line))


def kind(line):
    text = masked(line)
    label, sep, rest = text.partition(": ")
    if sep and rest and (re.fullmatch(r"[\w-]+", label) or "#" in label or "=" in label):
        return rest
    return text


class Run:
    """One plumage process; stderr read unbuffered and split into lines at '\\n' and '\\r'.
    `trigger(index, line)` returns True on the line at which to signal (after `delay` s);
    without a trigger the signal goes `delay` s after the start (no signal if delay is None)."""

    def __init__(self, cmd, trigger=None, delay=None, sig=signal.SIGINT, group=False):
        self.lines, self.sent_at, self.sig, self.group = [], None, sig, group
        self.start = time.monotonic()
        # Its own process group: a group signal reaches plumage and its plot interpreter, as
        # Ctrl-C in a terminal does; otherwise the signal goes to plumage alone, as `kill` does.
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.PIPE, bufsize=0, start_new_session=True)
        self.trigger, self.delay = trigger, delay
        self.timer = None
        if trigger is None and delay is not None:
            self.timer = threading.Timer(delay, self.send)
            self.timer.start()
        self.reader = threading.Thread(target=self.read, daemon=True)
        self.reader.start()
        self.code = self.proc.wait()
        self.exited_at = time.monotonic()
        if self.timer:
            self.timer.cancel()
        self.reader.join(STDERR_GRACE_S)
        self.stderr_held = self.reader.is_alive()

    def send(self):
        if self.sent_at is None and self.proc.returncode is None:
            self.sent_at = time.monotonic()
            (os.killpg if self.group else os.kill)(self.proc.pid, self.sig)

    def read(self):
        fd, pending = self.proc.stderr.fileno(), b""
        while True:
            chunk = os.read(fd, 65536)
            if not chunk:
                break
            now = time.monotonic() - self.start
            pending += chunk
            *complete, pending = re.split(rb"[\r\n]", pending)
            for raw in complete:
                line = raw.decode("utf-8", "replace").strip()
                if not line:
                    continue
                self.lines.append((now, line))
                if self.trigger and self.timer is None and self.trigger(len(self.lines) - 1, line):
                    if self.delay:
                        self.timer = threading.Timer(self.delay, self.send)
                        self.timer.start()
                    else:
                        self.send()
        if pending.strip():
            self.lines.append((time.monotonic() - self.start, pending.decode("utf-8", "replace").strip()))

    @property
    def latency(self):
        return None if self.sent_at is None else self.exited_at - self.sent_at

    def stderr_after_signal(self):
        t = (self.sent_at or 0) - self.start
        return [line for when, line in self.lines if when >= t]


def occurrence_trigger(text, n):
    """Fires on the n-th (0-based) line whose masked text is `text`."""
    seen = [0]

    def trigger(_, line):
        if masked(line) != text:
            return False
        seen[0] += 1
        return seen[0] == n + 1
    return trigger


def progress(lines):
    """Progress lines up to and including the commit line (None if there is none)."""
    out = []
    for when, line in lines:
        out.append((when, line))
        if COMMIT_LINE.match(line):
            return out, True
    return out, False


def plan(lines, duration, startup):
    """[(label, trigger text, occurrence, delay, is_last)] for one study. `startup`: how long
    the process takes to reach main (the time-fraction plans start after it)."""
    stages, committed = progress(lines)
    before_commit = stages[:-1] if committed else stages
    plans = []
    if not before_commit:
        end = stages[-1][0] if stages else duration
        for i, f in enumerate(TIME_FRACTIONS):
            t = startup + f * (end - startup)
            plans.append((f"at {t:.2f} s ({int(f * 100)} % of the run after start-up)", None, None, t,
                          i == len(TIME_FRACTIONS) - 1))
    else:
        seen, chosen = set(), []
        for i, (_, line) in enumerate(before_commit):
            k = kind(line)
            if k not in seen or i == len(before_commit) - 1:
                chosen.append(i)
            seen.add(k)
        for i in chosen:
            when, line = stages[i]
            text = masked(line)
            n = sum(1 for _, l in stages[:i] if masked(l) == text)
            last = i == len(before_commit) - 1
            short = STAGE_PREFIX.sub("", line)[:60]
            plans.append((f"at '{short}'", text, n, 0.0, last))
            length = (stages[i + 1][0] if i + 1 < len(stages) else duration) - when
            if length >= MID_STAGE_MIN_S:
                plans.append((f"mid ({length / 2:.1f} s into) '{short[:44]}'", text, n, length / 2, last))
    if committed:
        when, line = stages[-1]
        text = masked(line)
        n = sum(1 for _, l in stages[:-1] if masked(l) == text)
        plans.append(("at the commit line (after the commit)", text, n, 0.0, True))
    return plans


def leftovers(out, name):
    """Staging entries, incomplete or unexpected results in `out` (.checkpoints is allowed)."""
    found = []
    if not out.exists():
        return found
    for p in sorted(out.iterdir()):
        if ".partial-" in p.name or ".previous-" in p.name:
            found.append(p.name)
        elif p.name == name:
            missing = [f for f in ("report.md", ".plumage-results") if not (p / f).is_file()]
            if missing:
                found.append(f"{p.name} without {' and '.join(missing)}")
        elif p.name != ".checkpoints":
            found.append(f"unexpected {p.name}")
    return found


def digest(folder):
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        h.update(str(p.relative_to(folder)).encode() + b"\0")
        if p.is_file():
            h.update(p.read_bytes())
    return h.hexdigest()


def result_name(out):
    names = [p.name for p in out.iterdir() if p.is_dir() and not p.name.startswith(".")]
    return names[0] if len(names) == 1 else None


class Table:
    def __init__(self):
        self.rows, self.failures = [], []

    def check(self, study, label, run, name, expect_code, may_finish_first):
        left = leftovers(run.out, name)
        notes = []
        if any("stopped by force" in l for _, l in run.lines):
            notes.append("forced by the watchdog")
        if run.stderr_held:
            notes.append("stderr held open after exit")
        problems = []
        if run.code == 0 and run.sent_at is None:
            notes.append("finished first")
            if not may_finish_first:
                problems.append("finished before the signal (not the last stage)")
        elif run.code != expect_code:
            problems.append(f"exit {run.code}, expected {expect_code}")
        if run.latency is not None and run.latency > LIMIT_S:
            problems.append(f"{run.latency:.2f} s from the signal to the exit")
        if run.code == expect_code and not any("interrupted" in l for l in run.stderr_after_signal()):
            problems.append("no 'interrupted' message on stderr")
        if left:
            problems.append("left " + ", ".join(left))
        if run.stderr_held:
            problems.append("a child process still held stderr 1 s after plumage exited")
        latency = f"{run.latency:.3f}" if run.latency is not None else "-"
        self.rows.append((study, label, latency, run.code, ", ".join(left) or "none", "; ".join(notes)))
        for p in problems:
            last = run.stderr_after_signal()[-1:] or ["(no stderr)"]
            self.failures.append(f"{study}, {label}: {p} (last stderr line: {last[0][:120]})")

    def print(self):
        w = max(len(r[1]) for r in self.rows)
        print(f"{'study':16} {'stage (signal)':{w}} {'signal->exit s':>14} {'exit':>5}  {'leftovers':10} notes")
        for study, label, latency, code, left, notes in self.rows:
            print(f"{study:16} {label:{w}} {latency:>14} {code:>5}  {left:10} {notes}")


def interrupted_run(cmd, out, p, sig=signal.SIGINT, group=False):
    label, text, n, delay, _ = p
    trigger = occurrence_trigger(text, n) if text is not None else None
    run = Run(cmd, trigger, delay, sig, group)
    run.out = out
    return run


def startup_time(plumage):
    """How long the process takes to reach main: the dynamic loader and the libraries'
    initialisers run before main can install a handler, as long as `plumage --version` takes."""
    startup = 0.0
    for _ in range(3):
        t = time.monotonic()
        subprocess.run([plumage, "--version"], stdout=subprocess.DEVNULL, check=True)
        startup = max(startup, time.monotonic() - t)
    return startup


def interrupt_every_stage(plumage, source, study, work, startup, table, summary, verbose):
    """One study's reference run, then a run signalled at each of its stages. Returns the
    reference's (folder, result name, stderr lines), or None when the reference failed."""
    ref_out = work / study / "reference"
    ref = Run(command(plumage, source, study, ref_out))
    duration = ref.exited_at - ref.start
    name = result_name(ref_out) if ref_out.exists() else None
    if ref.code != 0 or name is None:
        table.failures.append(f"{study}: reference run exited {ref.code}: "
                              f"{ref.lines[-1][1] if ref.lines else ''}")
        return None
    plans = plan(ref.lines, duration, startup)
    kinds = len({kind(l) for _, l in progress(ref.lines)[0]})
    summary.append(f"{study}: reference {duration:.1f} s, {len(progress(ref.lines)[0])} progress "
                   f"lines of {kinds} kinds, {len(plans)} interrupted runs")
    for i, p in enumerate(plans):
        out = work / study / f"run{i}"
        run = interrupted_run(command(plumage, source, study, out), out, p)
        table.check(study, p[0], run, name, 130, p[4])
        if verbose:
            print(f"--- {study}, {p[0]}: exit {run.code}, {run.latency}")
            for when, line in run.lines:
                if when >= (run.sent_at or 1e9) - run.start - 0.5:
                    print(f"    {when:7.3f} {line[:150]}")
        shutil.rmtree(out, ignore_errors=True)
    return ref_out, name, ref.lines


def sigterm_and_earlier_result(plumage, source, work, reference, table):
    """rock_dove_quick: SIGTERM at the in-plane sweep exits 143; a rerun over an earlier
    complete result, interrupted late (its last stage), leaves that result byte-identical."""
    ref_out, name, ref_lines = reference
    stages = [masked(l) for _, l in progress(ref_lines)[0][:-1]]
    sweep = next((s for s in stages if s.startswith("in-plane sweep")), stages[len(stages) // 2])
    out = work / "sigterm"
    p = (f"SIGTERM at '{sweep[:40]}'", sweep, 0, 0.0, False)
    run = interrupted_run(command(plumage, source, "rock_dove_quick", out), out, p, signal.SIGTERM)
    table.check("rock_dove_quick", p[0], run, name, 143, False)
    out = work / "over_previous"
    shutil.copytree(ref_out, out, symlinks=True)
    before = digest(out / name)
    p = (f"over an earlier result, at '{stages[-1][:30]}'", stages[-1], stages.count(stages[-1]) - 1, 0.0, False)
    run = interrupted_run(command(plumage, source, "rock_dove_quick", out), out, p)
    table.check("rock_dove_quick", p[0], run, name, 130, False)
    same = (out / name).is_dir() and digest(out / name) == before
    table.rows[-1] = table.rows[-1][:5] + (("earlier result byte-identical" if same else
                                            "earlier result CHANGED OR GONE") +
                                           ("; " + table.rows[-1][5] if table.rows[-1][5] else ""),)
    if not same:
        table.failures.append(f"rock_dove_quick, {p[0]}: the earlier result {name} changed or is gone")


def ctrl_c_at_plots(plumage, source, work, references, table):
    """Ctrl-C in a terminal signals the whole process group, the plot interpreter too: once at
    every study's first plot stage."""
    for study, (ref_out, name, ref_lines) in references.items():
        for _, line in progress(ref_lines)[0][:-1]:
            if kind(line).startswith("plot"):
                out = work / study / "group"
                p = (f"Ctrl-C (group SIGINT) at '{masked(line)[:30]}'", masked(line), 0, 0.0, False)
                run = interrupted_run(command(plumage, source, study, out), out, p, group=True)
                table.check(study, p[0], run, name, 130, False)
                break


def signal_during_startup(plumage, source, work, references, startup, table):
    """A signal before main has installed its handler ends the process by the signal itself (a
    shell shows 130 all the same) with nothing written; reported, not failed, since no handler
    can exist before main's."""
    study = next(iter(references))
    ref_out, name, _ = references[study]
    out = work / "startup"
    run = interrupted_run(command(plumage, source, study, out), out,
                          (None, None, None, startup / 4, False))
    label = f"during start-up ({startup / 4 * 1000:.0f} ms after exec)"
    if run.code == -signal.SIGINT and not leftovers(out, name) and not (out / name).exists():
        table.rows.append((study, label, f"{run.latency:.3f}", run.code, "none",
                           "killed by SIGINT before main (shell: 130); nothing written"))
    else:
        table.check(study, label, run, name, 130, False)


def report(summary, table, began):
    """The summary, the table and one FAIL line per broken promise; the exit code."""
    for line in summary:
        print(line)
    if table.rows:
        table.print()
    latencies = [float(r[2]) for r in table.rows if r[2] != "-"]
    print(f"{len(table.rows)} interrupted runs, largest signal->exit "
          f"{max(latencies) if latencies else 0:.3f} s (limit {LIMIT_S} s), "
          f"{time.monotonic() - began:.0f} s in all")
    for f in table.failures:
        print("FAIL:", f)
    print("PASS" if not table.failures else f"{len(table.failures)} failures")
    return 1 if table.failures else 0


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--plumage", required=True)
    parser.add_argument("--source", required=True, type=pathlib.Path)
    parser.add_argument("--studies", nargs="*", default=QUICK_STUDIES)
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder")
    parser.add_argument("--verbose", action="store_true", help="print stderr after each signal")
    args = parser.parse_args()
    plumage = str(pathlib.Path(args.plumage).resolve())
    source = args.source.resolve()
    work = pathlib.Path(tempfile.mkdtemp(prefix="plumage_interrupt_"))
    began = time.monotonic()
    table, summary = Table(), []
    references = {}
    try:
        startup = startup_time(plumage)
        summary.append(f"start-up (plumage --version): {startup * 1000:.0f} ms")
        for study in args.studies:
            reference = interrupt_every_stage(plumage, source, study, work, startup, table,
                                              summary, args.verbose)
            if reference is not None:
                references[study] = reference
        if "rock_dove_quick" in references:
            sigterm_and_earlier_result(plumage, source, work, references["rock_dove_quick"], table)
        ctrl_c_at_plots(plumage, source, work, references, table)
        if references:
            signal_during_startup(plumage, source, work, references, startup, table)
    finally:
        if args.keep:
            print(f"kept {work}")
        else:
            shutil.rmtree(work, ignore_errors=True)
    return report(summary, table, began)


if __name__ == "__main__":
    sys.exit(main())
