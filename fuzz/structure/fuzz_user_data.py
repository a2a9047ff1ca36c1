#!/usr/bin/python3
"""Structure-aware fuzzer of the user-data readers (issue 42, "Records from outside";
docs/user_data.md, docs/reliability.md "Fuzzing"): well-formed HDF5 records, CSV tables and RGL
.bsdf tensor files with the wrong types, shapes, values, links and sizes, made with h5py from
valid seeds, fed to `plumage fit` and `plumage.read_record`.

    /usr/bin/python3 fuzz/structure/fuzz_user_data.py --plumage build/studies/plumage \\
        --count 600 --seed 1 --jobs 2 --work /tmp/structure [--targets record,csv,bsdf] \\
        [--findings DIR] [--only ID,ID...] [--timeout 60]

Seeds (seeds.py) are written into <work>/seeds by the script itself. Mutant ID of seed S is made
by random.Random("S:ID") alone, so `--seed S --only ID` rebuilds exactly that mutant (and runs
it), whatever --count and --jobs were.

Each mutant runs through (targets):
  record (HDF5)  `plumage fit --model huang2022 FILE --out OUT`, `... --model filip2024 ...`,
                 and plumage.read_record(FILE) in a long-lived worker subprocess (read_worker.py)
  csv            `plumage fit --model filip2024 FILE --out OUT`
  bsdf           the .bsdf reader, RglBsdf::read + eval (virtual_gonio/rgl_bsdf.h): no command
                 or Python function reads a .bsdf, so its replay harness
                 <build>/fuzz/plumage_replay_bsdf (or the libFuzzer binary plumage_fuzz_bsdf
                 of the instrumented build) is run on the file
each in a fresh empty working folder with its own TMPDIR, the input alone in its own folder,
OUT not existing before, `--threads 1` (two mutants run at once on two cores), a wall limit of
--timeout seconds (the process group is killed) and an address-space limit of
--memory-limit-mb (not under ASan, which reserves terabytes of shadow memory).

Findings:
  crash     death by a signal, or a sanitizer report (instrumented build); for read_record the
            worker process dying
  hang      a run still going at --timeout seconds that printed nothing in its last 60 s (a
            fit prints progress every 5 s; one still printing at --timeout is counted as "slow":
            a legitimate long fit of a large valid record, stopped to bound the campaign, listed
            in the table but not a finding)
  unclean   an exit code other than 0 and 2 (1: "failed", 134: abort, ...); for read_record an
            exception other than plumage.records.RecordError and FileNotFoundError
  unnamed   exit 2 whose stderr does not contain the input's path
  written   a file or folder created or changed outside OUT (the working folder, the input's
            folder, TMPDIR), or OUT present after an exit 2
  no_output exit 0 without OUT/*/parameters.json
  leak      a LeakSanitizer report (instrumented build)
Each is saved to <findings>/<ID>-<target>-<kinds>/: the input folder, description.txt (the
mutations, the command, the exit), stderr.txt, stdout.txt and reproduce.sh. The run log of every
mutant and target is <work>/results.jsonl. At the end a markdown table per target; exit 1 if
any finding.

"Variant" mutants (every mutation an equivalent encoding a reader may reasonably accept: float32
or big-endian data, fixed-length strings, chunked storage, a MATLAB user block, reordered CSV
columns, ...) that a fit rejects are listed after the table: not findings, but data users may
write.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import random
import select
import shlex
import shutil
import signal
import subprocess
import sys
import threading
import time
import traceback

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.dont_write_bytecode = True  # no __pycache__ in the source tree

import mutate_bsdf  # noqa: E402
import mutate_csv  # noqa: E402
import mutate_h5  # noqa: E402
from read_worker import RESULT_MARK  # noqa: E402
from seeds import SEEDS  # noqa: E402
from weighted import weighted  # noqa: E402

PYTHON = "/usr/bin/python3"
TARGET_ROWS = [("fit_huang2022", "record via fit huang2022"),
               ("fit_filip2024", "record via fit filip2024"),
               ("read_record", "record via plumage.read_record"),
               ("csv_filip2024", "csv via fit filip2024"),
               ("bsdf", "bsdf via RglBsdf::read (replay harness)")]
FAMILY_WEIGHTS = {"record": 0.7, "csv": 0.2, "bsdf": 0.1}
SEED_WEIGHTS = {"sc_beam.h5": 3, "sc_hemisphere.h5": 2, "sc_cone.h5": 1, "sc_minimal.h5": 2,
                "gonio.h5": 3, "brdf.csv": 2, "brdf_rgb.csv": 1, "huang.bsdf": 1,
                "filip_iso.bsdf": 1}
SANITIZER_MARKS = ("ERROR: AddressSanitizer", "ERROR: LeakSanitizer", "runtime error:",
                   "UndefinedBehaviorSanitizer", "ERROR: libFuzzer")


def log(msg):
    print(msg, flush=True)


# --------------------------------------------------------------------------------- files ---

def listing(folder):
    """{relative path: (size, mtime_ns, is_dir)} of everything under folder (links not followed)."""
    out = {}
    if not os.path.lexists(folder):
        return out
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            p = os.path.join(root, name)
            try:
                st = os.lstat(p)
            except OSError:
                continue
            out[os.path.relpath(p, folder)] = (st.st_size, st.st_mtime_ns, name in dirs)
    return out


def changes(before, after):
    new = sorted(set(after) - set(before))
    gone = sorted(set(before) - set(after))
    changed = sorted(k for k in set(before) & set(after)
                     if before[k][:2] != after[k][:2] and not before[k][2])
    return [f"+{k}" for k in new] + [f"-{k}" for k in gone] + [f"~{k}" for k in changed]


def copy_input(src_folder, dst_folder):
    """The mutant's folder, hard-linked where possible (symlinks kept as links)."""
    def link_or_copy(s, d):
        try:
            os.link(s, d)
        except OSError:
            shutil.copy2(s, d)
    shutil.copytree(src_folder, dst_folder, symlinks=True, copy_function=link_or_copy)


