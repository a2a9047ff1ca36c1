#!/usr/bin/python3
"""Issue 19: one rank of an MPI job SIGKILLed mid-run; the job stops naming that rank, nothing
half-written is left, and the rerun resumes the finished chunks and writes records equal to an
uninterrupted run's bit for bit (wall-time values aside: scripts/compare_records.py).

    kill_rank_resume.py --plumage BUILD/studies/plumage --source REPO --mpiexec MPIEXEC

The study is ablation_quick with 5x its quanta (15 values, one chunk each, ~1 s each). Two
kills in a row in one results root: rank 1 once a few values are checkpointed, then rank 0 (the
one that deals and writes) once a few more are; then the rerun, with 3 ranks (a resumed job need
not have the rank count of the killed one). Reference: the same study in one process, no launcher.
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


def chunks(folder):
    return sorted(folder.glob("chunk-*.bin")) if folder.exists() else []


def kill_rank_when(cmd, checkpoints, rank, at_least):
    """Runs cmd; SIGKILLs `rank` once `at_least` chunks are checkpointed. (exit code, stderr)."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while len(chunks(checkpoints)) < at_least and proc.poll() is None:
        if time.monotonic() > deadline:
            proc.kill()
            raise RuntimeError("no checkpoints appeared in 120 s")
        time.sleep(0.02)
    pid = rank_pid(proc.pid, rank)
    if pid is None:
        proc.kill()
        raise RuntimeError(f"rank {rank} not found among the launcher's children (finished first?)")
    os.kill(pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=60)
    return proc.returncode, err


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--plumage", required=True)
    parser.add_argument("--source", required=True, type=pathlib.Path)
    parser.add_argument("--mpiexec", required=True)
    args = parser.parse_args()
    work = pathlib.Path(tempfile.mkdtemp(prefix="plumage_mpi_kill_"))
    os.environ["TMPDIR"] = str(work / "tmp")  # the ranks' scratch folders, checked at the end
    (work / "tmp").mkdir()
    failures = []
    try:
        text = (args.source / "studies/ablation_quick.toml").read_text()
        text = re.sub(r'^name = .*$', 'name = "ablation_kill"', text, flags=re.M)
        text = re.sub(r"^quanta_per_pass = 6000$", "quanta_per_pass = 30000", text, flags=re.M)
        assert "quanta_per_pass = 30000" in text, "ablation_quick.toml changed: update the edit"
        study = work / "ablation_kill.toml"
        study.write_text(text)
        run = [args.plumage, "run", str(study), "--threads", "1", "--no-plots", "--out"]
        began = time.monotonic()
        reference = subprocess.run(run + [str(work / "reference")], capture_output=True, text=True)
        if reference.returncode != 0:
            print(reference.stderr)
            return 1
        print(f"reference (one process): {time.monotonic() - began:.1f} s")
        out = work / "out"
        checkpoints = out / ".checkpoints/ablation_kill/values"
        for rank, at_least in ((1, 3), (0, 7)):
            began = time.monotonic()
            code, err = kill_rank_when(launcher(args.mpiexec, 2) + run + [str(out)], checkpoints,
                                       rank, at_least)
            kept = len(chunks(checkpoints))
            named = re.search(rf"process rank {rank} with PID \d+ on node \S+ exited on signal 9",
                              err)
            print(f"rank {rank} killed with {at_least}+ values checkpointed: exit {code} after "
                  f"{time.monotonic() - began:.1f} s, {kept} values kept; mpirun: "
                  f"{named.group(0) if named else 'NO MESSAGE NAMING THE RANK'}")
            if code == 0 or not named:
                failures.append(f"rank {rank}: exit {code}, stderr:\n{err[-1500:]}")
            if (out / "ablation_kill").exists():
                failures.append(f"rank {rank}: a results folder appeared from a killed job")
            temporary = [p.name for p in checkpoints.iterdir() if not p.name.endswith(".bin")]
            if temporary:
                failures.append(f"rank {rank}: half-written checkpoints {temporary}")
        kept = len(chunks(checkpoints))
        began = time.monotonic()
        rerun = subprocess.run(launcher(args.mpiexec, 3) + run + [str(out)], capture_output=True,
                               text=True)
        resumed = re.search(r"(\d+) values resumed from", rerun.stderr)
        print(f"rerun on 3 ranks: exit {rerun.returncode} after {time.monotonic() - began:.1f} s, "
              f"{resumed.group(1) if resumed else 'no'} values resumed ({kept} were kept)")
        if rerun.returncode != 0 or not resumed or int(resumed.group(1)) != kept:
            failures.append(f"rerun: exit {rerun.returncode}, stderr:\n{rerun.stderr[-1500:]}")
        left = sorted(p.name for p in out.iterdir() if p.name != "ablation_kill")
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
