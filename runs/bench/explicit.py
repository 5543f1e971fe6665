#!/usr/bin/env python3
"""Explicit step cost per spring: cloth N = 64, 128, 256, 512 at 1 and 2 ranks, symplectic Euler.
Reads PETSc's -log_view (MSimForce: the force evaluation; MSimStep: the whole step) and
-memory_view (maximum resident memory), best of 3 runs. Writes runs/bench/explicit.csv and
explicit.png. Usage: explicit.py [ranks, e.g. 1,2]; explicit.py --plot redraws explicit.png from
explicit.csv.
Bytes per spring a force evaluation must move, as msim stores springs: the spring record (the
other end as int32, k and L as double: 20 B; the vertex is implied by its slice of four) plus the
position read and force write of the vertices (2 x 24 B per vertex), shared among the springs
per vertex (about 6 on a cloth): 28 B per spring. The slices' padding (under 1.5 % here) and the
ring and scratch rows the sums pass through (in cache) are not counted: they are the loop's
overhead; nor are the masses read for the weight m g (24 B per vertex), which would lower the
ratio.
The yardstick is the triad bandwidth of as many ranks as the run, streaming at once (stream.cpp):
ranks on one machine share its memory system (here two got 1.2-1.9x what one gets, not 2x), so
ratio_to_traffic compares the force's wall time per spring with its bytes at that bandwidth. The
bandwidth this shared machine gives moves between runs (31-38 GB/s one rank, 42-70 two), so the
triad is measured just before and just after each row's runs, and the higher of the two is the
row's yardstick (the stricter one).
core_ns_per_spring_force (wall time x ranks) is kept for comparing work across rank counts."""
import csv
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, event, write_csv  # noqa: E402
from plots import pyplot, save, style  # noqa: E402


def springs(n):
    return 2 * n * (n - 1) + 2 * (n - 1) ** 2 + 2 * n * (n - 2)



STREAM = os.path.join("/tmp", "msim_stream")


def triad(np):
    """GB/s of np ranks streaming at once (stream.cpp, built by main)"""
    return float(subprocess.run(["mpirun", "-n", str(np), STREAM], capture_output=True, text=True, check=True, env=ENV).stdout)


def plot(rows):
    """explicit.png from the rows (those of explicit.csv)"""
    ranks = sorted({r["ranks"] for r in rows})
    bw = {np: [r["triad_gb_s"] for r in rows if r["ranks"] == np] for np in ranks}
    plt = pyplot()
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for np in ranks:
        sel = [r for r in rows if r["ranks"] == np]
        ax[0].plot([r["springs"] for r in sel], [r["force_ns_per_spring"] for r in sel], "o-", label=f"force, {np} rank(s)")
        ax[0].plot([r["springs"] for r in sel], [r["step_ns_per_spring"] for r in sel], "s--", label=f"whole step, {np} rank(s)")
        ax[1].plot([r["springs"] for r in sel], [r["max_rss_mb_total"] for r in sel], "o-", label=f"{np} rank(s), all ranks")
    for np, colour in zip(ranks, ("k", "0.5")):
        sel = [r for r in rows if r["ranks"] == np]
        ax[0].plot([r["springs"] for r in sel], [2 * r["traffic_ns_per_spring"] for r in sel], ":", color=colour, lw=1.0,
                   label=f"target: 2x its bytes at {min(bw[np]):.0f}-{max(bw[np]):.0f} GB/s ({np} rank(s) at once)")
    ax[0].set_ylim(0, None)
    style(ax[0], "springs", "wall ns per spring", "Explicit step cost (symplectic Euler, cloth N x N)", xlog=True, grid=False, legend=dict(fontsize=7, loc="lower left", ncol=2))
    style(ax[1], "springs", "max resident memory (MB)", "Memory", xlog=True, ylog=True, grid=False, legend=dict(fontsize=8))
    save(fig, os.path.join(HERE, "explicit.png"), dpi=110)


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--plot":
        with open(os.path.join(HERE, "explicit.csv")) as f:
            plot([{k: (float(v) if k not in ("n", "ranks", "springs", "steps") else int(v)) for k, v in r.items()} for r in csv.DictReader(f)])
        return
    ranks = [int(x) for x in (sys.argv[1].split(",") if len(sys.argv) > 1 else ["1", "2"])]
    subprocess.run(["mpicxx", "-O3", "-march=x86-64-v2", os.path.join(HERE, "stream.cpp"), "-o", STREAM], check=True)
    rows = []
    for n in (64, 128, 256, 512):
        ns = springs(n)
        steps = max(20, int(3e8 / ns))
        for np in ranks:
            log = "/tmp/msim_bench_log.txt"
            cmd = ["mpirun", "-n", str(np), MSIM, "-msim_cloth_n", str(n), "-msim_dt", "1e-5", "-msim_steps", str(steps),
                   "-msim_spectrum_check", "0", "-msim_divergence_check_every", "1000000", "-log_view", f":{log}", "-memory_view"]
            before = triad(np)
            best = None
            for rep in range(3):
                r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
                if r.returncode:
                    sys.exit(r.stderr)
                text = open(log).read()
                if best is None or event(text, "MSimForce")[1] < event(best[0], "MSimForce")[1]:
                    best = (text, r.stdout)
            text, r.stdout = best
            after = triad(np)
            bw = max(before, after)
            print(f"triad bandwidth, {np} rank(s) at once: {before:.1f} GB/s before the row, {after:.1f} after")
            nf, tf = event(text, "MSimForce")
            nstep, tstep = event(text, "MSimStep")
            mem = re.search(r"Maximum \(over computational time\) process memory:\s+total\s+(\S+)\s+max\s+(\S+)", r.stdout)
            rss_total, rss_max = float(mem.group(1)), float(mem.group(2))
            bps = 20.0 + 48.0 * n * n / ns  # bytes per spring (docstring)
            ns_wall = tf / nf / ns * 1e9  # wall nanoseconds per spring
            ns_force = ns_wall * np  # core-nanoseconds per spring
            rows.append(dict(n=n, ranks=np, springs=ns, steps=steps, force_ns_per_spring=round(ns_wall, 3),
                             step_ns_per_spring=round(tstep / nstep / ns * 1e9, 3), core_ns_per_spring_force=round(ns_force, 3),
                             bytes_per_spring=round(bps, 1), triad_gb_s=round(bw, 2), traffic_ns_per_spring=round(bps / bw, 3),
                             ratio_to_traffic=round(ns_wall / (bps / bw), 2),
                             max_rss_mb_total=round(rss_total / 2**20, 1), max_rss_mb_per_rank=round(rss_max / 2**20, 1),
                             bytes_per_spring_rss=round(rss_total / ns, 1)))
            print(rows[-1])
    write_csv(os.path.join(HERE, "explicit.csv"), rows)
    plot(rows)


if __name__ == "__main__":
    main()
