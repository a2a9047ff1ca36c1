#!/usr/bin/python3
"""Issue 19: one rank of an MPI job SIGKILLed mid-run; the job stops naming that rank, nothing
half-written is left, and the rerun resumes the finished chunks and writes records equal to an
uninterrupted run's bit for bit (wall-time values aside: scripts/compare_records.py).

    kill_rank_resume.py --plumage BUILD/studies/plumage --source REPO --mpiexec MPIEXEC [--case C]

--case ablation (default): ablation_quick with 5x its quanta (15 values, one chunk each, ~1 s
each). Two kills in a row in one results root: rank 1 once a few values are checkpointed, then
rank 0 (the one that deals and writes) once a few more are.
--case goniometer: the single-process kill test's rock_dove_quick, its BRDF in 6 checkpointed
passes dealt over the ranks; rank 1 killed once the first pass is checkpointed.
Then the rerun: on 3 ranks for the ablation (a resumed job need not have the rank count of the
killed one), on 2 for the goniometer (its other stages run on every rank).
Reference: the same study in one process, no launcher.
"""
import argparse
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time


def launcher(mpiexec, ranks):
    cmd = [mpiexec, "--oversubscribe", "-np", str(ranks)]
    if os.geteuid() == 0:
        cmd.append("--allow-run-as-root")
    return cmd


def rank_pid(launcher_pid, rank):
    """The pid of `rank` among the launcher's children (Open MPI's environment names it)."""
    for proc in pathlib.Path("/proc").iterdir():
        if not proc.name.isdigit():
            continue
        try:
            stat = (proc / "stat").read_text()
            parent = int(stat[stat.rindex(")") + 2:].split()[1])
            environ = (proc / "environ").read_bytes().split(b"\0")
        except (OSError, ValueError):
            continue
        if parent == launcher_pid and f"OMPI_COMM_WORLD_RANK={rank}".encode() in environ:
            return int(proc.name)
    return None


