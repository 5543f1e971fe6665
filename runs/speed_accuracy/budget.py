#!/usr/bin/env python3
"""Equal-budget search (issue 33): which scheme, step h and iteration count k is most accurate for
PD-10 implicit Euler's cost at h = 1/30 s (the issue's budget), on the tet beam and the benchmark
cloth (and any scene of schemes.py: rope, cloth21).

A fixed-count solver with k iterations per step at h = k/300 s does k x (1/h) = 300 iterations per
simulated second, PD-10's at 1/30 s: a smaller step buys a better-converged solve (the step's
minimization is more mass-dominated) and a smaller discretisation error for the same iterations.
For each scheme (implicit_euler, bdf2, implicit_midpoint, newmark; `ts`: PETSc's alpha2 at radius
0.5 on msim's analytic Jacobian) and each family:
  PD      k fixed PD iterations (-snes_type pd -snes_pd_fixed -snes_max_it k)
  AA      the same with Anderson mixing (-snes_pd_anderson 5), k >= 2
  LB      L-BFGS on the PD matrix with k iterations (schemes.py's L-BFGS-10 at k), h = k / --lb-rate
          (an L-BFGS iteration costs 1.1-2 PD iterations: fewer per simulated second)
  NCG     (ts alpha2 only: it has no PD) one Newton iteration a step, its linear solve CG/ICC with at
          most k iterations (-snes_max_it 1 -snes_convergence_test skip)
and each k of --ks (h = k/300 s), one run to T (cloth, rope 1 s; beam 0.5 s) with frames every
0.2 s (beam 0.1 s). Error: schemes.py's, the largest vertex distance from its RK4 reference at a
tiny step (the references it keeps in /tmp/msim_schemes, made here the same way when missing).
Cost: instructions executed inside MSimIntegratorStep (valgrind callgrind --toggle-collect, the
steps only: setup, PD factor and output are outside) per simulated second, over the steps to T or
to the step where a run stopped (diverged); deterministic, unlike CPU time on this shared host. The
budget is the same count for PD-10 implicit Euler at h = 1/30 s. Part `cpu` checks chosen rows by
CPU user time (min of --repeats runs alternated with the baseline, the run less its first step).
Part `floor`: the converged scheme at a row's h (schemes.py's Newton; --newton cg for the
benchmark cloth), to split a row's error into the scheme's and the solver's.

Usage: /usr/bin/python3 runs/speed_accuracy/budget.py [grid|cpu|floor|plot] [--msim PATH]
  [--scenes solid,cloth] [--schemes implicit_euler,bdf2,implicit_midpoint,newmark,ts]
  [--families PD,AA,NCG] [--ks 1,2,3,5,10] [--points scene:scheme:family:k:h,...]
  (grid runs --points instead of the grid when given; cpu and floor run --points)
Writes budget.csv (one row per run and T; rows of the same scene, scheme, family, k and h are
replaced), budget_best.csv (part plot: per scene and T the best run within 1.1 x the budget,
implicit Euler's best within it and their ratio) and budget.png."""
import argparse
import csv
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import schemes as S  # noqa: E402  (scenes, references, run(), frames(), solver options)

REF_DIR = S.TMP  # schemes.py's RK4 references: read, made only when missing
S.TMP = "/tmp/msim_budget"  # this study's own runs
OUT = os.path.join(HERE, "budget.csv")
SCENES = {"rope": ("rope", {}), "cloth21": ("cloth", {"cloth_n": 21}), "cloth": ("cloth", {"cloth_n": 101}), "solid": ("solid", {})}
ITS_PER_SIM_S = 300  # PD-10 at h = 1/30 s
TS_ALPHA05 = S.TS_ALPHA["alpha2 r=0.5"]
COUNT_T = {}  # --count-t: simulated seconds over which instructions are counted (default T; fixed-count solvers cost the same every step)
TARGET = {("cloth", 0.2): 2.5, ("cloth", 1.0): 5.0, ("rope", None): 10.0, ("solid", None): 10.0}


