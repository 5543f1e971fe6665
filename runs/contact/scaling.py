#!/usr/bin/env python3
"""Issue 34, target 3: a 10^6-spring tet box dropped on a plane runs at 1 and 2 ranks with the same
speed-up as without contact (within 10%). Reading in runs/contact/README.md, "Contact at scale".

Usage (from the repository root):
    /usr/bin/python3 runs/contact/scaling.py [--msim build/msim] [--ranks 1,2] [--springs 1e6]
        [--steps pd:2,newton_cg:1,explicit:100] [--repeat 2] [--methods pd,newton_cg,explicit]
        [--out runs/contact/scaling.csv]
    /usr/bin/python3 runs/contact/scaling.py --merge A.csv B.csv --out C.csv   # one table from earlier runs
Runs unchanged on a cluster (--ranks 1,2,4,8 ...; --mpirun "srun --cpu-bind=cores"). Writes the CSV
and, beside it, the PNG of the same name.

The scene is runs/scaling's weak-scaling box (its box(): a Kuhn box n^3 with about --springs springs,
1000 kg/m^3, E = 1 MPa, the unit cube) left free (-msim_fix none) and falling under gravity onto the
plane z >= -gap. Methods take runs/scaling's options (its METHODS, steps set here):
  pd         implicit Euler, h = 10 ms, PD with 10 fixed iterations and CG + GAMG global steps (msim's
             own default for solids above 10^5 free vertices, so at 10^6 springs this is also what PD
             does unasked); with contact PD's default -msim_contact_pd_weight puts the barrier's weight
             on A's diagonal, re-setting up GAMG when the weights move by more than
             -msim_contact_pd_refactor's factor;
  pd_rhs     (on request) the same with -msim_contact_pd_weight 0: the barrier in the right-hand side
             only, A and GAMG fixed;
  newton_cg  implicit Euler, h = 1 ms, msim's default Newton (line search, CG + block Jacobi ICC);
  explicit   symplectic Euler, h = 50 us (runs/scaling's box step; SLEPc's guard off as there), with
             contact's penalty (explicit integrators have no barrier).
Contact: the barrier's range dhat is half the box's spacing; the implicit runs start with the bottom
face dhat + g h^2 / 2 above the plane, so their first step's fall (g h^2) takes it within dhat: the
barrier acts from step 1 on. The penalty acts at penetration: the explicit box starts g (5 h)^2 / 2
above the plane and touches it around step 5. Every contact run's monitor (-msim_monitor_csv) is read
to check that vertices are in contact (contact_n > 0) at the end of the measured steps.

Each (method, ranks) pair runs without and with the plane --repeat times, alternating which goes
first, and keeps the fastest time per step (the Stepping stage of -log_view over the steps, wall
time of its slowest rank; -log_view is written as CSV, :FILE:ascii_csv, for exact counts and each
rank's times). Also from the Stepping stage: its MPI reductions (exact; at one rank PETSc counts none)
and those outside KSPSolve, where contact's own would show; per event the count, time and each rank's
time (the balance of the work). The CPU time (user, sys) of each whole run (setup included, all
ranks; at 2 ranks it includes MPI's busy waiting) is kept beside. At several ranks each run prints
-msim_partition_view, and runs/scaling's msim_partition_model (beside --msim, `-near_z`) gives the
same partition's bottom-face vertices per rank: which ranks own the contact work."""
import argparse
import csv
import importlib.util
import os
import resource
import re
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
RUNS = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(RUNS, "tools"))
from msimrun import ENV, ROOT, write_csv  # noqa: E402

_spec = importlib.util.spec_from_file_location("scaling_study", os.path.join(RUNS, "scaling", "study.py"))
scaling = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(scaling)

