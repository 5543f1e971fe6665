#!/usr/bin/env python3
"""The volume term on the bunny (examples/bunny.opts) and on a squashed box: inverted tets per frame
with and without it, its cost per step (CPU time, alternated runs), and what it changes in the
explicit limit (Gershgorin bound msim prints, and SLEPc's omega_max of (K, M) with the term's
Hessian in K).
Usage: study.py [path/to/msim] [inverted|cost|limit|steps[:N[:msim-before]]] (default build/msim,
all but steps); writes inverted.csv (springs alone, the full term, the barrier alone), cost.csv, limit.csv and inverted.png here, and stepsN.csv
(the per-step CPU user time over N bunny steps at 1 rank, steps-only by difference with a 1-step
run, min of 3 alternated repetitions). Steps: 45 of the bunny's 150 (the inversions start at step 9), 2 ranks."""
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tools"))
import msimrun  # noqa: E402
import tetcheck  # noqa: E402

MSIM = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else msimrun.MSIM
ROOT = msimrun.ROOT
MPI = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-q", "-n"]


def run(args, np):
    """(stdout+stderr, user+system CPU seconds of msim's ranks, wall seconds)"""
    t0, r0 = time.time(), os.times()
    p = subprocess.run((MPI + [str(np)] if np > 1 else []) + [MSIM] + args, cwd=ROOT, env=msimrun.ENV, capture_output=True, text=True)
    r1 = os.times()
    if p.returncode:
        sys.exit(f"msim failed: {' '.join(args)}\n{p.stderr[-2000:]}")
    return p.stdout + p.stderr, (r1.children_user - r0.children_user) + (r1.children_system - r0.children_system), time.time() - t0


# the bunny's three settings: springs alone, the full term (Teschner's quadratic and the barrier;
# -msim_volume_stiffness -1: its default, since bunny.opts sets 0), the barrier alone (kv 0)
INVERTED = [("springs", ["-msim_volume", "0"]), ("volume", ["-msim_volume", "1", "-msim_volume_stiffness", "-1"]), ("barrier", ["-msim_volume", "1", "-msim_volume_stiffness", "0"])]


def inverted(tmp):
    """bunny.opts (45 of its 150 steps) in the three settings, and bunny_drop.opts (all its 60 steps,
    frames every 2) with the springs alone and the barrier alone: the example column"""
    rows = []
    cases = [("bunny", ["-msim_steps", "45"], INVERTED), ("bunny_drop", [], [INVERTED[0], INVERTED[2]])]
    for example, steps, confs in cases:
        for name, args in confs:
            out = os.path.join(tmp, f"{example}_{name}")
            run(["-options_file", f"examples/{example}.opts"] + steps + ["-msim_output", out] + args, 2)
            for t, J in tetcheck.ratios(os.path.join(out, "series.pvd")):
                rows.append({"example": example, "config": name, "t": f"{t:.2f}", "inverted": int((J <= 0).sum()), "below_jhat": int((J < 0.2).sum()), "J_min": f"{J.min():.4f}", "J_max": f"{J.max():.4f}"})
            print(example, name, "inverted tets per frame:", [r["inverted"] for r in rows if r["example"] == example and r["config"] == name], flush=True)
    msimrun.write_csv(os.path.join(HERE, "inverted.csv"), rows)
    return rows


def cost(tmp):
    """alternated pairs of 10-step runs at 1 and 2 ranks; CPU time and the MSimStep event"""
    rows = []
    for np in (1, 2):
        for rep in range(2):
            for vol in (0, 1):
                log, cpu, wall = run(["-options_file", "examples/bunny.opts", "-msim_steps", "10", "-msim_output", os.path.join(tmp, "c"), "-msim_output_every", "10", "-msim_volume", str(vol), "-msim_volume_stiffness", "-1", "-log_view"], np)
                rows.append({"np": np, "rep": rep, "volume": vol, "cpu_s": f"{cpu:.2f}", "wall_s": f"{wall:.2f}", "step_event_s": f"{msimrun.event(log, 'MSimStep')[1]:.3f}", "volume_event_s": f"{msimrun.event(log, 'MSimVolume')[1]:.3f}"})
                print(rows[-1], flush=True)
    msimrun.write_csv(os.path.join(HERE, "cost.csv"), rows)
    return rows


