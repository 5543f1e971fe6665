#!/usr/bin/env python3
"""PD's bounds on Phi as one mechanism (pd_steps.cpp): reference runs before and after a change to
PD's global step, compared bit for bit. For each case: the monitor CSV (-msim_monitor_csv), the final
state (-msim_view_final binary, compared byte for byte), and -log_view's counts of Phi evaluations
(MSimEnergy), local steps (MSimPDLocal), rejected steps the bound sized or tried to (MSimPDBound), the
bound tried in place of the check (MSimPDBoundCheck), halvings (MSimPDHalving) and factorizations (MSimLLTFactor), with the CPU user time of the run.
Cases: the benchmark drape (101 x 101 cloth on the ball, friction 0.3, PD-10, 24 steps:
runs/contact/pd_refactor.py's default), tests/contact_pd_refactor.py's runs, the same 21 x 21 drape
with Anderson(5) and with L-BFGS(8) (their checks are not deferred), free falls (no obstacle; and the
21 x 21 drape's first 3 steps, above the ball), and the bunny (examples/bunny.opts, self-contact
off, 20 steps) with the barrier alone (-msim_volume_stiffness 0), the full term and, 3 steps, with
self-contact; 10 steps of it with plain PD (the check deferred) and with PD + L-BFGS(8); examples/bunny_drop.opts's first
20 steps (the barrier, the floor and friction); the two bunnies' 1-step runs (the set-up, to take off
their CPU time).
Usage: pd_bounds.py run MSIM OUTDIR [--np 1,2] [--cases a,b]
       pd_bounds.py compare OUTDIR_BEFORE OUTDIR_AFTER     (prints a table)
       pd_bounds.py cpu MSIM_BEFORE MSIM_AFTER [--cases a,b] [--reps 3]   (CPU user s, alternated, min)
       pd_bounds.py rises MSIM [--np N] [--cases a,b]       (-info: Phi at both ends of each step the
                                                            bound accepted; the largest rise)"""
import csv
import filecmp
import os
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
H = ["-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.0333333333333333"]
PD10 = ["-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"]
CONV = ["-snes_type", "pd", "-snes_pd_anderson", "5", "-snes_max_it", "2000", "-snes_atol", "1e-9", "-snes_rtol", "0"]
BALL = ["-msim_contact_sphere", "0.5,0.5,-0.4,0.3"]
PLANE = ["-msim_contact_plane", "0,0,1,-0.05"]
DRAPE = ["-msim_cloth_n", "21", "-msim_steps", "24", "-msim_friction", "0.3"] + PD10 + H + BALL
BUNNY = ["-options_file", "examples/bunny.opts", "-msim_self_contact", "0", "-msim_output", "/tmp/pd_bounds_bunny", "-msim_output_every", "1000"]
CASES = {
    "drape101": ["-msim_cloth_n", "101", "-msim_steps", "24"] + H + BALL + ["-msim_friction", "0.3"] + PD10,
    "plane_rule0": ["-msim_cloth_n", "11", "-msim_steps", "8"] + H + CONV + PLANE + ["-msim_contact_pd_refactor", "0"],
    "plane_rule4": ["-msim_cloth_n", "11", "-msim_steps", "8"] + H + CONV + PLANE + ["-msim_contact_pd_refactor", "4"],
    "ball_rule0": ["-msim_cloth_n", "11", "-msim_steps", "4"] + H + CONV + BALL + ["-msim_contact_pd_refactor", "0"],
    "ball_rule4": ["-msim_cloth_n", "11", "-msim_steps", "4"] + H + CONV + BALL + ["-msim_contact_pd_refactor", "4"],
    "drape21": DRAPE,
    "drape21_rule0": DRAPE + ["-msim_contact_pd_refactor", "0"],
    "drape21_immediate": [a for a in DRAPE if a != "-snes_pd_fixed"] + ["-snes_atol", "0", "-snes_rtol", "0", "-snes_stol", "0"],
    "drape21_bound0": DRAPE + ["-msim_contact_pd_bound", "0"],
    "conv_ball_bound1": ["-msim_cloth_n", "11", "-msim_steps", "4"] + H + CONV + BALL + ["-msim_friction", "0.3"],
    "conv_ball_bound0": ["-msim_cloth_n", "11", "-msim_steps", "4"] + H + CONV + BALL + ["-msim_friction", "0.3", "-msim_contact_pd_bound", "0"],
    "drape21_anderson": DRAPE + ["-snes_pd_anderson", "5"],
    "drape21_lbfgs": DRAPE + ["-snes_pd_lbfgs", "8"],
    "freefall101": ["-msim_cloth_n", "101", "-msim_steps", "24"] + H + PD10,
    "freefall21_ball": ["-msim_cloth_n", "21", "-msim_steps", "3", "-msim_friction", "0.3"] + PD10 + H + BALL,
    "bunny_barrier": BUNNY + ["-msim_steps", "20", "-msim_volume", "-msim_volume_stiffness", "0"],
    "bunny_barrier_1step": BUNNY + ["-msim_steps", "1", "-msim_volume", "-msim_volume_stiffness", "0"],
    "bunny_drop_1step": ["-options_file", "examples/bunny_drop.opts", "-msim_steps", "1", "-msim_output", "/tmp/pd_bounds_bunny", "-msim_output_every", "1000"],
    "bunny_lbfgs": BUNNY + ["-msim_steps", "10", "-msim_volume", "-msim_volume_stiffness", "0", "-snes_pd_anderson", "0", "-snes_pd_lbfgs", "8"],
    "bunny_full": BUNNY + ["-msim_steps", "5", "-msim_volume", "-msim_volume_stiffness", "-1"],
    "bunny_plainpd": BUNNY + ["-msim_steps", "10", "-msim_volume", "-msim_volume_stiffness", "0", "-snes_pd_anderson", "0"],
    "bunny_drop": ["-options_file", "examples/bunny_drop.opts", "-msim_steps", "20", "-msim_output", "/tmp/pd_bounds_bunny", "-msim_output_every", "1000"],
    "bunny_selfcontact": BUNNY + ["-msim_steps", "3", "-msim_volume", "-msim_volume_stiffness", "0", "-msim_self_contact", "1"],
}
EVENTS = ["MSimEnergy", "MSimPDLocal", "MSimPDBound", "MSimPDBoundCheck", "MSimPDHalving", "MSimLLTFactor"]