G = 9.81
STEPS = {"pd": 2, "pd_rhs": 2, "newton_cg": 1, "explicit": 100}
DT = {"pd": 0.01, "pd_rhs": 0.01, "newton_cg": 0.001, "explicit": 5e-5}
# the events whose counts, reductions and balance the CSV keeps (those a run did not log are left out)
EVENTS = ["MSimStep", "MSimForce", "MSimEnergy", "MSimResidual", "MSimJacobian", "MSimPDLocal", "MSimPDGlobal", "MSimPDMaxStep",
          "MSimPDBound", "KSPSolve", "PCSetUp", "SNESLineSearch"]


def method_args(method):
    """runs/scaling's options for the method, less its step count"""
    base = scaling.METHODS["pd" if method == "pd_rhs" else method].format(dt_explicit="5e-5")
    base = re.sub(r"-msim_steps \d+", "", base)
    if method == "pd_rhs":
        base += " -msim_contact_pd_weight 0"
    dt = float(re.search(r"-msim_dt (\S+)", base).group(1))
    if dt != DT[method]:
        sys.exit(f"runs/scaling's {method} step is {dt} s; this study's gap assumes {DT[method]} s")
    return base


def scene(springs):
    """runs/scaling's box, free to fall"""
    n, args = scaling.box(springs)
    return n, args.replace("-msim_fix_plane x_min", "-msim_fix none")


def contact_args(method, n):
    """the plane under the box and the barrier's range (see the module's text)"""
    dhat = 0.5 / n
    h = DT[method]
    gap = 0.5 * G * (5 * h) ** 2 if method == "explicit" else dhat + 0.5 * G * h * h
    return dhat, gap, f"-msim_contact_plane 0,0,1,{-gap:.9g} -msim_contact_distance {dhat:.9g}"


def log_csv(path):
    """-log_view's ascii_csv file: {(stage, event): [(count, time s, reductions) per rank]}, with
    event "summary" the stage's own totals; exact counts, where the text table rounds to 2 digits"""
    out = {}
    with open(path) as f:
        next(f)
        for line in f:
            v = line.rstrip("\n").split(",")
            if len(v) < 8:
                continue
            out.setdefault((v[0], v[1]), []).append((int(float(v[3])), float(v[4]), int(float(v[7]))))
    return out


def monitor(path):
    """per step rows of -msim_monitor_csv (step 0, the start, left out)"""
    if not os.path.exists(path):
        return []
    with open(path) as f:
        head = f.readline().strip().split(",")
        rows = [dict(zip(head, line.strip().split(","))) for line in f if line.strip()]
    return [r for r in rows if int(r["step"]) > 0]


