#!/usr/bin/env python3
"""Second-order and energy-conserving schemes against implicit Euler (issue 33, item 4).

work: error at t = every frame (the cloth 0.2 ... 1 s, the rope 0.2 ... 1 s, the beam 0.1 ... 0.5 s)
  against RK4 at a tiny step, for implicit_euler, bdf2, implicit_midpoint, newmark (and
  discrete_gradient where this msim has it) each with Newton to convergence (exact Hessian, MUMPS
  LDL^T; --newton cg: Newton-CG on the PD factor to |dx| < 1e-4 m, for the benchmark cloth), PD 10 and 20 iterations, PD + safeguarded Anderson 10, L-BFGS 10 (PETSc's qn), PD + L-BFGS 10 and 8 (msim's fused
  -snes_pd_lbfgs), and PETSc TS alpha2
  (generalized-alpha, radius 1 and 0.5) with msim's analytic Jacobian; h = 1/30 s and finer for
  the cheap solvers. One frame series per run gives every T at once (-msim_output_every).
  Cost (the 2-core host is shared and loaded, so wall time swings by 2-4x): the child's CPU user
  time per simulated second, less that of the same run with one step (setup, PD factor, start-up
  and the first step taken off), over at least about 1 s of CPU (cheap runs are timed over more
  steps than T needs), the least of --repeats runs made in alternation (all configurations once,
  then the cheap ones again); MSimStep's wall seconds (-log_view) of the accuracy run beside it.
  Writes schemes.csv (one row per run and T).
energy: total energy against time for every scheme at h = 1/30 s and at 10 x the symplectic limit
  2/omega_max (SLEPc, -msim_spectrum) on the rope and a cloth (no damping, no drag), Newton to
  convergence and PD-10. Writes energy_schemes.csv.
plot: schemes_work_precision.png (error at each T against cost), energy_schemes.png;
  targets: prints the issue's comparison (error of the best second-order scheme at no more than
  PD-10 implicit Euler's cost against implicit Euler's best) and writes schemes_targets.csv.
Usage: /usr/bin/python3 runs/speed_accuracy/schemes.py [work|energy|plot|all] [--msim PATH]
  [--scenes cloth,rope,solid] [--cloth-n 101] [--rope-n 1000] [--beam 24,6,6] [--energy-cloth-n 31]
  [--repeats 2] [--newton exact|cg] [--schemes implicit_euler,bdf2,...,ts] [--solvers PD-10,PD+L-BFGS-8,...]. Sizes are arguments: a bigger machine runs the same script at the benchmark sizes.
  Rows of the scenes, schemes and solvers run replace theirs in schemes.csv; the others stay."""
import csv
import math
import os
import re
import subprocess
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, ROOT, study_parser, event, write_csv  # noqa: E402
from plots import SCHEME_COLORS as COLORS, energy_drift, pyplot, save, style  # noqa: E402
from vtu import read_vtu  # noqa: E402

TMP = "/tmp/msim_schemes"
H30 = "0.0333333333333333"
NEWTON = ("-snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps "
          "-msim_check_saddle 0 -snes_rtol 1e-9 -snes_atol 1e-12 -snes_stol 0 -snes_max_it 100")