def read_text(path, limit=1 << 20):
    try:
        with open(path, "rb") as fh:
            data = fh.read(limit + 1)
    except OSError:
        return ""
    text = data[:limit].decode("utf-8", "replace")
    return text + ("\n[... truncated]" if len(data) > limit else "")


def contains(path, needle):
    """Whether the file contains the bytes of needle (stderr can be tens of MB)."""
    raw = needle.encode("utf-8", "surrogateescape")
    try:
        with open(path, "rb") as fh:
            tail = b""
            while True:
                block = fh.read(1 << 22)
                if not block:
                    return False
                if raw in tail + block:
                    return True
                tail = block[-len(raw):]
    except OSError:
        return False


# ------------------------------------------------------------------------------- runners ---

class Runner:
    def __init__(self, args):
        self.args = args
        self.plumage = os.path.abspath(args.plumage)
        with open(self.plumage, "rb") as fh:
            self.asan = b"__asan_init" in fh.read()
        self.memory_limit = 0 if self.asan else args.memory_limit_mb
        build = os.path.dirname(os.path.dirname(self.plumage))
        self.python_path = args.python_path or os.path.join(build, "python")
        # The build's shared libraries: a run during which one of them (or the binary) changed
        # ran against a half-written build and is run again (build_stamp).
        self.libraries = sorted(
            os.path.join(r, f) for r, ds, fs in os.walk(build)
            for f in fs if f.endswith(".so") and "/python" not in r and "CMakeFiles" not in r)
        self.bsdf_reader = args.bsdf_reader
        if not self.bsdf_reader:
            for name in ("plumage_replay_bsdf", "plumage_fuzz_bsdf"):
                p = os.path.join(build, "fuzz", name)
                if os.path.exists(p):
                    self.bsdf_reader = p
                    break

    def env(self, tmp):
        env = dict(os.environ, TMPDIR=tmp, OMP_NUM_THREADS="1", PYTHONPATH=self.python_path)
        env.setdefault("HDF5_USE_FILE_LOCKING", "TRUE")
        return env

    def prefix(self):
        if self.memory_limit:
            return ["prlimit", f"--as={self.memory_limit * 1024 * 1024}", "--"]
        return []

    def build_stamp(self, binary):
        stamp = []
        for p in [binary] + self.libraries:
            try:
                st = os.stat(p)
                stamp.append((st.st_size, st.st_mtime_ns, st.st_mode))
            except OSError:
                stamp.append(None)
        return stamp

    def binary_ready(self, binary):
        """Whether binary starts (a rebuild under way leaves it missing or its libraries short)."""
        try:
            r = subprocess.run([binary, "--version"] if binary == self.plumage else [binary],
                               capture_output=True, timeout=60)
        except (OSError, subprocess.TimeoutExpired):
            return False
        return b"error while loading shared libraries" not in r.stderr and r.returncode != 127

    def wait_for(self, binary):
        """Until binary starts and the build has not changed for 20 s."""
        waited = 0
        while True:
            stamp = self.build_stamp(binary)
            if self.binary_ready(binary):
                time.sleep(20)
                if self.build_stamp(binary) == stamp and self.binary_ready(binary):
                    return waited
            if waited % 60 == 0:
                log(f"waiting for {binary} (being rebuilt?) ...")
            time.sleep(5)
            waited += 25

    def run_process(self, cmd, run_dir, input_path, out_dir, kind):
        """Runs cmd; a run the loader could not start (a rebuild under way: exit 127, "error
        while loading shared libraries", or the binary missing) waits for the binary and is
        run again, so a rebuild is not counted as findings."""
        for attempt in range(20):
            stamp = self.build_stamp(cmd[0])
            rec = self._run_process(cmd, run_dir, input_path, out_dir, kind)
            err = read_text(os.path.join(run_dir, "stderr.txt"), 1 << 12)
            rebuilt = self.build_stamp(cmd[0]) != stamp
            if not (rebuilt or rec.get("start_failed") or (
                    rec["rc"] in (126, 127) and ("error while loading shared libraries" in err
                                                 or "prlimit: failed to execute" in err))):
                break
            rec["rebuilt_under_the_run"] = rebuilt
            for sub in ("cwd", "tmp", "out"):
                shutil.rmtree(os.path.join(run_dir, sub), ignore_errors=True)
            rec["retried"] = attempt + 1
            self.wait_for(cmd[0])
        return rec

    def _wait(self, p, t0, stderr_file):
        """Waits for p; returns (exit code, hung, slow). A hang is a run that says nothing for
        --timeout seconds (at most 60). A fit that prints progress (every 5 s) and is still going
        at --timeout is "slow": a legitimate long fit of a large valid record, stopped to bound
        the campaign, listed but not a finding."""
        last_output, last_size = t0, 0
        while True:
            try:
                return p.wait(timeout=0.5), False, False
            except subprocess.TimeoutExpired:
                pass
            now = time.monotonic()
            size = os.path.getsize(stderr_file)
            if size != last_size:
                last_output, last_size = now, size
            if now - t0 >= self.args.timeout:
                hung = now - last_output >= min(self.args.timeout, 60.0) - 1e-9 or last_size == 0
                try:
                    os.killpg(p.pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
                return p.wait(), hung, not hung

    def _run_process(self, cmd, run_dir, input_path, out_dir, kind):
        """Runs cmd in run_dir/cwd with TMPDIR run_dir/tmp; returns the run's record."""
        cwd, tmp, infolder = (os.path.join(run_dir, x) for x in ("cwd", "tmp", "in"))
        os.makedirs(cwd)
        os.makedirs(tmp)
        before = {"cwd": listing(cwd), "in": listing(infolder), "tmp": listing(tmp)}
        t0 = time.monotonic()
        with open(os.path.join(run_dir, "stdout.txt"), "wb") as so, \
                open(os.path.join(run_dir, "stderr.txt"), "wb") as se:
            try:
                p = subprocess.Popen(self.prefix() + cmd, cwd=cwd, env=self.env(tmp), stdout=so,
                                     stderr=se, stdin=subprocess.DEVNULL, start_new_session=True)
            except OSError as e:  # the binary missing for a moment (a rebuild)
                return {"rc": None, "start_failed": str(e), "seconds": 0.0, "kinds": []}
            rc, hung, slow = self._wait(p, t0, os.path.join(run_dir, "stderr.txt"))
        seconds = time.monotonic() - t0
        if rc == 127 and self.prefix() and not os.path.exists(cmd[0]):
            return {"rc": None, "start_failed": "missing", "seconds": 0.0, "kinds": []}
        after = {"cwd": listing(cwd), "in": listing(infolder), "tmp": listing(tmp)}
        stderr_path = os.path.join(run_dir, "stderr.txt")
        rec = {"rc": rc, "seconds": round(seconds, 3), "hung": hung, "slow": slow, "cmd": cmd,
               "stderr_bytes": os.path.getsize(stderr_path), "kinds": []}
        written = []
        for where in ("cwd", "in", "tmp"):
            ch = changes(before[where], after[where])
            if where == "tmp" and kind == "bsdf" and (rc != 0 or hung):
                ch = [c for c in ch if "plumage_fuzz_" not in c]  # the harness's own input copy
            written += [f"{where}:{c}" for c in ch]
        if hung:
            rec["kinds"].append("hang")
        elif slow:
            pass
        elif rc < 0:
            rec["kinds"].append("crash")
            rec["signal"] = signal.Signals(-rc).name if -rc in signal.valid_signals() else -rc
        else:
            err = read_text(stderr_path, 1 << 16)
            if "ERROR: LeakSanitizer" in err:
                rec["kinds"].append("leak")
            elif any(m in err for m in SANITIZER_MARKS):
                rec["kinds"].append("crash")
                rec["sanitizer"] = True
            elif kind == "bsdf":
                if rc != 0:
                    rec["kinds"].append("unclean")
            elif rc not in (0, 2):
                rec["kinds"].append("unclean")
            elif rc == 2 and not contains(stderr_path, input_path):
                rec["kinds"].append("unnamed")
        if out_dir is not None and not hung:
            if rc == 0 and kind != "bsdf":
                found = [r for r, _, fs in os.walk(out_dir) if "parameters.json" in fs]
                if not found:
                    rec["kinds"].append("no_output")
            elif rc != 0 and os.path.lexists(out_dir):
                written.append(f"out: {os.path.basename(out_dir)}/ exists after exit {rc}: "
                               + ", ".join(sorted(listing(out_dir))[:5]))
        if written:
            rec["kinds"].append("written")
            rec["written"] = written[:20]
        return rec


class ReadWorker:
    """One long-lived read_record process; restarted after a crash or a hang."""

    def __init__(self, runner, folder):
        self.runner, self.folder = runner, folder
        self.proc = None
        self.buffer = b""
        self.restarts = -1

    def start(self):
        cwd, tmp = os.path.join(self.folder, "cwd"), os.path.join(self.folder, "tmp")
        shutil.rmtree(cwd, ignore_errors=True)
        shutil.rmtree(tmp, ignore_errors=True)
        os.makedirs(cwd)
        os.makedirs(tmp)
        if getattr(self, "stderr", None):
            self.stderr.close()
        self.stderr = open(os.path.join(self.folder, "worker_stderr.txt"), "ab")
        self.proc = subprocess.Popen(
            [PYTHON, os.path.join(HERE, "read_worker.py"), "--memory-limit-mb",
             str(self.runner.args.memory_limit_mb)],
            cwd=cwd, env=self.runner.env(tmp), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            stderr=self.stderr, start_new_session=True)
        self.buffer = b""
        self.restarts += 1
        self.started_with = self.module_stamp()
        ready = self._answer(120)
        if not ready or ready.get("status") != "ready":
            self.stop()
            return False
        return True

    def ensure(self):
        """A running worker; waits while the module cannot be imported (a rebuild)."""
        for attempt in range(1000):
            if self.proc is not None and self.proc.poll() is None:
                return
            if self.start():
                return
            if attempt % 12 == 0:
                log(f"read_record worker does not start (plumage module being rebuilt?); "
                    f"retrying: see {self.folder}/worker_stderr.txt")
            time.sleep(5)
        raise SystemExit("read_record worker never started")

    def _answer(self, timeout):
        deadline = time.monotonic() + timeout
        fd = self.proc.stdout.fileno()
        while True:
            while b"\n" in self.buffer:
                line, self.buffer = self.buffer.split(b"\n", 1)
                text = line.decode("utf-8", "replace")
                if text.startswith(RESULT_MARK):
                    return json.loads(text[len(RESULT_MARK):])
            left = deadline - time.monotonic()
            if left <= 0:
                return None  # hang
            r, _, _ = select.select([fd], [], [], left)
            if r:
                block = os.read(fd, 65536)
                if not block:
                    return {"status": "died"}
                self.buffer += block

    def stop(self):
        if self.proc and self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            self.proc.wait()
        self.proc = None

    def module_stamp(self):
        folder = os.path.join(self.runner.python_path, "plumage")
        try:
            return sorted((f, os.stat(os.path.join(folder, f)).st_mtime_ns)
                          for f in os.listdir(folder))
        except OSError:
            return None

    def read(self, path, run_dir):
        if self.proc is not None and self.module_stamp() != self.started_with:
            self.stop()  # the module was rebuilt: read with the new one
        self.ensure()
        infolder = os.path.dirname(path)
        cwd, tmp = os.path.join(self.folder, "cwd"), os.path.join(self.folder, "tmp")
        before = {"cwd": listing(cwd), "in": listing(infolder), "tmp": listing(tmp)}
        t0 = time.monotonic()
        self.stderr.flush()
        err_start = self.stderr.tell()
        try:
            self.proc.stdin.write((json.dumps({"path": path}) + "\n").encode())
            self.proc.stdin.flush()
            ans = self._answer(self.runner.args.timeout)
        except (BrokenPipeError, OSError):
            ans = {"status": "died"}
        seconds = time.monotonic() - t0
        rec = {"seconds": round(seconds, 3), "kinds": [], "cmd": ["read_record", path]}
        if ans is None:
            rec.update(status="hang", rc="timeout", hung=True)
            rec["kinds"].append("hang")
            self.stop()
        elif ans["status"] == "died":
            rc = self.proc.wait()
            rec.update(status="died", rc=rc)
            rec["signal"] = signal.Signals(-rc).name if rc < 0 and -rc in signal.valid_signals() \
                else rc
            rec["kinds"].append("crash")
            self.proc = None
        else:
            rec.update(status=ans["status"], rc=ans["status"], type=ans.get("type"),
                       message=ans.get("message"), traceback=ans.get("traceback"))
            if ans["status"] == "exception":
                rec["kinds"].append("unclean")
        after = {"cwd": listing(cwd), "in": listing(infolder), "tmp": listing(tmp)}
        written = [f"{w}:{c}" for w in ("cwd", "in", "tmp") for c in changes(before[w], after[w])]
        if written:
            rec["kinds"].append("written")
            rec["written"] = written[:20]
        # the worker's stderr for this file
        with open(os.path.join(self.folder, "worker_stderr.txt"), "rb") as fh:
            fh.seek(err_start)
            err = fh.read(1 << 20)
        with open(os.path.join(run_dir, "stderr.txt"), "wb") as fh:
            fh.write(err)
            if rec.get("traceback"):
                fh.write(b"\n--- traceback ---\n" + rec["traceback"].encode())
            if rec.get("message"):
                fh.write(b"\n--- message ---\n" + rec["message"].encode("utf-8", "replace"))
        open(os.path.join(run_dir, "stdout.txt"), "wb").close()
        return rec


# -------------------------------------------------------------------------------- fuzzer ---

class Fuzzer:
    def __init__(self, args):
        self.args = args
        self.work = os.path.abspath(args.work)
        self.findings_dir = os.path.abspath(args.findings or os.path.join(self.work, "findings"))
        self.runner = Runner(args)
        self.families = [t for t in args.targets.split(",") if t]
        if "bsdf" in self.families and not self.runner.bsdf_reader:
            log("note: no .bsdf reader reachable (plumage_replay_bsdf / plumage_fuzz_bsdf not "
                "built): the bsdf target is skipped")
            self.families.remove("bsdf")
        self.lock = threading.Lock()
        self.stats = {t: {"tried": 0, "seconds": 0.0, "exits": collections.Counter(),
                          "kinds": collections.Counter(), "variant_rejected": []}
                      for t, _ in TARGET_ROWS}
        self.findings = []
        self.done = 0
        self.local = threading.local()
        self.workers = []
        self.results = None

    # seeds ---------------------------------------------------------------------------------
    def make_seeds(self):
        folder = os.path.join(self.work, "seeds")
        want = [n for n, (fmt, _) in SEEDS.items()
                if fmt != "bsdf" or "bsdf" in self.families]
        if all(os.path.exists(os.path.join(folder, n)) for n in want) and not self.args.reseed:
            return folder
        shutil.rmtree(folder, ignore_errors=True)
        t0 = time.monotonic()
        cmd = [PYTHON, os.path.join(HERE, "seeds.py"), "--out", folder, "--plumage",
               self.runner.plumage] + ([] if "bsdf" in self.families else ["--no-bsdf"])
        run = subprocess.run(cmd, env=dict(os.environ, PYTHONPATH=self.runner.python_path),
                             capture_output=True, text=True)
        if run.returncode != 0:
            raise SystemExit(f"seeds failed ({run.returncode}): {' '.join(cmd)}\n{run.stderr}")
        log(f"seeds written to {folder} in {time.monotonic() - t0:.1f} s")
        return folder

    def check_seeds(self, folder):
        """Every seed through its targets, unmutated: each must be accepted (exit 0)."""
        log("seed check (unmutated seeds must be accepted):")
        log("| seed | target | exit | seconds |")
        log("|---|---|---|---|")
        ok = True
        for name, (fmt, _) in SEEDS.items():
            family = {"h5": "record", "csv": "csv", "bsdf": "bsdf"}[fmt]
            if family not in self.families:
                continue
            mdir = os.path.join(self.work, "mutants", f"seed-{name}")
            shutil.rmtree(mdir, ignore_errors=True)
            os.makedirs(mdir)
            shutil.copyfile(os.path.join(folder, name), os.path.join(mdir, name))
            for target, rec in self.run_targets(f"seed-{name}", family, mdir, name):
                expect = "ok" if target == "read_record" else 0
                if target == "fit_filip2024" and SEEDS[name][1] != "goniometer":
                    expect = 2  # a scatterogram is no BRDF data
                if target == "fit_huang2022" and SEEDS[name][1] != "imaging_scatterometer":
                    expect = 2
                good = rec["rc"] == expect and not rec["kinds"]
                ok &= good
                log(f"| {name} | {target} | {rec['rc']}{'' if good else ' (UNEXPECTED)'} | "
                    f"{rec['seconds']:.2f} |")
            shutil.rmtree(mdir, ignore_errors=True)
        if not ok:
            log("warning: a seed is not accepted as it should be: mutants of it test less")
        return ok

    # one mutant ----------------------------------------------------------------------------
    def make_mutant(self, mid, seeds):
        rnd = random.Random(f"{self.args.seed}:{mid}")
        # Drawn over every family whatever --targets says, so that a mutant of an enabled family
        # is the same in a run of fewer targets (`--targets record` rebuilds the record mutants
        # of a full run); a disabled family's id gets an enabled one from another stream.
        family = weighted(rnd, list(FAMILY_WEIGHTS.items()))
        if family not in self.families:
            family = weighted(random.Random(f"{self.args.seed}:{mid}:family"),
                                         [(f, FAMILY_WEIGHTS[f]) for f in self.families])
        fmt = {"record": "h5", "csv": "csv", "bsdf": "bsdf"}[family]
        names = [(n, SEED_WEIGHTS[n]) for n, (f, _) in SEEDS.items() if f == fmt]
        seed_name = weighted(rnd, names)
        count = weighted(rnd, [(1, 0.6), (2, 0.25), (3, 0.15)])
        mdir = os.path.join(self.work, "mutants", str(mid))
        shutil.rmtree(mdir, ignore_errors=True)
        os.makedirs(mdir)
        path = os.path.join(mdir, seed_name)
        shutil.copyfile(os.path.join(seeds, seed_name), path)
        if family == "record":
            path, muts = mutate_h5.mutate(path, rnd, count, SEEDS[seed_name][1])
        elif family == "csv":
            path, muts = mutate_csv.mutate(path, rnd, count)
        else:
            path, muts = mutate_bsdf.mutate(path, rnd, count)
        return family, seed_name, mdir, os.path.basename(path), muts

    def run_targets(self, mid, family, mdir, fname):
        out = []
        runs = os.path.join(self.work, "runs")
        if family == "record":
            targets = ["fit_huang2022", "fit_filip2024", "read_record"]
        elif family == "csv":
            targets = ["csv_filip2024"]
        else:
            targets = ["bsdf"]
        for target in targets:
            run_dir = os.path.join(runs, f"{mid}-{target}")
            shutil.rmtree(run_dir, ignore_errors=True)
            os.makedirs(run_dir)
            infolder = os.path.join(run_dir, "in")
            copy_input(mdir, infolder)
            inp = os.path.join(infolder, fname)
            if target == "read_record":
                worker = getattr(self.local, "worker", None)
                if worker is None:
                    worker = ReadWorker(self.runner, os.path.join(
                        self.work, "workers", threading.current_thread().name))
                    self.local.worker = worker
                    with self.lock:
                        self.workers.append(worker)
                rec = worker.read(inp, run_dir)
            elif target == "bsdf":
                rec = self.runner.run_process([self.runner.bsdf_reader, inp], run_dir, inp,
                                              None, "bsdf")
            else:
                model = "filip2024" if target in ("fit_filip2024", "csv_filip2024") else "huang2022"
                outdir = os.path.join(run_dir, "out")
                cmd = [self.runner.plumage, "fit", "--model", model, inp, "--out", outdir,
                       "--no-plots"]
                if self.args.plumage_threads:
                    cmd += ["--threads", str(self.args.plumage_threads)]
                rec = self.runner.run_process(cmd, run_dir, inp, outdir, "fit")
            rec["target"] = target
            rec["run_dir"] = run_dir
            rec["input"] = inp
            out.append((target, rec))
        return out

    def process(self, mid, seeds):
        try:
            family, seed_name, mdir, fname, muts = self.make_mutant(mid, seeds)
        except Exception as e:  # a generator bug: reported, not a finding of plumage
            with self.lock:
                self.generator_errors.append((mid, f"{type(e).__name__}: {e}",
                                              traceback.format_exc()[-1500:]))
                self.done += 1
            return
        description = [f"mutant {mid} of seed {seed_name} (fuzz seed {self.args.seed})"] + [
            f"  - {d}{' [variant]' if v else ''}" for d, v, _ in muts]
        variant = bool(muts) and all(v for _, v, _ in muts)
        # the targets that must accept the seed (and so its variants)
        accepting = {"imaging_scatterometer": {"fit_huang2022", "read_record"},
                     "goniometer": {"fit_filip2024", "read_record"}}.get(
            SEEDS[seed_name][1], {"csv_filip2024", "bsdf"})
        results = self.run_targets(mid, family, mdir, fname)
        with self.lock:
            self.done += 1
            for target, rec in results:
                st = self.stats[target]
                st["tried"] += 1
                st["seconds"] += rec["seconds"]
                key = rec["rc"] if not (rec.get("hung") or rec.get("slow")) else \
                    ("timeout" if rec.get("hung") else "slow")
                if isinstance(key, int) and key < 0:
                    key = rec.get("signal", key)
                st["exits"][str(key)] += 1
                for k in rec["kinds"]:
                    st["kinds"][k] += 1
                if variant and target in accepting and rec["rc"] not in (0, "ok") \
                        and not rec["kinds"]:
                    st["variant_rejected"].append((mid, "; ".join(d for d, _, _ in muts),
                                                   first_error_line(rec)))
                entry = {"id": mid, "seed": seed_name, "target": target,
                         "binary": binary_stamp(self.runner.plumage),
                         "mutations": [{"op": o, "desc": d, "variant": v} for d, v, o in muts],
                         **{k: rec.get(k) for k in ("rc", "seconds", "kinds", "signal", "type",
                                                    "message", "written", "stderr_bytes")}}
                if target != "read_record":
                    entry["stderr_head"] = first_error_line(rec)
                self.results.write(json.dumps(entry, default=str) + "\n")
                self.results.flush()
                if rec["kinds"]:
                    self.save_finding(mid, target, rec, description, mdir, fname)
        for _, rec in results:
            if not self.args.keep_runs:
                shutil.rmtree(rec["run_dir"], ignore_errors=True)
        if not self.args.keep_runs:
            shutil.rmtree(mdir, ignore_errors=True)

    def save_finding(self, mid, target, rec, description, mdir, fname):
        name = f"{mid}-{target}-{'+'.join(rec['kinds'])}"
        folder = os.path.join(self.findings_dir, name)
        shutil.rmtree(folder, ignore_errors=True)
        os.makedirs(folder)
        copy_input(mdir, os.path.join(folder, "input"))
        for f in ("stderr.txt", "stdout.txt"):
            src = os.path.join(rec["run_dir"], f)
            if os.path.exists(src):
                with open(src, "rb") as a, open(os.path.join(folder, f), "wb") as b:
                    b.write(a.read(1 << 20))
        inp = os.path.join(folder, "input", fname)
        if target == "read_record":
            repro = (f"cd \"$(mktemp -d)\" && PYTHONPATH={shlex.quote(self.runner.python_path)} "
                     f"{PYTHON} -c 'import sys, plumage; print(plumage.read_record(sys.argv[1]))' "
                     f"{shlex.quote(inp)}")
        else:
            cmd = [inp if c == rec["input"] else c for c in rec["cmd"]]
            if "--out" in cmd:
                cmd[cmd.index("--out") + 1] = "out"
            repro = f"cd \"$(mktemp -d)\" && TMPDIR=$PWD {shlex.join(cmd)}"
        again = (f"{PYTHON} {os.path.join(HERE, 'fuzz_user_data.py')} --plumage "
                 f"{shlex.quote(self.runner.plumage)} --seed {self.args.seed} --only {mid} "
                 f"--targets {self.args.targets} --work {shlex.quote(self.work)}-again")
        with open(os.path.join(folder, "reproduce.sh"), "w") as fh:
            fh.write(f"#!/bin/sh\n# {target}: {', '.join(rec['kinds'])}\n{repro}\n"
                     f"# or rebuild the mutant from its seed:\n# {again}\n")
        info = description + [
            f"target: {target}", f"command: {shlex.join(str(c) for c in rec['cmd'])}",
            (f"exit: killed at the {self.args.timeout:.0f} s limit" if rec.get("hung") else
             f"exit: {rec.get('rc')}" + (f" (signal {rec['signal']})" if rec.get("signal") else "")
             + f" after {rec['seconds']} s"),
            f"findings: {', '.join(rec['kinds'])}"]
        if rec.get("written"):
            info += ["written outside --out:"] + [f"  {w}" for w in rec["written"]]
        if rec.get("type"):
            info.append(f"exception: {rec['type']}: {rec.get('message')}")
        with open(os.path.join(folder, "description.txt"), "w") as fh:
            fh.write("\n".join(info) + "\n")
        self.findings.append({"id": mid, "target": target, "kinds": rec["kinds"],
                              "folder": folder, "description": description,
                              "error": first_error_line(rec)})

    # the campaign --------------------------------------------------------------------------
    def run(self):
        os.makedirs(self.work, exist_ok=True)
        os.makedirs(self.findings_dir, exist_ok=True)
        self.generator_errors = []
        self.runner.wait_for(self.runner.plumage)
        self.binary_at_start = binary_stamp(self.runner.plumage)
        seeds = self.make_seeds()
        t0 = time.monotonic()
        self.results = open(os.path.join(self.work, "results.jsonl"), "a")
        if not self.args.only and not self.args.no_seed_check:
            self.check_seeds(seeds)
        if self.args.only:
            ids = [int(x) for x in self.args.only.split(",")]
        else:
            ids = list(range(self.args.first, self.args.first + self.args.count))
        log(f"fuzzing {len(ids)} mutants (fuzz seed {self.args.seed}, ids {ids[0]}..{ids[-1]}), "
            f"{self.args.jobs} jobs, targets {','.join(self.families)}, timeout "
            f"{self.args.timeout} s, memory limit "
            f"{'none (ASan build)' if self.runner.asan else f'{self.args.memory_limit_mb} MB'}")
        start = time.monotonic()
        stop = threading.Event()

        def progress():
            while not stop.wait(30):
                with self.lock:
                    el = time.monotonic() - start
                    kinds = collections.Counter(k for f in self.findings for k in f["kinds"])
                    log(f"[{el:6.0f} s] mutants {self.done}/{len(ids)} "
                        f"({self.done / el * 60:.1f}/min), findings {len(self.findings)} "
                        f"({', '.join(f'{k} {n}' for k, n in sorted(kinds.items())) or 'none'})")
        threading.Thread(target=progress, daemon=True).start()
        queue = collections.deque(ids)
        qlock = threading.Lock()

        def worker_loop():
            while True:
                with qlock:
                    if self.args.max_seconds and time.monotonic() - start > self.args.max_seconds:
                        queue.clear()  # the time budget is spent: no new mutant
                    if not queue:
                        return
                    mid = queue.popleft()
                self.process(mid, seeds)
        threads = [threading.Thread(target=worker_loop, name=f"job{j}")
                   for j in range(self.args.jobs)]
        try:
            for t in threads:
                t.start()
            for t in threads:
                t.join()
        except KeyboardInterrupt:
            queue.clear()
            log("interrupted: finishing the mutants under way")
            for t in threads:
                t.join()
        stop.set()
        for w in self.workers:
            w.stop()
        wall = time.monotonic() - start
        self.results.close()
        self.report(wall, len(ids), time.monotonic() - t0)
        if self.args.summary_json:
            kinds = collections.Counter(k for st in self.stats.values() for k in st["kinds"])
            with open(self.args.summary_json, "w") as fh:
                json.dump({"mutants": self.done, "wall_s": round(wall, 1),
                           "runs": sum(st["tried"] for st in self.stats.values()),
                           "findings": len(self.findings), **{k: kinds[k] for k in (
                               "crash", "hang", "unclean", "unnamed", "written", "no_output",
                               "leak")}, "findings_dir": self.findings_dir}, fh)
        return 1 if self.findings else 0

    def report(self, wall, n, total):
        a = self.args
        base = (f"{PYTHON} fuzz/structure/fuzz_user_data.py --plumage {shlex.quote(a.plumage)} "
                f"--seed {a.seed} --jobs {a.jobs} --work {shlex.quote(a.work)}")
        log("")
        log(f"## Structure fuzzing: {self.done} mutants in {wall:.0f} s wall "
            f"({self.done / max(wall, 1e-9) * 60:.1f} mutants/min, {a.jobs} jobs; "
            f"{total:.0f} s with the seeds and their check)")
        log("")
        log("| target | runs | run time (sum) | s/run | exits | crashes | hangs | unclean | "
            "unnamed exit 2 | written outside --out | no output | leaks | reproduce |")
        log("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        fam = {"fit_huang2022": "record", "fit_filip2024": "record", "read_record": "record",
               "csv_filip2024": "csv", "bsdf": "bsdf"}
        for t, label in TARGET_ROWS:
            st = self.stats[t]
            if fam[t] not in self.families:
                continue
            ex = " ".join(f"{k}:{v}" for k, v in sorted(st["exits"].items()))
            k = st["kinds"]
            log(f"| {label} | {st['tried']} | {st['seconds']:.0f} s | "
                f"{st['seconds'] / max(st['tried'], 1):.2f} | {ex} | {k['crash']} | {k['hang']} | "
                f"{k['unclean']} | {k['unnamed']} | {k['written']} | {k['no_output']} | "
                f"{k['leak']} | `{base} --count {n} --targets {fam[t]}` |")
        log("")
        now = binary_stamp(self.runner.plumage)
        if now != self.binary_at_start:
            log(f"note: {a.plumage} changed during the run ({self.binary_at_start} -> {now}: "
                "rebuilt): the mutants ran against more than one build (results.jsonl, "
                "'binary', says which)\n")
        if self.findings:
            log(f"{len(self.findings)} findings in {self.findings_dir} (description.txt and "
                "reproduce.sh in each):")
            groups = collections.defaultdict(list)
            for f in self.findings:
                groups[(f["target"], "+".join(f["kinds"]))].append(f)
            for (t, k), fs in sorted(groups.items()):
                log(f"- {t} {k}: {len(fs)}, e.g. mutant {fs[0]['id']}: "
                    f"{' '.join(x.strip() for x in fs[0]['description'][1:])[:300]} -> "
                    f"{fs[0]['error'][:200]}")
        else:
            log("no findings")
        for t, label in TARGET_ROWS:
            rej = self.stats[t]["variant_rejected"]
            if rej:
                log(f"\nvariants (equivalent encodings) rejected by {label}: {len(rej)} "
                    "(not findings; data users may write):")
                for mid, d, err in rej[:15]:
                    log(f"- mutant {mid}: {d[:160]} -> {err[:160]}")
        if self.generator_errors:
            log(f"\n{len(self.generator_errors)} mutants not made (generator errors, a bug of "
                "the fuzzer, not of plumage):")
            for mid, e, tb in self.generator_errors[:10]:
                log(f"- mutant {mid}: {e}")


def binary_stamp(path):
    try:
        st = os.stat(path)
        return f"{st.st_size}@{time.strftime('%H:%M:%S', time.localtime(st.st_mtime))}"
    except OSError:
        return "missing"


def first_error_line(rec):
    if rec.get("type"):
        return f"{rec['type']}: {rec.get('message') or ''}".splitlines()[0][:300]
    if rec.get("hung"):
        return f"killed after {rec['seconds']:.0f} s"
    err = read_text(os.path.join(rec["run_dir"], "stderr.txt"), 1 << 16)
    lines = [l for l in err.splitlines() if l.strip() and not l.startswith("replaying ")]
    head = next((l for l in lines if "rror" in l or "what()" in l or "terminate" in l),
                lines[0] if lines else "")
    sig = f"signal {rec['signal']}: " if rec.get("signal") else ""
    return (sig + head)[:300]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--plumage", required=True, help="the plumage binary")
    ap.add_argument("--count", type=int, default=100, help="mutants (default 100)")
    ap.add_argument("--first", type=int, default=0, help="first mutant id (default 0)")
    ap.add_argument("--seed", type=int, default=1, help="the fuzz seed (default 1)")
    ap.add_argument("--jobs", type=int, default=2, help="mutants at once (default 2)")
    ap.add_argument("--work", required=True, help="work folder (seeds, runs, findings)")
    ap.add_argument("--targets", default="record,csv,bsdf", help="record,csv,bsdf (default all)")
    ap.add_argument("--findings", help="findings folder (default WORK/findings)")
    ap.add_argument("--only", help="comma-separated mutant ids: rebuild and run just these")
    ap.add_argument("--timeout", type=float, default=60.0, help="wall limit per run, s (60)")
    ap.add_argument("--memory-limit-mb", type=int, default=6144,
                    help="address-space limit per process (default 6144; 0: none; ignored "
                         "for an ASan build)")
    ap.add_argument("--plumage-threads", type=int, default=1,
                    help="--threads of each fit (default 1; 0: plumage's default)")
    ap.add_argument("--python-path", help="folder holding the plumage module (default "
                    "<build>/python, the build of --plumage)")
    ap.add_argument("--bsdf-reader", help="the .bsdf reader (default <build>/fuzz/"
                    "plumage_replay_bsdf or plumage_fuzz_bsdf)")
    ap.add_argument("--reseed", action="store_true", help="rewrite the seeds")
    ap.add_argument("--no-seed-check", action="store_true")
    ap.add_argument("--keep-runs", action="store_true", help="keep every run folder")
    ap.add_argument("--max-seconds", type=float, default=0,
                    help="start no new mutant after this many seconds (default 0: no limit)")
    ap.add_argument("--summary-json", help="also write the totals here (scripts/fuzz.sh)")
    args = ap.parse_args()
    if not os.path.exists(args.plumage):
        ap.error(f"{args.plumage}: no such file (build it first)")
    return Fuzzer(args).run()


if __name__ == "__main__":
    sys.exit(main())