def kill_rank_when(cmd, chunks, checkpoints, rank, at_least):
    """Runs cmd; SIGKILLs `rank` once this job has written `at_least` checkpoint files (exit,
    stderr). Only files written since the launch count: those a killed job kept would satisfy the
    count before mpirun has started the ranks, and the goniometer's single checkpoint file is
    rewritten in place, so neither the total nor "kept + n" works for both cases."""
    launched = time.time()
    written = lambda: [p for p in chunks(checkpoints) if modified(p) > launched]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while len(written()) < at_least and proc.poll() is None:
        if time.monotonic() > deadline:
            proc.kill()
            raise RuntimeError("no checkpoints appeared in 120 s")
        time.sleep(0.02)
    pid = rank_pid(proc.pid, rank)
    if pid is None:
        proc.kill()
        raise RuntimeError(f"rank {rank} not found among the launcher's children (finished first?)")
    ranks = [r for r in (rank_pid(proc.pid, n) for n in range(8)) if r is not None]
    os.kill(pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    # The job's other ranks end within Open MPI's SIGTERM-then-SIGKILL second; the rerun comes
    # after (a rank still running would rightly keep its folders from the rerun's clean-up).
    deadline = time.monotonic() + 15
    while any(running(r) for r in ranks) and time.monotonic() < deadline:
        time.sleep(0.1)
    return proc.returncode, err


def modified(path):
    """The file's modification time, or 0 once it is gone (renamed over between glob and stat)."""
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0


def running(pid):
    try:
        stat = pathlib.Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return stat[stat.rindex(")") + 2] != "Z"


# The two cases: the study text, its name, where its checkpoints appear, how many are there
# before each kill (rank, count), how the rerun says what it resumed, and the rerun's ranks (the
# goniometer case reruns on 2: its scatterograms are not dealt, and 3 ranks on 2 cores triple them).
def ablation_case(source):
    text = (source / "studies/ablation_quick.toml").read_text()
    text = re.sub(r'^name = .*$', 'name = "ablation_kill"', text, flags=re.M)
    text = re.sub(r"^quanta_per_pass = 6000$", "quanta_per_pass = 30000", text, flags=re.M)
    assert "quanta_per_pass = 30000" in text, "ablation_quick.toml changed: update the edit"
    return (text, "ablation_kill", ".checkpoints/ablation_kill/values", "chunk-*.bin",
            ((1, 3), (0, 5)), r"(\d+) values resumed from", 3)


def goniometer_case(source):
    # The single-process kill test's study: rock_dove_quick with its BRDF on the 61 x 60 set in
    # 6 checkpointed passes; rank 1 killed once the first pass is checkpointed.
    sys.path.insert(0, str(source / "tests/reliability"))
    import kill_resume_test
    return (kill_resume_test.study_text(source), "rock_dove_quick", ".checkpoints/rock_dove_quick",
            "brdf_simulation.checkpoint", ((1, 1),), r"resuming after (\d+) completed passes", 2)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plumage", required=True)
    parser.add_argument("--source", required=True, type=pathlib.Path)
    parser.add_argument("--mpiexec", required=True)
    parser.add_argument("--case", choices=["ablation", "goniometer"], default="ablation")
    args = parser.parse_args()
    text, name, kept_in, pattern, kills, resumed_line, rerun_ranks = (
        ablation_case if args.case == "ablation" else goniometer_case)(args.source)
    work = pathlib.Path(tempfile.mkdtemp(prefix="plumage_mpi_kill_"))
    os.environ["TMPDIR"] = str(work / "tmp")  # the ranks' scratch folders, checked at the end
    (work / "tmp").mkdir()
    failures = []
    try:
        study = work / f"{name}.toml"
        study.write_text(text)
        run = [args.plumage, "run", str(study), "--threads", "1", "--no-plots", "--out"]
        began = time.monotonic()
        reference = subprocess.run(run + [str(work / "reference")], capture_output=True, text=True)
        if reference.returncode != 0:
            print(reference.stderr)
            return 1
        print(f"reference (one process): {time.monotonic() - began:.1f} s")
        out = work / "out"
        checkpoints = out / kept_in
        chunks = lambda folder: sorted(folder.glob(pattern)) if folder.exists() else []
        for rank, at_least in kills:
            began = time.monotonic()
            code, err = kill_rank_when(launcher(args.mpiexec, 2) + run + [str(out)], chunks,
                                       checkpoints, rank, at_least)
            kept = len(chunks(checkpoints))
            named = re.search(rf"process rank {rank} with PID \d+ on node \S+ exited on signal 9",
                              err)
            print(f"rank {rank} killed with {at_least}+ checkpoints: exit {code} after "
                  f"{time.monotonic() - began:.1f} s, {kept} kept; mpirun: "
                  f"{named.group(0) if named else 'NO MESSAGE NAMING THE RANK'}")
            if code == 0 or not named:
                failures.append(f"rank {rank}: exit {code}, stderr:\n{err[-1500:]}")
            if (out / name).exists():
                failures.append(f"rank {rank}: a results folder appeared from a killed job")
            temporary = [p.name for p in checkpoints.iterdir() if ".tmp" in p.name]
            if temporary:
                failures.append(f"rank {rank}: half-written checkpoints {temporary}")
        began = time.monotonic()
        rerun = subprocess.run(launcher(args.mpiexec, rerun_ranks) + run + [str(out)],
                               capture_output=True, text=True)
        resumed = re.search(resumed_line, rerun.stderr)
        print(f"rerun on {rerun_ranks} ranks: exit {rerun.returncode} after {time.monotonic() - began:.1f} s, "
              f"resumed: {resumed.group(0) if resumed else 'nothing'}")
        if rerun.returncode != 0 or not resumed or int(resumed.group(1)) < 1:
            failures.append(f"rerun: exit {rerun.returncode}, stderr:\n{rerun.stderr[-1500:]}")
        left = sorted(p.name for p in out.iterdir() if p.name != name)
        left += [p.name for p in (work / "tmp").glob("plumage-scratch-*")]
        if left:
            failures.append(f"left behind after the rerun: {left}")
        diff = subprocess.run(["/usr/bin/python3", str(args.source / "scripts/compare_records.py"),
                               str(work / "reference"), str(out)], capture_output=True, text=True)
        print(diff.stdout.strip().splitlines()[-1] if diff.stdout.strip() else diff.stderr)
        if diff.returncode != 0:
            failures.append("records differ from the uninterrupted run's:\n" + diff.stdout[-1500:])
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