LOOSE = "-snes_rtol 0 -snes_atol 0 -snes_stol 0"
# Newton to convergence on the benchmark cloth (exact Hessian, MUMPS) takes 30-100 s of CPU per
# simulated second on this host: there the converged solver is Newton-CG on the PD factor with
# Eisenstat-Walker to |dx| < 1e-4 m (2.7 mm from the tight solve at T = 0.2 s for implicit Euler in
# trajectory.csv); --newton exact|cg chooses
NEWTON_CG = f"-snes_type newtonls -ksp_type cg -msim_pc_pd -snes_ksp_ew {LOOSE} -msim_step_atol 1e-4 -snes_max_it 30"
# discrete_gradient's Newton: its Jacobian is not symmetric (a Cholesky factor would be wrong) and
# PD / L-BFGS are refused (no objective): MUMPS LU
DG_NEWTON = "-snes_type newtonls -ksp_type preonly -pc_type lu -pc_factor_mat_solver_type mumps -snes_rtol 1e-9 -snes_atol 1e-12 -snes_stol 0 -snes_max_it 100"
DG_NEWTON_LOOSE = f"-snes_type newtonls -ksp_type preonly -pc_type lu -pc_factor_mat_solver_type mumps {LOOSE} -msim_step_atol 1e-4 -snes_max_it 30"
SOLVERS = {  # label: options (msim's own implicit path)
    "Newton": NEWTON,
    "PD-10": "-snes_type pd -snes_pd_fixed -snes_max_it 10",
    "PD-20": "-snes_type pd -snes_pd_fixed -snes_max_it 20",
    "PD+Anderson-10": "-snes_type pd -snes_pd_fixed -snes_pd_anderson 5 -snes_max_it 10",
    "L-BFGS-10": f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it 10",
    # msim's own L-BFGS on the PD matrix, fused with PD's steps (-snes_pd_lbfgs; 3 pairs)
    "PD+L-BFGS-10": "-snes_type pd -snes_pd_fixed -snes_pd_lbfgs 3 -snes_max_it 10",
    "PD+L-BFGS-8": "-snes_type pd -snes_pd_fixed -snes_pd_lbfgs 3 -snes_max_it 8",
}
SOLVER_WANT = set(SOLVERS)  # --solvers: which of them this run makes (the others' rows stay)
TS_ALPHA = {  # label: options (PETSc TS on msim's analytic Jacobian, fixed steps)
    "alpha2 r=1": "-msim_integrator ts -ts_type alpha2 -ts_alpha_radius 1 -ts_adapt_type none",
    "alpha2 r=0.5": "-msim_integrator ts -ts_type alpha2 -ts_alpha_radius 0.5 -ts_adapt_type none",
}
SCHEMES = ["implicit_euler", "bdf2", "implicit_midpoint", "newmark", "discrete_gradient"]
WANT = set(SCHEMES) | {"ts"}  # --schemes: which of them (and "ts" for PETSc's alpha2) this run makes
# simulated time and the interval between compared frames
T_END = {"cloth": 1.0, "rope": 1.0, "solid": 0.5}
T_FRAME = {"cloth": 0.2, "rope": 0.2, "solid": 0.1}
H_REF = {"cloth": "2.5e-5", "rope": "1e-5", "solid": "1e-5"}


def scene_opts(a):
    return {
        "cloth": f"-msim_cloth_n {a.cloth_n}",
        "rope": f"-msim_scene chain -msim_chain_n {a.rope_n} -msim_fix edge",
        "solid": f"-msim_scene box -msim_box_n {a.beam} -msim_box_size 1,0.25,0.25 -msim_fix_plane x_min -msim_young 2e5 -msim_density 100",
    }


def has_integrator(msim, name):
    r = subprocess.run([msim, "-help"], capture_output=True, text=True, env=ENV, cwd=ROOT)
    line = next((l for l in r.stdout.splitlines() if "-msim_integrator" in l), "")
    return re.search(rf"\b{name}\b", line) is not None


def run(msim, args, tag):
    """one msim run: (returncode, stderr, CPU user s of the child, MSimStep s, monitor rows, frames dir)"""
    out, mon, log = f"{TMP}/{tag}", f"{TMP}/{tag}.csv", f"{TMP}/{tag}_log.txt"
    for p in (mon, log):
        if os.path.exists(p):
            os.remove(p)
    if os.path.isdir(out):
        for f in os.listdir(out):
            os.remove(os.path.join(out, f))
    cmd = [msim] + args.split() + ["-msim_spectrum_check", "0", "-msim_output", out, "-msim_monitor_csv", mon, "-log_view", f":{log}"]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV, cwd=ROOT)
    _, err = p.communicate()
    rows = list(csv.DictReader(open(mon))) if os.path.exists(mon) else []
    step_s = event(open(log).read(), "MSimStep")[1] if os.path.exists(log) else float("nan")
    return p.returncode, err, step_s, rows, out


def run_timed(msim, args, tag):
    """run() with the child's CPU user time: measured as the change in RUSAGE_CHILDREN"""
    import resource
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    r = run(msim, args, tag)
    return r + (resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before,)


def frames(out):
    """{frame step: positions (n,3)} of a run's series"""
    got = {}
    if not os.path.isdir(out):
        return got
    for f in os.listdir(out):
        m = re.match(r"frame_(\d+)\.vtu$", f)
        if m:
            got[int(m.group(1))] = read_vtu(os.path.join(out, f))["points"].copy()
    return got