def run_once(a, method, np_, contact, n, springs_scene, mon=True):
    steps = a.steps[method]
    lpath = f"/tmp/msim_contact_scaling_{os.getpid()}_log.csv"
    args = f"{springs_scene} {method_args(method)} -msim_steps {steps} -log_view :{lpath}:ascii_csv -msim_scene_view"
    dhat, gap = "", ""
    if contact:
        dhat, gap, cargs = contact_args(method, n)
        args += " " + cargs
    mpath = f"/tmp/msim_contact_scaling_{os.getpid()}.csv"
    if mon:
        if os.path.exists(mpath):
            os.remove(mpath)
        args += f" -msim_monitor_csv {mpath}"
    if np_ > 1:
        args += f" -msim_partition_view -msim_partition {a.partition}"
    cmd = (a.mpirun.split() + ["-n", str(np_)] if np_ > 1 else []) + [a.msim] + args.split()
    t0, ru0 = time.time(), resource.getrusage(resource.RUSAGE_CHILDREN)
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT, timeout=a.timeout)
    wall, ru1 = time.time() - t0, resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode:
        sys.exit(f"msim failed: {' '.join(cmd)}\n{r.stdout[-2000:]}\n{r.stderr[-3000:]}")
    log = r.stdout
    lv = log_csv(lpath)
    stage = lv[("Stepping", "summary")]
    stepping = max(t for _, t, _ in stage)  # the stage's time as -log_view prints it: its slowest rank
    red = stage[0][2]
    ksp = lv.get(("Stepping", "KSPSolve"), [(0, 0.0, 0)])[0][2]
    rows = monitor(mpath) if mon else []
    owned = re.findall(r"^\s+(\d+)\s+(\d+)\s+\d+\s+\d+\s+\d+\s*$", log.split("rank   owned")[1] if "rank   owned" in log else "", re.M)
    out = dict(method=method, ranks=np_, partition=a.partition if np_ > 1 else "", contact=int(contact), springs=int(re.search(r"(\d+) springs", log).group(1)), box_n=n,
               dhat_m=dhat, gap_m=gap, dt_s=DT[method], steps=steps, step_s=stepping / steps, wall_s=round(wall, 2),
               cpu_user_s=round(ru1.ru_utime - ru0.ru_utime, 3), cpu_sys_s=round(ru1.ru_stime - ru0.ru_stime, 3),
               reductions=red, reductions_outside_ksp=red - ksp, owned_per_rank=";".join(o for _, o in owned) if owned else "")
    if rows:
        out["nonlinear_its"] = sum(int(x["nonlinear_its"]) for x in rows)
        out["linear_its"] = sum(int(x["linear_its"]) for x in rows)
        out["contact_n_first"] = int(rows[0]["contact_n"])
        out["contact_n_last"] = int(rows[-1]["contact_n"])
        out["contact_fz_last"] = float(rows[-1]["contact_fz"])
    for e in EVENTS:
        per = lv.get(("Stepping", e))
        if per and per[0][0]:
            times = [t for _, t, _ in per]
            out[f"{e}_n"] = per[0][0]
            out[f"{e}_s"] = max(times)
            out[f"{e}_ranks_s"] = ";".join(f"{t:.4g}" for t in times)  # each rank's time: the balance
            out[f"{e}_red"] = per[0][2]
    out["cmd"] = " ".join(x for x in cmd if "msim_contact_scaling_" not in x).replace("-msim_monitor_csv", "-msim_monitor_csv FILE").replace("-log_view", "-log_view :FILE:ascii_csv")
    for path in (mpath, lpath):
        if os.path.exists(path):
            os.remove(path)
    return out


def explicit_check(a, n, sc):
    """the explicit runs are timed without the monitor (its energy sweep costs about a step): one
    extra 1-rank contact run with it shows the penalty acting within the measured steps"""
    r = run_once(a, "explicit", 1, True, n, sc, mon=True)
    return r.get("contact_n_first", 0), r.get("contact_n_last", 0)


def bottom_owners(a, sc, ranks):
    """{P: [(free vertices, bottom-face vertices) per part]} of msim's partition (--partition) into P
    parts, from runs/scaling's msim_partition_model beside msim (the same METIS call and graph as
    msim's partitioner; each run's -msim_partition_view owned counts are checked against it)"""
    tool = os.path.join(os.path.dirname(a.msim), "msim_partition_model")
    parts = [p for p in ranks if p > 1]
    if not parts or not os.path.exists(tool):
        return {}
    r = subprocess.run([tool] + sc.split() + ["-parts", ",".join(map(str, parts)), "-near_z", "1e-9"], capture_output=True, text=True, env=ENV, cwd=ROOT)
    if r.returncode:
        print(f"msim_partition_model failed, no ownership of the bottom face: {r.stderr[-500:]}")
        return {}
    out = {}
    for line in r.stdout.splitlines()[1:]:
        name, P, _, owned, below = line.split(",")
        if name == a.partition:
            out.setdefault(int(P), []).append((int(owned), int(below)))
    return out


