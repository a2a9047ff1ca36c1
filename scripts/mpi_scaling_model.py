#!/usr/bin/python3
"""How a study's time scales with MPI ranks (issue 19), modelled from one measured run.

    PLUMAGE_CHUNK_LOG=chunks.csv build/studies/plumage run studies/ablation.toml --threads 1 \\
        --no-plots --out results_1rank
    scripts/mpi_scaling_model.py chunks.csv results_1rank/ablation/stages.csv --out DIR

Inputs, all measured: every chunk's CPU time and result size (chunks.csv, written by
common/distributed.cpp), and the run's total CPU time (stages.csv). CPU time, not wall time:
on a shared machine a process waits for a core, and CPU time is what the work costs on a core
of its own (at one thread per rank the two agree on an idle machine).

Model of a run on N ranks (one per node, one thread each; a node's threads divide every term
but the messages by its thread speed-up, measured at 1.8-1.97x for 2 threads: README):
  serial     S = total CPU - sum of chunk CPU: the stages every rank runs alone (reading,
             light stages, and rank 0's records, images and report), the same for any N;
  dealt      the makespan of dealing the chunks in index order to whichever rank is free first
             (common/distributed.h's dealer), each chunk costing its CPU time plus a
             request/reply round trip (2 alpha + the dealer's 0.1 ms poll) and its result message
             to rank 0 (alpha + bytes / beta); rank 0 receives all results through one link, so
             the dealt time is at least sum(bytes) / beta;
  broadcast  every chunk's results back to every rank: a binomial tree, log2(N) (alpha + B / beta)
             for B bytes in all.
Interconnects (stated assumptions, not measured here): InfiniBand EDR (100 Gb/s = 12.5 GB/s
line rate; alpha = 1.5 us, beta = 10 GB/s achieved by MPI), and 10 Gigabit Ethernet over TCP
(10 Gb/s = 1.25 GB/s line rate; alpha = 50 us, beta = 1.0 GB/s).
Writes scaling.csv and scaling.png in DIR and prints the table (markdown).
"""
import argparse
import csv
import heapq
import math
import pathlib

INTERCONNECTS = {
    "InfiniBand EDR": (1.5e-6, 10e9),
    "10 GbE (TCP)": (50e-6, 1.0e9),
}
DEALER_POLL_S = 1e-4  # common/distributed.cpp: the dealing thread polls every 100 us
RANKS = [1, 2, 4, 8, 16, 32, 64]


def read_chunks(path):
    calls = {}
    with open(path) as f:
        for row in csv.DictReader(f):
            if int(row["chunk"]) < 0:
                continue
            calls.setdefault(int(row["call"]), []).append(
                (int(row["chunk"]), float(row["cpu_s"]), int(row["result_bytes"])))
    return [sorted(chunks) for _, chunks in sorted(calls.items())]


def total_cpu(stages):
    with open(stages) as f:
        return sum(float(row["cpu time (s)"]) for row in csv.DictReader(f))


def dealt_time(chunks, ranks, alpha, beta):
    """Greedy list scheduling in chunk order onto `ranks` workers, with message costs."""
    if ranks == 1:
        return sum(cpu for _, cpu, _ in chunks)  # one process: no messages at all
    free = [0.0] * ranks
    for _, cpu, size in chunks:
        start = heapq.heappop(free)
        heapq.heappush(free, start + cpu + 2 * alpha + DEALER_POLL_S + alpha + size / beta)
    gather = sum(size for _, _, size in chunks) / beta
    return max(max(free), gather)


def broadcast_time(chunks, ranks, alpha, beta):
    if ranks == 1:
        return 0.0
    size = sum(s for _, _, s in chunks)
    return math.ceil(math.log2(ranks)) * (alpha + size / beta)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("chunks", help="PLUMAGE_CHUNK_LOG of a one-rank run")
    parser.add_argument("stages", help="stages.csv of the same run")
    parser.add_argument("--out", default=".", type=pathlib.Path)
    parser.add_argument("--title", default="ablation study (studies/ablation.toml)")
    args = parser.parse_args()
    calls = read_chunks(args.chunks)
    chunk_cpu = sum(cpu for call in calls for _, cpu, _ in call)
    serial = max(0.0, total_cpu(args.stages) - chunk_cpu)
    n_chunks = sum(len(c) for c in calls)
    longest = max(cpu for call in calls for _, cpu, _ in call)
    result_bytes = sum(s for call in calls for _, _, s in call)
    rows = []
    for name, (alpha, beta) in INTERCONNECTS.items():
        t1 = serial + sum(dealt_time(c, 1, alpha, beta) for c in calls)
        for n in RANKS:
            t = serial + sum(dealt_time(c, n, alpha, beta) + broadcast_time(c, n, alpha, beta)
                             for c in calls)
            rows.append({"interconnect": name, "ranks": n, "time_s": t, "speedup": t1 / t,
                         "efficiency": t1 / t / n})
    args.out.mkdir(parents=True, exist_ok=True)
    with open(args.out / "scaling.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0]))
        writer.writeheader()
        for r in rows:
            writer.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    print(f"measured: {n_chunks} chunks in {len(calls)} dealt call(s), {chunk_cpu:.1f} CPU s in "
          f"chunks (longest {longest:.1f} s), serial {serial:.1f} s, "
          f"{result_bytes / 1e6:.1f} MB of results")
    print("| ranks | " + " | ".join(f"{name}: time (s), speed-up, efficiency"
                                     for name in INTERCONNECTS) + " |")
    print("|---|" + "---|" * len(INTERCONNECTS))
    for n in RANKS:
        cells = [r for r in rows if r["ranks"] == n]
        print(f"| {n} | " + " | ".join(f"{r['time_s']:.3g}, {r['speedup']:.2f}x, "
                                       f"{100 * r['efficiency']:.0f} %" for r in cells) + " |")

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax_t, ax_e) = plt.subplots(1, 2, figsize=(10, 4.2))
    for name, marker in zip(INTERCONNECTS, "os"):
        cells = [r for r in rows if r["interconnect"] == name]
        ax_t.plot([r["ranks"] for r in cells], [r["time_s"] for r in cells], marker=marker,
                  label=f"model, {name}")
        ax_e.plot([r["ranks"] for r in cells], [100 * r["efficiency"] for r in cells],
                  marker=marker, label=f"model, {name}")
    t1 = rows[0]["time_s"]
    ax_t.plot(RANKS, [t1 / n for n in RANKS], "k:", label="ideal T(1)/N")
    ax_t.axhline(serial + longest, color="grey", ls="--",
                 label=f"floor: serial + longest chunk ({serial + longest:.0f} s)")
    ax_t.set(xscale="log", yscale="log", xlabel="MPI ranks (one per node, 1 thread each)",
             ylabel="time per study (s)", title="Modelled time per study")
    ax_e.axvline(n_chunks, color="grey", ls="--", label=f"{n_chunks} chunks")
    ax_e.set(xscale="log", xlabel="MPI ranks (one per node, 1 thread each)",
             ylabel="parallel efficiency T(1) / (N T(N)) (%)", ylim=(0, 105),
             title="Modelled efficiency")
    for ax in (ax_t, ax_e):
        ax.set_xticks(RANKS, [str(n) for n in RANKS])
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"MPI scaling of the {args.title}, from measured chunk CPU times")
    fig.tight_layout()
    fig.savefig(args.out / "scaling.png", dpi=110)


if __name__ == "__main__":
    main()