def configs(scene, msim, newton="exact"):
    """[(label, scheme, solver, h, options)]: who runs on this scene"""
    solvers = dict(SOLVERS)
    if newton == "cg":
        del solvers["Newton"]
        solvers = {"Newton-CG |dx|<1e-4": NEWTON_CG, **solvers}
    schemes = [s for s in SCHEMES if (s != "discrete_gradient" or has_integrator(msim, s)) and s in WANT]
    hs = {"cloth": [H30, "0.0166666666666667"], "rope": [H30, "0.01", "0.005"], "solid": [H30, "0.01", "0.005"]}[scene]
    out = []
    for s in schemes:
        if s == "discrete_gradient":
            own = {"Newton": DG_NEWTON} if newton == "exact" else {"Newton LU |dx|<1e-4": DG_NEWTON_LOOSE}
        else:
            own = solvers
        for solver, opts in own.items():
            if solver not in SOLVER_WANT and not (solver.startswith("Newton") and "Newton" in SOLVER_WANT):
                continue
            for h in (hs if solver.startswith("Newton") or solver == "PD-10" else [H30]):
                if scene == "cloth" and solver.startswith("Newton") and h != H30:
                    continue  # seconds per step on the benchmark cloth: one h only
                out.append((f"{s}, {solver}", s, solver, h, f"-msim_integrator {s} {opts}"))
    for label, opts in TS_ALPHA.items() if "ts" in WANT and label in SOLVER_WANT else ():
        for h in (hs if scene != "cloth" else [H30]):  # Newton on the benchmark cloth: one h
            out.append((f"ts {label}", "ts alpha2", label, h, opts))
    return out