def command(msim, args, np_):
    mpi = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-q", "-n", str(np_)] if np_ > 1 else []
    return mpi + [msim] + args


def counts(log):
    return {e: sum(int(c) for c in re.findall(rf"^{e}\s+(\d+)", log, re.M)) for e in EVENTS}


def run_all(msim, out, nps, names):
    os.makedirs(out, exist_ok=True)
    for np_ in nps:
        for c in names:
            tag = os.path.join(out, f"{c}_{np_}")
            args = CASES[c] + ["-msim_monitor_csv", tag + ".csv", "-msim_view_final", f"binary:{tag}.bin", "-log_view", f"ascii:{tag}.log"]
            r0 = os.times()
            p = subprocess.run(command(msim, args, np_), cwd=ROOT, capture_output=True, text=True)
            r1 = os.times()
            user = r1.children_user - r0.children_user
            with open(tag + ".user", "w") as f:
                f.write(f"{user:.3f} {p.returncode}\n")
            print(c, np_, "rc", p.returncode, f"user {user:.2f} s", flush=True)
            if p.returncode:
                print(p.stderr[-1500:])


def monitor(path):
    """the monitor CSV's rows without its wall-clock column"""
    with open(path) as f:
        rows = list(csv.reader(f))
    keep = [i for i, h in enumerate(rows[0]) if h != "wall_s"]
    return [[r[i] for i in keep] for r in rows]


def compare(a, b):
    print(f"| case | ranks | final state | monitor CSV (but wall_s) | Phi evals | local steps | bound retries | bound in place of the check | halvings | factorizations | CPU user s |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for f in sorted(os.listdir(a)):
        if not f.endswith(".log") or not os.path.exists(os.path.join(b, f)):
            continue
        tag = f[:-4]
        case, np_ = tag.rsplit("_", 1)
        same = lambda ext: filecmp.cmp(os.path.join(a, tag + ext), os.path.join(b, tag + ext), shallow=False) if os.path.exists(os.path.join(b, tag + ext)) else None
        ca, cb = (counts(open(os.path.join(d, f)).read()) for d in (a, b))
        ua, ub = (open(os.path.join(d, tag + ".user")).read().split()[0] for d in (a, b))
        cell = lambda e: f"{ca[e]}" if ca[e] == cb[e] else f"{ca[e]} -> {cb[e]}"
        print(f"| {case} | {np_} | {'same' if same('.bin') else 'differs'} | {'same' if monitor(os.path.join(a, tag + '.csv')) == monitor(os.path.join(b, tag + '.csv')) else 'differs'} | " + " | ".join(cell(e) for e in EVENTS) + f" | {ua} -> {ub} |")


def rises(msim, nps, names):
    for np_ in nps:
        for c in names:
            p = subprocess.run(command(msim, CASES[c] + ["-info", ":vec"], np_), cwd=ROOT, capture_output=True, text=True)
            pairs = [(float(x), float(y)) for x, y in re.findall(r"pd bound: .*accepted.* Phi (\S+) -> (\S+)", p.stdout + p.stderr)]
            pairs = [(x, y) for x, y in pairs if x or y]
            worst = max(((y - x) / max(abs(x), 1e-300) for x, y in pairs), default=0.0)
            worst_abs = max((y - x for x, y in pairs), default=0.0)
            print(f"{c} np={np_} rc={p.returncode}: {len(pairs)} accepted steps evaluated, largest rise {worst_abs:.3g} J ({worst:.3g} of |Phi|)", flush=True)


def cpu(before, after, names, reps):
    """CPU user time of each case's run (1 rank), the two builds alternated, min over reps"""
    best = {}
    for r in range(reps):
        for c in names:
            for tag, msim in (("before", before), ("after", after)):
                r0 = os.times()
                p = subprocess.run([msim] + CASES[c], cwd=ROOT, capture_output=True, text=True)
                r1 = os.times()
                if p.returncode:
                    sys.exit(f"{c} failed with {msim}")
                best[(c, tag)] = min(best.get((c, tag), 1e30), r1.children_user - r0.children_user)
    print("| case | CPU user s before | after | after / before |")
    print("|---|---|---|---|")
    for c in names:
        b, a = best[(c, "before")], best[(c, "after")]
        print(f"| {c} | {b:.2f} | {a:.2f} | {a / b:.3f} |", flush=True)


def main():
    mode = sys.argv[1]
    opt = lambda k, d: sys.argv[sys.argv.index(k) + 1] if k in sys.argv else d
    nps = [int(n) for n in opt("--np", "1").split(",")]
    names = opt("--cases", ",".join(CASES)).split(",")
    if mode == "run":
        run_all(os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3]), nps, names)
    elif mode == "compare":
        compare(sys.argv[2], sys.argv[3])
    elif mode == "cpu":
        cpu(os.path.abspath(sys.argv[2]), os.path.abspath(sys.argv[3]), names, int(opt("--reps", "3")))
    elif mode == "rises":
        rises(os.path.abspath(sys.argv[2]), nps, names)


if __name__ == "__main__":
    main()