def steps(tmp, nsteps=21, reps=3, extra=None):
    """the term's cost per step: CPU user time of nsteps- and 1-step runs (their difference is the
    steps alone, without TetGen and the setup), 1 rank, self-contact off, min over reps of runs
    alternated between springs alone, the barrier alone (kv 0: its passes skip the tets the safe
    radii prove above jhat), the volume term without its barrier (kappa 0: Teschner's quadratic
    alone, no max_step) and the full term. extra: a second msim (another build) whose full term
    and barrier alone are measured in the same alternation (the code before a change)."""
    confs = [("springs", MSIM, ["-msim_volume", "0"]), ("barrier", MSIM, ["-msim_volume", "1", "-msim_volume_stiffness", "0"]), ("quadratic", MSIM, ["-msim_volume", "1", "-msim_volume_stiffness", "-1", "-msim_volume_kappa", "0"]), ("volume", MSIM, ["-msim_volume", "1", "-msim_volume_stiffness", "-1"])]
    if extra:
        confs.append(("volume_before", os.path.abspath(extra), ["-msim_volume", "1", "-msim_volume_stiffness", "-1"]))
        confs.append(("barrier_before", os.path.abspath(extra), ["-msim_volume", "1", "-msim_volume_stiffness", "0"]))
    best = {}
    for rep in range(reps):
        for name, exe, args in confs:
            for n in (1, nsteps):
                t0 = os.times()
                p = subprocess.run([exe, "-options_file", "examples/bunny.opts", "-msim_self_contact", "0", "-msim_steps", str(n), "-msim_output", os.path.join(tmp, "s"), "-msim_output_every", "1000"] + args, cwd=ROOT, env=msimrun.ENV, capture_output=True, text=True)
                t1 = os.times()
                if p.returncode:
                    sys.exit(f"msim failed: {name}\n{p.stderr[-2000:]}")
                user = t1.children_user - t0.children_user
                best[(name, n)] = min(best.get((name, n), 1e30), user)
    base = best[("springs", nsteps)] - best[("springs", 1)]
    rows = []
    for name, _, _ in confs:
        s = best[(name, nsteps)] - best[(name, 1)]
        rows.append({"config": name, "steps": nsteps - 1, "user_1step_s": f"{best[(name, 1)]:.2f}", f"user_{nsteps}steps_s": f"{best[(name, nsteps)]:.2f}", "steps_user_s": f"{s:.2f}", "vs_springs": f"{s / base:.3f}"})
        print(rows[-1], flush=True)
    msimrun.write_csv(os.path.join(HERE, f"steps{nsteps - 1}.csv"), rows)
    return rows


def limit():
    """explicit limit of the bunny with and without the term: SLEPc's omega_max of (K, M) with the
    term's Hessian in K (-msim_spectrum), and the Gershgorin bound the stability guard uses (its
    warning at a too-large h)"""
    rows = []
    base = ["-options_file", "examples/bunny.opts", "-msim_integrator", "symplectic_euler", "-msim_steps", "1", "-msim_output", os.path.join(tempfile.gettempdir(), "lim")]
    for vol in (0, 1):
        log, _, _ = run(base + ["-msim_volume", str(vol), "-msim_volume_stiffness", "-1", "-msim_spectrum"], 1)
        w = re.search(r"omega_max = (\S+) rad/s", log)
        hs = re.search(r"symplectic_euler h < (\S+) s", log)
        log2, _, _ = run(base + ["-msim_volume", str(vol), "-msim_volume_stiffness", "-1", "-msim_dt", "0.01"], 1)
        g = re.search(r"stability limit h <= (\S+) of \S+ \(omega_max <= (\S+) from the (\w+)", log2)
        rows.append({"volume": vol, "slepc_omega_max": w.group(1), "slepc_h_symplectic": hs.group(1), "gershgorin_omega_max": g.group(2), "gershgorin_h_symplectic": g.group(1)})
        print(rows[-1], flush=True)
    msimrun.write_csv(os.path.join(HERE, "limit.csv"), rows)
    return rows


def plot(rows):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for name, label in (("springs", "springs alone"), ("volume", "with -msim_volume"), ("barrier", "barrier alone (kv 0)")):
        r = [x for x in rows if x["config"] == name and x.get("example", "bunny") == "bunny"]
        ax.plot([float(x["t"]) for x in r], [x["inverted"] for x in r], "o-", label=label)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("inverted tets in the frame")
    ax.set_title("bunny (examples/bunny.opts), 2 ranks, frames every 3 steps")
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "inverted.png"), dpi=100)


if __name__ == "__main__":
    with tempfile.TemporaryDirectory() as tmp:
        what = sys.argv[2:] or ["inverted", "cost", "limit"]
        if "limit" in what:
            limit()
        if "inverted" in what:
            plot(inverted(tmp))
        if "cost" in what:
            cost(tmp)
        for w in what:  # steps[:N[:before-msim]]: the per-step cost over N steps (steps: 20)
            if w.startswith("steps"):
                f = w.split(":")
                steps(tmp, int(f[1]) + 1 if len(f) > 1 else 21, 3, f[2] if len(f) > 2 else None)