def work(a, msim):
    os.makedirs(TMP, exist_ok=True)
    rows = []
    names = []
    for scene in a.scenes:
        name = scene if scene != "cloth" or a.cloth_n == 101 else f"cloth{a.cloth_n}"  # the benchmark cloth is "cloth"
        names.append(name)
        base = scene_opts(a)[scene]
        T, dT = T_END[scene], T_FRAME[scene]
        href = H_REF[scene]
        nref = round(T / float(href))
        out = f"{TMP}/{name}_ref"
        if not os.path.exists(f"{out}/frame_{nref:06d}.vtu") or a.fresh_reference:  # the reference is kept between runs of this script
            rc, err, _, _, out, _ = run_timed(msim, f"{base} -msim_integrator rk4 -msim_dt {href} -msim_steps {nref} -msim_output_every {round(dT / float(href))}", f"{name}_ref")
            if rc:
                sys.exit(f"reference failed: {err[-400:]}")
        ref = {round(k * float(href), 6): x for k, x in frames(out).items()}
        todo = configs(scene, msim, a.newton)
        best = {}
        for rep in range(a.repeats):
            for i, (label, scheme, solver, h, opts) in enumerate(todo):
                key = (label, h)
                if rep > 0 and (key not in best or best[key]["failed"] or best[key]["user"] > a.repeat_below):
                    continue  # later passes re-time only the cheap, successful runs (the targets' range)
                steps = round(T / float(h))
                every = round(dT / float(h))
                t0 = time.time()
                cmd = f"{base} -msim_dt {h} {opts}"
                if rep == 0:  # the accuracy run: frames at every T
                    rc, err, step_s, mon, out, user = run_timed(msim, f"{cmd} -msim_steps {steps} -msim_output_every {every}", f"{name}_{i}")
                    fr = frames(out)
                    errs = {round(k * float(h), 6): float(np.max(np.linalg.norm(x - ref[round(k * float(h), 6)], axis=1)))
                            for k, x in fr.items() if k > 0 and round(k * float(h), 6) in ref}
                    done = max((int(m["step"]) for m in mon), default=0)
                    # a run that stopped (diverged, solver failed) keeps its errors at the frames it
                    # reached and its cost per simulated second over the steps it took
                    rec = dict(failed=rc != 0, errs=errs, steps_done=done, note=(err.strip().splitlines() or [""])[-1][:160] if rc else "",
                               e0=float(mon[0]["total"]) if mon else float("nan"), e1=float(mon[-1]["total"]) if mon else float("nan"),
                               its=sum(int(m["nonlinear_its"]) for m in mon), step_s=step_s / max(done * float(h), 1e-30))
                    best[key] = rec
                    steps_cost, user_n = done, user
                else:
                    rec = best[key]
                    steps_cost = rec["cost_steps"]
                    user_n = None
                # the cost: the same run's user time less that of its first step alone (mesh, PD
                # factor, MUMPS and PETSc start-up), over a run long enough (>= about 1 s of CPU) for
                # the kernel's CPU accounting (ticks of several ms) not to matter: the cheap runs
                # (the rope's PD-10: about 10 ms for its 30 steps) are timed over more steps
                user1 = run_timed(msim, f"{cmd} -msim_steps 1 -msim_output_every 1", f"{name}_{i}_one")[-1]
                if user_n is not None:
                    rec["acc"] = (user_n, steps_cost)  # the accuracy run's own measure
                if user_n is None or (user_n - user1 < 1.0 and not rec["failed"]):
                    if user_n is not None:
                        steps_cost = min(100 * steps, max(steps, int(steps * 1.0 / max(user_n - user1, 0.01))))
                    r = run_timed(msim, f"{cmd} -msim_steps {steps_cost} -msim_output_every {steps_cost}", f"{name}_{i}_cost")
                    steps_cost = max((int(m["step"]) for m in r[3]), default=steps_cost)
                    user_n = r[-1]
                    if steps_cost < rec["acc"][1]:  # the longer run stopped (diverged) before T: keep the accuracy run's
                        user_n, steps_cost = rec["acc"]
                rec["cost_steps"] = steps_cost
                user_s = max(user_n - user1, 0.0) / max((steps_cost - 1) * float(h), 1e-30)
                if user_n - user1 < 0.05:  # a few CPU ticks (a run that diverges within tens of cheap steps): not timed
                    user_s = float("inf")
                rec["user"] = min(rec.get("user", float("inf")), user_s)
                print(f"{name} {label} h={float(h):.4g} pass {rep}: user {user_s:.4f} s/s over {steps_cost} steps, MSimStep wall {rec['step_s']:.3f} s/s "
                      f"{'FAILED ' + rec['note'] if rec['failed'] else ''} errs {', '.join(f'{t:g}:{e:.2e}' for t, e in sorted(rec['errs'].items()))} "
                      f"({time.time() - t0:.0f} s)", flush=True)
        for label, scheme, solver, h, _ in todo:
            b = best[(label, h)]
            for t in sorted(set(ref)):
                if t == 0:
                    continue
                rows.append(dict(scene=name, size=base, scheme=scheme, solver=solver, h=h, T=t,
                                 error_vs_rk4_m=f"{b['errs'][t]:.4e}" if t in b["errs"] else "",
                                 cost_step_s_per_sim_s=f"{b['step_s']:.4g}", cost_user_s_per_sim_s=f"{b['user']:.4g}" if b["user"] < float("inf") else "", cost_steps=b["cost_steps"],
                                 nonlinear_its=b["its"], steps_done=b["steps_done"], failed=b["note"] if b["failed"] else "",
                                 energy_change_J=f"{b['e1'] - b['e0']:.4e}", load_1min=f"{os.getloadavg()[0]:.1f}"))
    merge(os.path.join(HERE, "schemes.csv"), rows, names)


def merge(path, rows, scenes):
    """rows replace those of the same scenes and schemes (--scenes, --schemes); the others stay"""
    kept = []
    if os.path.exists(path):
        with open(path) as f:
            kept = [r for r in csv.DictReader(f) if r["scene"] not in scenes or (r["scheme"].split()[0] not in WANT)
                    or (r["solver"] not in SOLVER_WANT and not (r["solver"].startswith("Newton") and "Newton" in SOLVER_WANT))]
    write_csv(path, kept + rows)


def omega_max(msim, base):
    r = subprocess.run([msim] + base.split() + ["-msim_spectrum"], capture_output=True, text=True, env=ENV, cwd=ROOT)
    return float(re.search(r"omega_max = (\S+)", r.stdout).group(1))