def base_opts(name):
    scene, size = SCENES[name]
    a = argparse.Namespace(cloth_n=101, rope_n=1000, beam="24,6,6")
    for k, v in size.items():
        setattr(a, k, v)
    return scene, S.scene_opts(a)[scene]


def solver_opts(scheme, family, k):
    if family == "PD":
        s = f"-snes_type pd -snes_pd_fixed -snes_max_it {k}"
    elif family == "AA":
        s = f"-snes_type pd -snes_pd_fixed -snes_pd_anderson 5 -snes_max_it {k}"
    elif family == "LB":  # L-BFGS on the PD matrix, k iterations (schemes.py's L-BFGS-10 with k)
        s = f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {S.LOOSE} -snes_max_it {k}"
    elif family == "NCG":
        s = f"-snes_type newtonls -snes_max_it 1 -snes_convergence_test skip -snes_linesearch_type basic -ksp_type cg -pc_type icc -ksp_max_it {k} -ksp_converged_maxits"
    elif family == "Newton":  # converged: schemes.py's
        s = S.NEWTON
    elif family == "Newton-CG":
        s = S.NEWTON_CG
    else:
        sys.exit(f"budget.py: unknown family {family}")
    return (TS_ALPHA05 if scheme == "ts" else f"-msim_integrator {scheme}") + " " + s


def reference(msim, name):
    scene, base = base_opts(name)
    T, dT, href = S.T_END[scene], S.T_FRAME[scene], S.H_REF[scene]
    nref = round(T / float(href))
    out = f"{REF_DIR}/{name}_ref"
    if not os.path.exists(f"{out}/frame_{nref:06d}.vtu"):
        tmp, S.TMP = S.TMP, REF_DIR
        rc, err, *_ = S.run_timed(msim, f"{base} -msim_integrator rk4 -msim_dt {href} -msim_steps {nref} -msim_output_every {round(dT / float(href))}", f"{name}_ref")
        S.TMP = tmp
        if rc:
            sys.exit(f"reference failed: {err[-400:]}")
    return {round(k * float(href), 6): x for k, x in S.frames(out).items()}


def instructions(msim, args, n):
    """instructions inside MSimIntegratorStep over n steps (valgrind callgrind)"""
    if n < 1:
        return float("nan")
    r = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", "--toggle-collect=MSimIntegratorStep*", msim]
                       + args.split() + ["-msim_spectrum_check", "0", "-msim_output_every", "1000000", "-msim_steps", str(n)],
                       capture_output=True, text=True, env=S.ENV, cwd=S.ROOT)
    m = re.search(r"Collected : (\d+)", r.stderr)
    return int(m.group(1)) if m else float("nan")


def one(msim, name, scheme, family, k, h, ref, count=True):
    """the accuracy run (native) and its instruction count: rows, one per T"""
    scene, base = base_opts(name)
    T, dT = S.T_END[scene], S.T_FRAME[scene]
    steps, every = round(T / float(h)), round(dT / float(h))
    opts = f"{base} -msim_dt {h} {solver_opts(scheme, family, k)}"
    rc, err, _, mon, out, user = S.run_timed(msim, f"{opts} -msim_steps {steps} -msim_output_every {every}", f"{name}_b")
    errs = {round(i * float(h), 6): float(np.max(np.linalg.norm(x - ref[round(i * float(h), 6)], axis=1)))
            for i, x in S.frames(out).items() if i > 0 and round(i * float(h), 6) in ref}
    done = max((int(m["step"]) for m in mon), default=0)
    note = (err.strip().splitlines() or [""])[-1][:160] if rc else ""
    nc = min(done, steps, max(1, round(COUNT_T.get(name, T) / float(h))))  # steps counted
    ins = instructions(msim, opts, nc) if count else float("nan")
    ips = ins / (nc * float(h)) if nc else float("nan")
    its = sum(int(m["nonlinear_its"]) for m in mon)
    rows = []
    for t in sorted(x for x in ref if x > 0):
        rows.append(dict(scene=name, scheme=scheme, family=family, k=k, h=h, T=t, error_vs_rk4_m=f"{errs[t]:.4e}" if t in errs else "",
                         steps=steps, steps_done=done, t_stop=f"{done * float(h):.4g}" if rc else "", stopped=note, nonlinear_its=its,
                         run_user_s=f"{user:.3f}", instructions_per_sim_s=f"{ips:.5g}", counted_steps=nc, load_1min=f"{os.getloadavg()[0]:.1f}"))
    print(f"{name} {scheme} {family}-{k} h={float(h):.4g}: {' '.join(f'{t:g}:{e:.3e}' for t, e in sorted(errs.items()))} "
          f"ins/s {ips:.4g} {('STOPPED at step %d: ' % done + note) if rc else ''}", flush=True)
    return rows