def study(a):
    n, sc = scene(a.springs)
    a.owners = bottom_owners(a, sc, a.ranks)
    for P, parts in a.owners.items():
        print(f"{a.partition} into {P} parts: bottom-face vertices per part {[b for _, b in parts]} (free vertices {[o for o, _ in parts]})", flush=True)
    print(f"box {n}^3 ({sc}), methods {a.methods}, ranks {a.ranks}, repeat {a.repeat}", flush=True)
    runs = []
    for rep in range(a.repeat):
        for method in a.methods:
            for np_ in a.ranks:
                order = (False, True) if (rep + a.ranks.index(np_)) % 2 == 0 else (True, False)
                for contact in order:
                    r = run_once(a, method, np_, contact, n, sc, mon=method != "explicit")
                    r["rep"] = rep
                    runs.append(r)
                    extra = f", {r.get('nonlinear_its', '-')} nonlinear / {r.get('linear_its', '-')} linear its, contact_n {r.get('contact_n_first', '-')} -> {r.get('contact_n_last', '-')}"
                    print(f"rep {rep} {method:9s} {np_} ranks {'contact' if contact else 'free   '}: {r['step_s'] * 1e3:10.2f} ms/step, "
                          f"CPU {r['cpu_user_s']:.2f} s user (whole run), reductions {r['reductions']:.0f} ({r['reductions_outside_ksp']:.0f} outside KSPSolve){extra if method != 'explicit' else ''}", flush=True)
    if "explicit" in a.methods:
        c0, c1 = explicit_check(a, n, sc)
        for r in runs:
            if r["method"] == "explicit" and r["contact"]:
                r["contact_n_first"], r["contact_n_last"] = c0, c1
    return n, runs


def summarize(a, runs):
    """the best run of each (method, ranks, contact); speed-ups, the target's ratio, and the ratio
    from each repetition alone (the noise)"""
    best = {}
    for r in runs:
        k = (r["method"], r["ranks"], r["contact"])
        if k not in best or r["step_s"] < best[k]["step_s"]:
            best[k] = r
    rows = []
    for (method, np_, contact), r in sorted(best.items(), key=lambda kv: (a.methods.index(kv[0][0]), kv[0][1], kv[0][2])):
        r = dict(r)
        r["step_s_all"] = ";".join(f"{x['step_s']:.6g}" for x in runs if (x["method"], x["ranks"], x["contact"]) == (method, np_, contact))
        base = best[(method, a.ranks[0], contact)]["step_s"]
        r["speedup"] = base / r["step_s"] * a.ranks[0]
        free = best[(method, np_, 0)]["step_s"]
        r["contact_adds"] = r["step_s"] / free - 1 if contact else 0.0
        parts = a.owners.get(np_)
        if parts:
            r["bottom_per_rank"] = ";".join(str(b) for _, b in parts)
            r["partition_checked"] = int(r.get("owned_per_rank") == ";".join(str(o) for o, _ in parts))
        rows.append(r)
    for r in rows:
        if r["contact"]:
            free = next(x for x in rows if (x["method"], x["ranks"], x["contact"]) == (r["method"], r["ranks"], 0))
            r["speedup_ratio"] = r["speedup"] / free["speedup"]
            r["target_met"] = int(0.9 <= r["speedup_ratio"] <= 1.1) if r["ranks"] != a.ranks[0] else ""
            # the same ratio from each repetition's own four runs
            per = []
            for rep in range(a.repeat):
                t = {(x["ranks"], x["contact"]): x["step_s"] for x in runs if x["method"] == r["method"] and x["rep"] == rep}
                if (r["ranks"], 1) in t and (a.ranks[0], 1) in t:
                    per.append((t[(a.ranks[0], 1)] / t[(r["ranks"], 1)]) / (t[(a.ranks[0], 0)] / t[(r["ranks"], 0)]))
            r["speedup_ratio_per_rep"] = ";".join(f"{x:.3f}" for x in per)
    return rows