def energy(a, msim):
    """energy against time, every scheme, at h = 1/30 s and at 10 x the symplectic limit"""
    os.makedirs(TMP, exist_ok=True)
    scenes = {"rope": f"-msim_scene chain -msim_chain_n {a.rope_n} -msim_fix edge",
              "cloth": f"-msim_cloth_n {a.energy_cloth_n}"}
    schemes = [s for s in SCHEMES if s != "discrete_gradient" or has_integrator(msim, s)]
    rows = []
    for scene, base in scenes.items():
        om = omega_max(msim, base)
        h10 = 10 * 2 / om
        for hname, h in (("1/30", float(H30)), ("10 x explicit limit", h10)):
            steps = round(a.energy_t / h)
            runs = [(s, solver, f"-msim_integrator {s} {SOLVERS[solver] if s != 'discrete_gradient' else DG_NEWTON}") for s in schemes
                    for solver in (("Newton", "PD-10") if s != "discrete_gradient" else ("Newton",)) if s in WANT]
            runs += [("ts alpha2", label, opts) for label, opts in TS_ALPHA.items() if "ts" in WANT]
            for scheme, solver, opts in runs:
                rc, err, step_s, mon, _, user = run_timed(msim, f"{base} -msim_dt {h:.10g} -msim_steps {steps} -msim_output_every {steps} {opts}", f"energy_{scene}")
                note = (err.strip().splitlines() or [""])[-1][:160] if rc else ""
                for m in mon:
                    rows.append(dict(scene=scene, size=base, omega_max=f"{om:.6g}", h_name=hname, h=f"{h:.6g}", h_omega_max=f"{h * om:.3g}",
                                     scheme=scheme, solver=solver, t=m["t"], total=m["total"], kinetic=m["kinetic"], potential=m["potential"], stopped=note))
                print(f"energy {scene} h={h:.4g} ({hname}, h omega_max {h * om:.3g}) {scheme} {solver}: {len(mon)} steps, "
                      f"E {mon[0]['total'] if mon else '-'} -> {mon[-1]['total'] if mon else '-'} {note}", flush=True)
    path = os.path.join(HERE, "energy_schemes.csv")
    kept = [r for r in csv.DictReader(open(path)) if r["scheme"].split()[0] not in WANT] if os.path.exists(path) else []
    write_csv(path, kept + rows)  # the schemes run replace their rows; the others stay


MARKERS = {"Newton": "o", "Newton-CG |dx|<1e-4": "o", "Newton LU |dx|<1e-4": "o", "PD-10": "s", "PD-20": "D", "PD+Anderson-10": "^", "L-BFGS-10": "v",
           "PD+L-BFGS-10": "<", "PD+L-BFGS-8": ">", "alpha2 r=1": "P", "alpha2 r=0.5": "X"}