def hname(k, rate=ITS_PER_SIM_S):
    return f"{k / rate:.15g}"


def merge(rows):
    keys = {(r["scene"], r["scheme"], r["family"], str(r["k"]), str(r["h"])) for r in rows}
    old = [r for r in csv.DictReader(open(OUT))] if os.path.exists(OUT) else []
    old = [r for r in old if (r["scene"], r["scheme"], r["family"], r["k"], r["h"]) not in keys]
    S.write_csv(OUT, old + rows)


def parse_points(a):
    pts = []
    for p in filter(None, a.points.split(",")):
        name, scheme, family, k, h = p.split(":")
        pts.append((name, scheme, family, int(k), h))
    return pts


def grid(a, msim):
    os.makedirs(S.TMP, exist_ok=True)
    pts = parse_points(a)
    if not pts:
        for name in a.scenes.split(","):
            pts.append((name, "implicit_euler", "PD", 10, S.H30))  # the budget first
            for scheme in a.schemes.split(","):
                for family in a.families.split(","):
                    if (family == "NCG") != (scheme == "ts"):
                        continue
                    for k in map(int, a.ks.split(",")):
                        if family == "AA" and k < 2:
                            continue
                        h = hname(k, a.lb_rate if family == "LB" else ITS_PER_SIM_S)
                        if (name, scheme, family, k, h) not in pts:
                            pts.append((name, scheme, family, k, h))
    refs = {}
    for name, scheme, family, k, h in pts:
        if name not in refs:
            refs[name] = reference(msim, name)
        rows = one(msim, name, scheme, family, k, h, refs[name], count=not a.no_count)
        merge(rows)  # after every run: a long grid keeps what it made


def cpu(a, msim):
    """CPU user seconds per simulated second of --points, alternated with the baseline (PD-10
    implicit Euler at 1/30 s), min of --repeats: (user of n steps - user of 1 step) / ((n - 1) h),
    n the steps to --cpu-t or to where the run stops"""
    os.makedirs(S.TMP, exist_ok=True)
    pts = parse_points(a)
    names = dict.fromkeys(p[0] for p in pts)
    best = {}
    for rep in range(a.repeats):
        for name in names:
            _, base = base_opts(name)
            todo = [(name, "implicit_euler", "PD", 10, S.H30)] + [p for p in pts if p[0] == name]
            for p in todo:
                _, scheme, family, k, h = p
                opts = f"{base} -msim_dt {h} {solver_opts(scheme, family, k)} -msim_output_every 1000000"
                n = round(a.cpu_t / float(h))
                r = S.run_timed(msim, f"{opts} -msim_steps {n}", f"{name}_cpu")
                done = max((int(m["step"]) for m in r[3]), default=0)
                u1 = S.run_timed(msim, f"{opts} -msim_steps 1", f"{name}_cpu1")[-1]
                per = (r[-1] - u1) / max((done - 1) * float(h), 1e-30)
                best[p] = min(best.get(p, float("inf")), per)
                print(f"cpu pass {rep} {p}: {per:.4f} s/s over {done} steps ({r[-1]:.2f} - {u1:.2f} s)", flush=True)
    old = list(csv.DictReader(open(OUT))) if os.path.exists(OUT) else []
    for r in old:
        p = (r["scene"], r["scheme"], r["family"], int(r["k"]), r["h"])
        b = (r["scene"], "implicit_euler", "PD", 10, S.H30)
        if p in best and b in best:
            r["cpu_user_s_per_sim_s"] = f"{best[p]:.4g}"
            r["cpu_vs_budget"] = f"{best[p] / best[b]:.3f}"
    S.write_csv(OUT, old)