def merged_runs(a, files):
    """the runs of several earlier runs of this script, from their CSVs (e.g. two sessions on one
    machine): each row's step_s_all gives one run per repetition, carrying the row's other columns,
    with repetitions numbered on across the files so that summarize() pairs the four runs of one
    repetition of one file, as when they ran"""
    runs, rep0 = [], 0
    for f in files:
        with open(f) as fh:
            rows = list(csv.DictReader(fh))
        nrep = 0
        for r in rows:
            for k in ("ranks", "contact", "springs"):
                r[k] = int(r[k])
            times = [float(x) for x in r["step_s_all"].split(";")]
            nrep = max(nrep, len(times))
            for i, t in enumerate(times):
                runs.append(dict(r, step_s=t, rep=rep0 + i))
        rep0 += nrep
    a.repeat = rep0
    a.ranks = sorted({r["ranks"] for r in runs})
    a.methods = [m for m in a.methods if any(r["method"] == m for r in runs)]
    a.owners = {}
    return runs


def plot(a, rows, png):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax3, ax2) = plt.subplots(1, 3, figsize=(16, 4.8), gridspec_kw=dict(width_ratios=[1, 1, 1.4]))
    marks = {"pd": "o", "pd_rhs": "D", "newton_cg": "s", "explicit": "^"}
    for i, m in enumerate(a.methods):
        for contact, ls in ((0, "--"), (1, "-")):
            sel = [r for r in rows if r["method"] == m and r["contact"] == contact]
            ax1.plot([r["ranks"] for r in sel], [r["speedup"] for r in sel], ls, marker=marks.get(m, "o"), color=f"C{i}",
                     mfc="none" if not contact else f"C{i}", label=f"{m}, {'with' if contact else 'without'} contact")
    ax1.plot(a.ranks, a.ranks, ":", color="grey", label="ideal")
    ax1.set_xlabel("ranks")
    ax1.set_ylabel(f"speed-up over {a.ranks[0]} rank(s), best runs")
    if a.ranks[-1] >= 8 * a.ranks[0]:  # many rank counts: spread them evenly
        for ax in (ax1, ax3):
            ax.set_xscale("log", base=2)
    ax1.set_xticks(a.ranks, [str(p) for p in a.ranks])
    ax1.set_title("Speed-up without (dashed) and with the plane")
    ax1.legend(fontsize=7)
    # the target's ratio: from the best runs, and from each repetition's own runs (the noise)
    for i, m in enumerate(a.methods):
        label = f"{m}: best runs (x: each repetition)"
        for r in rows:
            if r["method"] == m and r["contact"] and r["ranks"] != a.ranks[0]:
                x = r["ranks"] * (1 + 0.04 * (i - (len(a.methods) - 1) / 2))
                per = [float(v) for v in r["speedup_ratio_per_rep"].split(";") if v]
                ax3.plot([x] * len(per), per, "x", color=f"C{i}", alpha=0.6)
                ax3.plot([x], [r["speedup_ratio"]], marks.get(m, "o"), color=f"C{i}", ms=9, label=label)
                label = None
    ax3.axhspan(0.9, 1.1, color="green", alpha=0.12, label="target 0.9-1.1")
    ax3.set_xticks([p for p in a.ranks if p != a.ranks[0]], [str(p) for p in a.ranks if p != a.ranks[0]])
    ax3.minorticks_off()
    ax3.set_xlabel("ranks")
    ax3.set_ylabel("speed-up with contact / without")
    ax3.set_yscale("log")
    ax3.set_title("The target's ratio")
    ax3.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=2)
    labels, vals, cols = [], [], []
    for i, m in enumerate(a.methods):
        for np_ in a.ranks:
            for contact in (0, 1):
                r = next((x for x in rows if (x["method"], x["ranks"], x["contact"]) == (m, np_, contact)), None)
                if r:
                    labels.append(f"{m} {np_}r {'contact' if contact else 'free'}")
                    vals.append(r["step_s"] * 1e3)
                    cols.append(f"C{i}" if contact else "lightgrey")
    ax2.bar(range(len(vals)), vals, color=cols, edgecolor=[c if c != "lightgrey" else "black" for c in cols])
    ax2.set_xticks(range(len(vals)))
    ax2.set_xticklabels(labels, fontsize=7, rotation=60, ha="right")
    ax2.set_yscale("log")
    ax2.set_ylabel("ms per step (Stepping stage, best run)")
    ax2.set_title("Time per step (grey: free, colour: with contact)")
    springs = rows[0]["springs"]
    fig.suptitle(f"Tet box of {springs:,} springs dropped on a plane (issue 34 target 3)")
    fig.tight_layout()
    fig.savefig(png, dpi=110)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--msim", default=os.path.join(ROOT, "build", "msim"))
    p.add_argument("--mpirun", default="mpirun")
    p.add_argument("--ranks", default="1,2")
    p.add_argument("--springs", type=float, default=1e6)
    p.add_argument("--steps", default="", help="per method, e.g. pd:2,newton_cg:1,explicit:100 (defaults those)")
    p.add_argument("--repeat", type=int, default=2)
    p.add_argument("--methods", default="pd,newton_cg,explicit")
    p.add_argument("--partition", default="metis", choices=["metis", "natural"],
                   help="msim's partition at several ranks (natural: blocks in input order, so one rank owns the whole bottom face)")
    p.add_argument("--timeout", type=float, default=1800)
    p.add_argument("--out", default=os.path.join(HERE, "scaling.csv"))
    p.add_argument("--plot-only", action="store_true", help="redraw the PNG from --out's CSV, run nothing")
    p.add_argument("--merge", nargs="+", metavar="CSV", help="run nothing: one table (--out and its PNG) from these CSVs of earlier runs, best of all their repetitions")
    a = p.parse_args()
    a.msim = os.path.abspath(a.msim)
    a.ranks = [int(x) for x in a.ranks.split(",")]
    a.methods = a.methods.split(",")
    steps = dict(STEPS)
    for kv in filter(None, a.steps.split(",")):
        k, v = kv.split(":")
        steps[k] = int(v)
    a.steps = steps
    for m in a.methods:
        if m not in STEPS:
            sys.exit(f"--methods: unknown method {m} (known: {', '.join(STEPS)})")
    if a.plot_only:
        with open(a.out) as f:
            rows = list(csv.DictReader(f))
        for r in rows:
            for k in ("ranks", "contact", "springs"):
                r[k] = int(r[k])
            for k in ("speedup", "step_s", "speedup_ratio"):
                r[k] = float(r[k]) if r.get(k) else r.get(k)
        a.methods = [m for m in a.methods if any(r["method"] == m for r in rows)]
        plot(a, rows, os.path.splitext(a.out)[0] + ".png")
        return
    if a.merge:
        runs = merged_runs(a, a.merge)
        rows = summarize(a, runs)
        write_csv(a.out, rows)
        plot(a, rows, os.path.splitext(a.out)[0] + ".png")
        report(a, rows, f"{len(a.merge)} runs merged")
        return
    t0 = time.time()
    try:
        load = open("/proc/loadavg").read().split()[:3]
    except OSError:
        load = ["?"]
    print(f"load average at the start: {' '.join(load)}; {os.cpu_count()} CPUs", flush=True)
    n, runs = study(a)
    rows = summarize(a, runs)
    os.makedirs(os.path.dirname(os.path.abspath(a.out)), exist_ok=True)
    write_csv(a.out, rows)
    plot(a, rows, os.path.splitext(a.out)[0] + ".png")
    report(a, rows, f"box {n}^3; {time.time() - t0:.0f} s in all")


def report(a, rows, what):
    print(f"\n{rows[0]['springs']} springs; best of {a.repeat}; {what}")
    for r in rows:
        line = f"{r['method']:9s} {r['ranks']} ranks {'contact' if r['contact'] else 'free   '}: {r['step_s'] * 1e3:10.2f} ms/step  speed-up {r['speedup']:.3f}"
        if r["contact"]:
            line += f"  contact adds {r['contact_adds'] * 100:+.1f}%  speed-up ratio {r['speedup_ratio']:.3f} (per repeat {r['speedup_ratio_per_rep']})"
        print(line)
    print(f"wrote {a.out} and {os.path.splitext(a.out)[0] + '.png'}")


if __name__ == "__main__":
    main()