def targets(rows):
    """the issue's comparison at each scene and T: cost budget = PD-10 implicit Euler at h = 1/30 s;
    the best second-order scheme within 1.1 x that budget against implicit Euler's best error
    (a) within the same budget, (b) at any cost (at h = 1/30 s: the discretisation error)"""
    out = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        for T in sorted({float(r["T"]) for r in rows if r["scene"] == scene}):
            sel = [r for r in rows if r["scene"] == scene and float(r["T"]) == T and r["error_vs_rk4_m"] and r["cost_user_s_per_sim_s"]]
            budget = [float(r["cost_user_s_per_sim_s"]) for r in sel if r["scheme"] == "implicit_euler" and r["solver"] == "PD-10" and r["h"] == H30]
            if not budget:
                continue
            c = budget[0] * 1.1
            ie_budget = min((r for r in sel if r["scheme"] == "implicit_euler" and float(r["cost_user_s_per_sim_s"]) <= c), key=lambda r: float(r["error_vs_rk4_m"]))
            ie_any = min((r for r in sel if r["scheme"] == "implicit_euler" and r["h"] == H30), key=lambda r: float(r["error_vs_rk4_m"]))
            so = [r for r in sel if r["scheme"] != "implicit_euler" and float(r["cost_user_s_per_sim_s"]) <= c]
            so_best = min(so, key=lambda r: float(r["error_vs_rk4_m"])) if so else None
            so_any = min((r for r in sel if r["scheme"] != "implicit_euler"), key=lambda r: float(r["error_vs_rk4_m"]))
            e = lambda r: float(r["error_vs_rk4_m"])  # noqa: E731
            # the factor (cloth: 2.5 at 0.2 s, 5 at 1 s; rope and beam: 10) and the cheapest
            # second-order run that is that much below implicit Euler's best within the budget
            factor = {0.2: 2.5, 1.0: 5.0}.get(T, 0) if scene.startswith("cloth") else 10.0
            meet = [r for r in sel if r["scheme"] != "implicit_euler" and factor and e(r) * factor <= e(ie_budget)]
            cheapest = min(meet, key=lambda r: float(r["cost_user_s_per_sim_s"])) if meet else None
            out.append(dict(scene=scene, T=T, budget_s_per_sim_s=f"{c:.4g}",
                            ie_best_in_budget=f"{ie_budget['solver']} h={float(ie_budget['h']):.3g}", ie_best_in_budget_m=f"{e(ie_budget):.3e}",
                            ie_best_h30_any_cost=f"{ie_any['solver']}", ie_best_h30_any_cost_m=f"{e(ie_any):.3e}",
                            second_order_in_budget=f"{so_best['scheme']} {so_best['solver']} h={float(so_best['h']):.3g}" if so_best else "none",
                            second_order_in_budget_m=f"{e(so_best):.3e}" if so_best else "",
                            ratio_vs_ie_in_budget=f"{e(ie_budget) / e(so_best):.2f}" if so_best else "",
                            ratio_vs_ie_any_cost=f"{e(ie_any) / e(so_best):.2f}" if so_best else "",
                            second_order_any_cost=f"{so_any['scheme']} {so_any['solver']} h={float(so_any['h']):.3g}",
                            second_order_any_cost_m=f"{e(so_any):.3e}", second_order_any_cost_s=so_any["cost_user_s_per_sim_s"],
                            target_factor=factor or "",
                            cheapest_meeting_target=f"{cheapest['scheme']} {cheapest['solver']} h={float(cheapest['h']):.3g}" if cheapest else "none",
                            its_cost_over_budget=f"{float(cheapest['cost_user_s_per_sim_s']) / c:.2f}" if cheapest else ""))
            print(out[-1])
    return out