def floor(a, msim):
    """the converged scheme at each point's h (its family replaced by a converged solve)"""
    os.makedirs(S.TMP, exist_ok=True)
    refs = {}
    for name, scheme, family, k, h in parse_points(a):
        if name not in refs:
            refs[name] = reference(msim, name)
        merge(one(msim, name, scheme, family, k, h, refs[name], count=False))


MARK = {"PD": "s", "AA": "^", "LB": "v", "NCG": "X", "Newton": "o", "Newton-CG": "o"}


def plot(a):
    rows = list(csv.DictReader(open(OUT)))
    for r in rows:
        r["key"] = (r["scene"], r["scheme"], r["family"], r["k"], r["h"])
    budget = {}
    for r in rows:
        if r["scheme"] == "implicit_euler" and r["family"] == "PD" and r["k"] == "10" and r["h"] == S.H30:
            budget[r["scene"]] = float(r["instructions_per_sim_s"])
    for r in rows:
        ips = float(r["instructions_per_sim_s"] or "nan")
        r["x"] = ips / budget[r["scene"]] if r["scene"] in budget else float("nan")
        r["e"] = float(r["error_vs_rk4_m"]) if r["error_vs_rk4_m"] else float("nan")
    best = []
    for name in dict.fromkeys(r["scene"] for r in rows):
        for T in sorted({float(r["T"]) for r in rows if r["scene"] == name}):
            sel = [r for r in rows if r["scene"] == name and float(r["T"]) == T and r["e"] == r["e"] and r["x"] == r["x"]
                   and r["family"] not in ("Newton", "Newton-CG")]
            inb = [r for r in sel if r["x"] <= 1.1]
            ie = [r for r in inb if r["scheme"] == "implicit_euler"]
            ie30 = [r for r in ie if r["h"] == S.H30]
            so = [r for r in inb if r["scheme"] != "implicit_euler"]
            if not ie or not so:
                continue
            e = lambda r: r["e"]  # noqa: E731
            b_ie, b_ie30, b_so = min(ie, key=e), min(ie30, key=e) if ie30 else None, min(so, key=e)
            f = TARGET.get((SCENES[name][0], T), TARGET.get((SCENES[name][0], None))) if name != "cloth21" else None
            meet = [r for r in sel if r["scheme"] != "implicit_euler" and f and r["e"] * f <= b_ie["e"]]
            cheap = min(meet, key=lambda r: r["x"]) if meet else None
            conv = [r for r in rows if r["scene"] == name and float(r["T"]) == T and r["family"] in ("Newton", "Newton-CG")
                    and r["scheme"] == b_so["scheme"] and r["h"] == b_so["h"] and r["e"] == r["e"]]
            lab = lambda r: f"{r['scheme']} {r['family']}-{r['k']} h={float(r['h']):.4g}"  # noqa: E731
            best.append(dict(scene=name, T=T, target_factor=f or "",
                             ie_best_in_budget=lab(b_ie), ie_best_in_budget_m=f"{b_ie['e']:.3e}", ie_best_in_budget_x=f"{b_ie['x']:.3f}",
                             ie_best_h30_in_budget=lab(b_ie30) if b_ie30 else "", ie_best_h30_in_budget_m=f"{b_ie30['e']:.3e}" if b_ie30 else "",
                             second_order_best_in_budget=lab(b_so), second_order_best_m=f"{b_so['e']:.3e}", second_order_best_x=f"{b_so['x']:.3f}",
                             ratio_vs_ie_best=f"{b_ie['e'] / b_so['e']:.2f}", ratio_vs_ie_h30=f"{b_ie30['e'] / b_so['e']:.2f}" if b_ie30 else "",
                             converged_same_scheme_h_m=f"{conv[0]['e']:.3e}" if conv else "",
                             cheapest_meeting_target=lab(cheap) if cheap else "none", its_cost_x=f"{cheap['x']:.2f}" if cheap else ""))
            print(best[-1])
    S.write_csv(os.path.join(HERE, "budget_best.csv"), best)

    from plots import SCHEME_COLORS as COLORS, pyplot, save, style  # noqa: E402
    plt = pyplot()
    panels = [(n, T) for n in dict.fromkeys(r["scene"] for r in rows) for T in sorted({float(r["T"]) for r in rows if r["scene"] == n})]
    ncol = 5
    nrow = (len(panels) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.9 * nrow + 2.2), squeeze=False)
    for ax, (name, T) in zip(axes.flat, panels):
        sel = [r for r in rows if r["scene"] == name and float(r["T"]) == T and r["family"] not in ("Newton", "Newton-CG")]
        fams = {}
        for r in sel:
            fams.setdefault((r["scheme"], r["family"]), []).append(r)
        for (scheme, family), rs in fams.items():
            rs = sorted(rs, key=lambda r: int(r["k"]))
            pts = [(r["x"], r["e"], r["k"]) for r in rs if r["e"] == r["e"] and r["x"] == r["x"]]
            if not pts:
                continue
            col = COLORS.get("ts alpha2 r=0.5" if scheme == "ts" else scheme, "gray")
            ax.plot([p[0] for p in pts], [p[1] for p in pts], color=col, marker=MARK.get(family, "o"), ms=5, lw=0.8,
                    ls="-" if family == "PD" else "--", label=f"{'ts alpha2 r=0.5' if scheme == 'ts' else scheme}, {family}")
            for x, y, k in pts:
                ax.annotate(k, (x, y), fontsize=6, xytext=(2, 2), textcoords="offset points", color=col)
        ax.axvline(1.0, color="gray", ls=":", lw=1)
        ax.axvline(1.1, color="gray", ls=":", lw=0.6)
        ax.set_xlim(0.85, 1.5)  # the budget's neighbourhood (alpha2 NCG at small h costs 1.3-6 x: beyond, in budget.csv)
        style(ax, "instructions / budget (PD-10 implicit Euler, 1/30 s)", "largest distance from RK4 (m)",
              f"{name}, T = {T:g} s (k: iterations per step)", 8, ylog=True)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    handles = {}
    for ax in axes.flat:
        for hd, lb in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(lb, hd)
    fig.subplots_adjust(left=0.05, right=0.99, top=0.95, bottom=2.2 / (3.9 * nrow + 2.2), hspace=0.4, wspace=0.25)
    fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=6, fontsize=7)
    save(fig, os.path.join(HERE, "budget.png"))