def plot(a):
    plt = pyplot()
    path = os.path.join(HERE, "schemes.csv")
    if os.path.exists(path):
        rows = list(csv.DictReader(open(path)))
        tg = targets(rows)
        if tg:
            write_csv(os.path.join(HERE, "schemes_targets.csv"), tg)
        panels = []
        for sc in dict.fromkeys(r["scene"] for r in rows):
            ts = sorted({float(r["T"]) for r in rows if r["scene"] == sc})
            panels += [(sc, ts[0]), (sc, ts[-1])]
        nrow = (len(panels) + 1) // 2
        height = 4.6 * nrow + 1.6  # 1.6 in at the bottom for the legend
        fig, axes = plt.subplots(nrow, 2, figsize=(13, height), squeeze=False)
        for ax, (scene, T) in zip(axes.flat, panels):
            sel = [r for r in rows if r["scene"] == scene and abs(float(r["T"]) - T) < 1e-9]
            budget = [float(r["cost_user_s_per_sim_s"]) for r in sel if r["scheme"] == "implicit_euler" and r["solver"] == "PD-10" and r["h"] == H30 and r["cost_user_s_per_sim_s"]]
            fams = {}
            for r in sel:
                fams.setdefault((r["scheme"], r["solver"]), []).append(r)
            for (scheme, solver), rs in fams.items():
                # joined in order of h (a family's points: the same solver at h = 1/30, 1/60, ...)
                pts = [(float(r["cost_user_s_per_sim_s"]), float(r["error_vs_rk4_m"])) for r in sorted(rs, key=lambda r: -float(r["h"]))
                       if r["error_vs_rk4_m"] and r["cost_user_s_per_sim_s"]]
                if not pts:
                    continue
                ax.plot([p[0] for p in pts], [p[1] for p in pts], color=COLORS.get(scheme, "gray"), marker=MARKERS.get(solver, "o"),
                        ms=5, lw=1 if len(pts) > 1 else 0, ls="-" if len(pts) > 1 else "", label=f"{scheme}, {solver}")
            if budget:
                ax.axvline(budget[0], color="gray", ls=":", lw=1)
            size = sel[0]["size"] if sel else ""
            style(ax, "CPU user seconds per simulated second, setup excluded (1 rank)", "largest vertex distance from RK4 (m)",
                  f"{scene} ({size.replace('-msim_', '')[:60]}), T = {T:g} s\nlines join one solver's h = 1/30 s, 1/60 ...; dotted: PD-10 implicit Euler's cost", 8, xlog=True, ylog=True)
        handles = {}
        for ax in axes.flat:
            for hd, lb in zip(*ax.get_legend_handles_labels()):
                handles.setdefault(lb, hd)
        for ax in list(axes.flat)[len(panels):]:
            ax.axis("off")
        fig.subplots_adjust(left=0.07, right=0.98, top=1 - 0.4 / height, bottom=2.2 / height, hspace=0.35, wspace=0.2)
        fig.legend(list(handles.values()), list(handles.keys()), loc="lower center", ncol=5, fontsize=7)
        fig.savefig(os.path.join(HERE, "schemes_work_precision.png"), dpi=90)
    path = os.path.join(HERE, "energy_schemes.csv")
    if os.path.exists(path):
        rows = list(csv.DictReader(open(path)))
        keys = list(dict.fromkeys((r["scene"], r["h_name"]) for r in rows))
        fig, axes = plt.subplots(len(keys), 2, figsize=(13, 3.8 * len(keys)), squeeze=False)
        for i, (scene, hname) in enumerate(keys):
            sel = [r for r in rows if r["scene"] == scene and r["h_name"] == hname]
            for j, solver_kind in enumerate(("Newton", "PD-10")):
                ax = axes[i][j]
                runs = dict.fromkeys((r["scheme"], r["solver"]) for r in sel)
                for scheme, solver in runs:
                    if (solver_kind == "Newton") != (solver in ("Newton", "alpha2 r=1", "alpha2 r=0.5")):
                        continue
                    rs = [r for r in sel if r["scheme"] == scheme and r["solver"] == solver]
                    energy_drift(ax, rs, color=COLORS.get(scheme, "gray"),
                                 ls="--" if "0.5" in solver else (":" if "r=1" in solver else "-"), lw=2 if "r=1" in solver else 1.2, label=f"{scheme} {solver}" + (" (stopped)" if rs[-1]["stopped"] else ""))
                ax.set_yscale("symlog", linthresh=1e-3)
                style(ax, "t (s)", "E(t) - E(0) (J)", f"{scene}, h = {hname} ({float(sel[0]['h']):.3g} s, h omega_max = {sel[0]['h_omega_max']}): "
                      f"{'Newton to convergence, TS alpha2 (r = 1 dotted: on midpoint)' if solver_kind == 'Newton' else 'PD, 10 iterations'}", 8, legend=dict(fontsize=6))
        save(fig, os.path.join(HERE, "energy_schemes.png"))


def main():
    p = study_parser(("work", "energy", "plot", "all"))
    p.add_argument("--scenes", default="cloth,rope,solid")
    p.add_argument("--cloth-n", type=int, default=101)
    p.add_argument("--rope-n", type=int, default=1000)
    p.add_argument("--beam", default="24,6,6")
    p.add_argument("--energy-cloth-n", type=int, default=31)
    p.add_argument("--energy-t", type=float, default=2.0)
    p.add_argument("--repeats", type=int, default=2)
    p.add_argument("--fresh-reference", action="store_true", help="recompute the RK4 reference even if /tmp holds it")
    p.add_argument("--newton", default="exact", choices=("exact", "cg"), help="the converged solver: exact-Hessian Newton (MUMPS) or Newton-CG to |dx| < 1e-4")
    p.add_argument("--schemes", default=",".join(SCHEMES + ["ts"]), help="which schemes to run (ts: PETSc's alpha2)")
    p.add_argument("--solvers", default=",".join(list(SOLVERS) + list(TS_ALPHA)), help="which solvers to run (labels of SOLVERS and TS_ALPHA; Newton: the scene's converged one); the other solvers' rows stay")
    p.add_argument("--repeat-below", type=float, default=5.0, help="re-time only runs whose user seconds per simulated second are below this")
    a = p.parse_args()
    a.scenes = a.scenes.split(",")
    WANT.clear()
    WANT.update(a.schemes.split(","))
    SOLVER_WANT.clear()
    SOLVER_WANT.update(a.solvers.split(","))
    msim = os.path.abspath(a.msim)
    if a.part in ("work", "all"):
        work(a, msim)
    if a.part in ("energy", "all"):
        energy(a, msim)
    plot(a)


if __name__ == "__main__":
    main()