def main():
    p = argparse.ArgumentParser()
    p.add_argument("part", nargs="?", default="grid", choices=("grid", "cpu", "floor", "plot"))
    p.add_argument("--msim", default=os.path.join(S.ROOT, "build", "msim"))
    p.add_argument("--scenes", default="solid,cloth")
    p.add_argument("--schemes", default="implicit_euler,bdf2,implicit_midpoint,newmark,ts")
    p.add_argument("--families", default="PD,AA,NCG")
    p.add_argument("--ks", default="1,2,3,5,10")
    p.add_argument("--lb-rate", type=float, default=ITS_PER_SIM_S, help="family LB: h = k / this (an L-BFGS iteration costs more than a PD one)")
    p.add_argument("--points", default="", help="scene:scheme:family:k:h,... instead of the grid")
    p.add_argument("--count-t", default="cloth:0.2", help="scene:seconds,...: count instructions over the steps to this time only (default: to T)")
    p.add_argument("--no-count", action="store_true", help="skip the instruction counts")
    p.add_argument("--repeats", type=int, default=3)
    p.add_argument("--cpu-t", type=float, default=2.0, help="simulated seconds of a CPU-timed run (fewer where it stops)")
    a = p.parse_args()
    msim = os.path.abspath(a.msim)
    for kv in filter(None, a.count_t.split(",")):
        COUNT_T[kv.split(":")[0]] = float(kv.split(":")[1])
    {"grid": grid, "cpu": cpu, "floor": floor, "plot": lambda a, m: None}[a.part](a, msim)
    plot(a)


if __name__ == "__main__":
    main()
