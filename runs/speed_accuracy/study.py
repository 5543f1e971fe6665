#!/usr/bin/env python3
"""Speed against accuracy of every integrator and implicit solver, over whole runs.

1. Per-step solver accuracy. Steps 1, 10, 30 and 60 of the benchmark cloth (101 x 101, h = 1/30 s),
   of a falling rope (1000 vertices, one end fixed, h = 1/30 s) and of a tet solid (a cantilever
   beam, 1 x 0.25 x 0.25 m in 24 x 6 x 6 cubes, 7,056 springs, Young's modulus 2e5 Pa, 100 kg/m^3,
   clamped at x = 0, swinging under gravity), each solved by every method
   from the same start: the implicit Euler trajectory solved tightly (exact-Hessian Newton,
   |g| <= 1e-9 |g0|) up to the step before, taken from a checkpoint (-msim_restart).
   -msim_monitor_convergence gives Phi(x_k), |g(x_k)| and wall time per iteration (each solve run
   twice, the faster kept); Phi* is the lowest Phi any method reached on that step. Relative energy
   (Phi_k - Phi*)/(Phi_0 - Phi*), also normalised by Phi_1 - Phi* as the literature does, and
   |g_k|/|g_0|; time to 1e-4 and 1e-6.
   The one-off PD factorization (MSimPDSetUp), which a whole run pays once, is taken out of the
   times of the step it falls in.
2. Trajectory accuracy (work-precision). The largest vertex distance and the energy difference at
   T (the cloth 0.2 s, before it folds chaotically; the rope 1 s; the beam 0.5 s) against (a) the implicit Euler trajectory solved tightly at the same h (solver error
   alone) and (b) RK4 at a tiny step (discretisation + solver error), against the cost per
   simulated second (MSimStep time / T), for every integrator and solver at several h and
   iteration budgets; and the energy PD loses per simulated second against its iteration count,
   next to implicit Euler's own loss (the tight solve).
Writes per_step.csv, per_step_summary.csv, trajectory.csv, per_step.png, work_precision.png,
energy_loss.png. 3. Median over steps 1 ... 30 of the cloth, each from the tight trajectory: time to 1e-4 and
   1e-6 for the fastest methods, the median and the worst step.
Writes also median_steps.csv, median_summary.csv.
Usage: /usr/bin/python3 runs/speed_accuracy/study.py [part: steps|median|trajectory|plot] [scenes]
(or part hessian [steps]: L-BFGS with the PD matrix or the PSD-projected Hessian as initial Hessian)
(scenes: cloth, rope, solid; default all. Rows of the scenes named replace theirs in the CSVs, the
others' stay. One rank for every timed run; the tight reference solves run on 2 ranks)."""
import csv
import math
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, event, write_csv  # noqa: E402

TMP = "/tmp/msim_speed_accuracy"
H = "0.0333333333333333"
SCENES = {
    "cloth": "-msim_cloth_n 101 -msim_integrator implicit_euler",
    "rope": "-msim_scene chain -msim_chain_n 1000 -msim_fix edge -msim_integrator implicit_euler",
    "solid": "-msim_scene box -msim_box_n 24,6,6 -msim_box_size 1,0.25,0.25 -msim_fix_plane x_min -msim_young 2e5 -msim_density 100 -msim_integrator implicit_euler",
}
LOOSE = "-snes_rtol 0 -snes_atol 0 -snes_stol 0"
NEWTON_EXACT = "-snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -msim_check_saddle 0"
TIGHT = f"{NEWTON_EXACT} -snes_rtol 1e-9 -snes_max_it 400"
NEWTON_CG_PD = "-snes_type newtonls -ksp_type cg -msim_pc_pd -snes_ksp_ew"
STEPS = (1, 10, 30, 60)
PER_STEP = [
    ("PD", "-snes_type pd -snes_pd_fixed -snes_max_it 3000"),
    ("PD + safeguarded Anderson", "-snes_type pd -snes_pd_fixed -snes_pd_anderson 5 -snes_max_it 1000"),
    ("PETSc Anderson-PD", f"-snes_type anderson -snes_anderson_m 5 -npc_snes_type pd -npc_snes_max_it 1 -npc_snes_pd_fixed {LOOSE} -snes_max_it 400"),
    ("L-BFGS (PD Hessian)", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it 1500"),
    ("Baraff-Witkin", "-snes_type ksponly -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps"),
    ("Newton, PSD Hessian, MUMPS Cholesky", f"-snes_type newtonls -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps {LOOSE} -snes_max_it 60"),
    ("Newton, exact Hessian, MUMPS LDL^T", f"{NEWTON_EXACT} {LOOSE} -snes_max_it 60"),
    ("Newton-CG, ICC (EW)", f"-snes_type newtonls -ksp_type cg -pc_type icc -snes_ksp_ew {LOOSE} -snes_max_it 100"),
    ("Newton-CG, GAMG (EW)", f"-snes_type newtonls -ksp_type cg -pc_type gamg -snes_ksp_ew {LOOSE} -snes_max_it 60"),
    ("Newton-CG, PD factor (EW)", f"{NEWTON_CG_PD} {LOOSE} -snes_max_it 100"),
    ("trust region (Steihaug CG + PD factor)", f"-snes_type ntr {LOOSE} -snes_max_it 150"),
]


def msim(args, np_=1, check=True):
    cmd = (["mpirun", "-n", str(np_)] if np_ > 1 else []) + [MSIM] + args.split()
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
    if check and r.returncode:
        print("failed:", args, r.stderr.strip()[-400:], flush=True)
    return r


def checkpoints(scene):
    """the tight trajectory's state after steps 9, 29 and 59: ck{k} (a chain of restarts)"""
    prev, done = None, 0
    for k in (s - 1 for s in STEPS if s > 1):
        ck = f"{TMP}/{scene}_ck{k}"
        if not os.path.exists(ck):
            restart = f" -msim_restart {prev}" if prev else ""
            msim(f"{SCENES[scene]} -msim_dt {H} {TIGHT} -msim_steps {k} -msim_checkpoint {ck}{restart}", np_=2)
        prev, done = ck, k
    return done


def solve_step(scene, opts, step, checkpoint):
    """one method on one step from a checkpoint of the step before (None: from the start): its
    history [(iteration, seconds, Phi, |g|)], the one-off PD factorization taken out of the times,
    or None where it wrote none. A solver that ends in failure (ntr with zero tolerances stops with
    DIVERGED_TR_DELTA once its radius is down at roundoff) keeps its history: it is used."""
    path, log = f"{TMP}/conv.csv", f"{TMP}/conv_log.txt"
    for p in (path, log):
        if os.path.exists(p):
            os.remove(p)
    start = f" -msim_restart {checkpoint}" if checkpoint else ""
    r = msim(f"{SCENES[scene]} -msim_dt {H} {opts} -msim_steps {step}{start} -msim_monitor_convergence {path} -log_view :{log}", check=False)
    if not os.path.exists(path):
        print(f"{scene} step {step} {opts}: failed {r.stderr.strip()[-200:]}", flush=True)
        return None
    with open(path) as f:
        it = [(int(x["iteration"]), float(x["wall_s"]), float(x["phi"]), float(x["gnorm"])) for x in csv.DictReader(f) if int(x["step"]) == step]
    _, setup = event(open(log).read(), "MSimPDSetUp", "Stepping") if os.path.exists(log) else (0, 0.0)
    return [(i, max(t - (setup if i > 0 else 0), 0.0), p, g) for i, t, p, g in it]


# the per-step table's solves run twice and keep the faster: this host swings between a fast and a
# slow state for minutes at a time (the same solve 1.5x slower), while the iterations do not change
PER_STEP_REPEATS = 2


def fastest(histories):
    """of several runs of one solve, the one whose last iteration came soonest (None if all failed)"""
    done = [h for h in histories if h]
    return min(done, key=lambda h: h[-1][1]) if done else None


def per_step(scenes):
    rows, summary = [], []
    for scene in scenes:
        checkpoints(scene)
        for step in STEPS:
            data = {}
            for name, opts in PER_STEP:
                it = fastest([solve_step(scene, opts, step, f"{TMP}/{scene}_ck{step - 1}" if step > 1 else None) for _ in range(PER_STEP_REPEATS)])
                if it:
                    data[name] = it
            phi_star = min(p for it in data.values() for _, _, p, _ in it)
            phi0 = next(iter(data.values()))[0][2]
            phi1 = min((it[1][2] for it in data.values() if len(it) > 1), default=phi0)
            for name, it in data.items():
                g0 = it[0][3]
                for i, t, p, g in it:
                    rows.append(dict(scene=scene, step=step, method=name, iteration=i, wall_s=f"{t:.6e}", phi=f"{p:.17e}",
                                     relative_energy=f"{(p - phi_star) / (phi0 - phi_star):.6e}",
                                     relative_energy_from_x1=f"{(p - phi_star) / (phi1 - phi_star):.6e}" if phi1 > phi_star else "",
                                     relative_gnorm=f"{g / g0:.6e}" if g0 > 0 else ""))
                rel = [((p - phi_star) / (phi0 - phi_star), i, t) for i, t, p, _ in it]
                hit4 = next(((i, t) for r_, i, t in rel if r_ <= 1e-4), (None, None))
                hit6 = next(((i, t) for r_, i, t in rel if r_ <= 1e-6), (None, None))
                s = dict(scene=scene, step=step, method=name, iterations=it[-1][0], ms_per_iteration=round(it[-1][1] / max(1, it[-1][0]) * 1e3, 3),
                         iterations_to_1em4=hit4[0], ms_to_1em4=round(hit4[1] * 1e3, 1) if hit4[1] is not None else "",
                         iterations_to_1em6=hit6[0], ms_to_1em6=round(hit6[1] * 1e3, 1) if hit6[1] is not None else "",
                         final_relative_energy=f"{rel[-1][0]:.2e}", final_relative_gnorm=f"{it[-1][3] / it[0][3]:.2e}" if it[0][3] > 0 else "")
                summary.append(s)
                print(s, flush=True)
    merge(os.path.join(HERE, "per_step.csv"), rows, scenes)
    merge(os.path.join(HERE, "per_step_summary.csv"), summary, scenes)


MEDIAN_STEPS = 30
MEDIAN_METHODS = [
    ("L-BFGS (PD Hessian)", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it 800"),
    ("PD + safeguarded Anderson", "-snes_type pd -snes_pd_fixed -snes_pd_anderson 5 -snes_max_it 800"),
    ("Newton-CG, PD factor (EW)", f"{NEWTON_CG_PD} {LOOSE} -snes_max_it 60"),
    ("trust region (Steihaug CG + PD factor)", f"-snes_type ntr {LOOSE} -snes_max_it 60"),
]


def tight_states(last):
    """the tight trajectory of the cloth up to step `last`, a checkpoint after each step
    (cloth_all_ck{k}); returns its Phi at each step"""
    phi_tight = {}
    for k in range(1, last + 1):
        ck, mon = f"{TMP}/cloth_all_ck{k}", f"{TMP}/cloth_all_ck{k}.csv"
        if not os.path.exists(ck):
            restart = f" -msim_restart {TMP}/cloth_all_ck{k - 1}" if k > 1 else ""
            msim(f"{SCENES['cloth']} -msim_dt {H} {TIGHT} -msim_steps {k} -msim_checkpoint {ck} -msim_monitor_csv {mon}{restart}", np_=2)
        with open(mon) as f:
            phi_tight[k] = [float(x["phi"]) for x in csv.DictReader(f) if int(x["step"]) == k][0]
    return phi_tight


def median_steps():
    """the cloth's steps 1 ... 30, each from the tight trajectory's state before it: time to a
    relative energy of 1e-4 and 1e-6 per method; median and worst step"""
    phi_tight = tight_states(MEDIAN_STEPS)
    rows = []
    for k in range(1, MEDIAN_STEPS + 1):
        data = {}
        for name, opts in MEDIAN_METHODS:
            it = solve_step("cloth", opts, k, f"{TMP}/cloth_all_ck{k - 1}" if k > 1 else None)
            if it:
                data[name] = it
        phi_star = min([phi_tight[k]] + [p for it in data.values() for _, _, p, _ in it])
        phi0 = next(iter(data.values()))[0][2]
        for name, it in data.items():
            # three yardsticks: the lowest Phi any solve reached (a method that settles in another
            # local minimum of this nonconvex Phi never gets there), the method's own lowest Phi
            # (the literature's "Phi* from a long run of the same method"), and |g| / |g0|
            own = min(p for _, _, p, _ in it)
            row = dict(step=k, method=name, own_minimum_above_lowest=f"{(own - phi_star) / (phi0 - phi_star):.2e}")
            measures = (("", [((p - phi_star) / (phi0 - phi_star), i, t) for i, t, p, _ in it]),
                        ("_own", [((p - own) / (phi0 - own), i, t) for i, t, p, _ in it]),
                        ("_gnorm", [(g / it[0][3], i, t) for i, t, _, g in it]))
            for suffix, rel in measures:
                for tol, tag in ((1e-4, "1em4"), (1e-6, "1em6")):
                    hit = next(((i, t) for r_, i, t in rel if r_ <= tol), (None, None))
                    row[f"iterations_to_{tag}{suffix}"] = hit[0] if hit[0] is not None else ""
                    row[f"ms_to_{tag}{suffix}"] = round(hit[1] * 1e3, 1) if hit[1] is not None else ""
            rows.append(row)
            print(row, flush=True)
    write_csv(os.path.join(HERE, "median_steps.csv"), rows)
    summary = []
    for name, _ in MEDIAN_METHODS:
        sel = [r for r in rows if r["method"] == name]
        out = dict(method=name, steps=len(sel))
        for tag in ("1em4", "1em6", "1em4_own", "1em6_own", "1em4_gnorm", "1em6_gnorm"):
            times = sorted(float(r[f"ms_to_{tag}"]) if r[f"ms_to_{tag}"] != "" else math.inf for r in sel)
            out[f"median_ms_to_{tag}"] = times[len(times) // 2] if len(times) % 2 else 0.5 * (times[len(times) // 2 - 1] + times[len(times) // 2])
            out[f"worst_ms_to_{tag}"] = times[-1]
            out[f"worst_step_{tag}"] = max(sel, key=lambda r: float(r[f"ms_to_{tag}"]) if r[f"ms_to_{tag}"] != "" else math.inf)["step"]
            out[f"steps_not_reaching_{tag}"] = sum(1 for t in times if t == math.inf)
        summary.append(out)
        print(out, flush=True)
    write_csv(os.path.join(HERE, "median_summary.csv"), summary)


INITIAL_HESSIANS = [
    ("PD matrix", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it 1500"),
    ("PSD-projected Hessian, MUMPS", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 -ksp_type preonly -pc_type cholesky "
                                     f"-pc_factor_mat_solver_type mumps {LOOSE} -snes_max_it 300"),
]


def initial_hessian(steps):
    """L-BFGS with two initial Hessians on some of the cloth's steps (from the tight trajectory):
    iterations and ms to 1e-6 of the lowest Phi and of the method's own lowest Phi (printed only)"""
    phi_tight = tight_states(max(steps))
    for k in steps:
        data = {name: solve_step("cloth", opts, k, f"{TMP}/cloth_all_ck{k - 1}" if k > 1 else None) for name, opts in INITIAL_HESSIANS}
        phi_star = min([phi_tight[k]] + [p for it in data.values() if it for _, _, p, _ in it])
        for name, it in data.items():
            if not it:
                continue
            phi0, own = it[0][2], min(p for _, _, p, _ in it)
            hit = {ref: next(((i, round(t * 1e3)) for i, t, p, _ in it if (p - ref) / (phi0 - ref) <= 1e-6), ("-", "-")) for ref in (phi_star, own)}
            print(f"step {k:2d} L-BFGS, initial Hessian the {name}: 1e-6 of the lowest Phi after {hit[phi_star][0]} iterations, "
                  f"{hit[phi_star][1]} ms; of its own lowest after {hit[own][0]}, {hit[own][1]} ms "
                  f"({(it[-1][1] * 1e3) / max(1, len(it) - 1):.2f} ms per iteration)", flush=True)


def merge(path, rows, scenes):
    """rows replace those of their scenes in path; other scenes' rows are kept"""
    kept = []
    if os.path.exists(path):
        with open(path) as f:
            kept = [r for r in csv.DictReader(f) if r["scene"] not in scenes]
    write_csv(path, kept + rows)


def final_state(path):
    return [float(l) for l in open(path) if l.strip() and l.strip()[0] in "+-0123456789"]


# Final times: the cloth folds chaotically once it buckles (two RK4 runs at h = 1e-4 and 5e-5 end
# 4 cm apart at 1 s), so its trajectories are compared at 0.2 s, before the folds; the rope at 1 s.
T_END = {"cloth": 0.2, "rope": 1.0, "solid": 0.5}


def run_traj(scene, integrator, h, opts, tag, np_=1):
    """final positions, final total energy and MSimStep seconds of a run to T_END"""
    steps = round(T_END[scene] / float(h))
    out, mon, log = f"{TMP}/{tag}.txt", f"{TMP}/{tag}.csv", f"{TMP}/{tag}_log.txt"
    base = SCENES[scene].replace("-msim_integrator implicit_euler", f"-msim_integrator {integrator}")
    r = msim(f"{base} -msim_dt {h} -msim_steps {steps} {opts} -msim_spectrum_check 0 -msim_view_final ascii:{out}:ascii_matlab -msim_monitor_csv {mon} -log_view :{log}", np_=np_)
    if r.returncode:
        return None
    with open(mon) as f:
        energies = [float(x["total"]) for x in csv.DictReader(f)]
    return final_state(out), energies, event(open(log).read(), "MSimStep")[1] / T_END[scene], steps


def distance(a, b):
    return max(math.dist(a[i:i + 3], b[i:i + 3]) for i in range(0, len(a), 3))


def trajectory(scenes):
    """every run to T_END: error against the tight implicit Euler at the same h and against RK4"""
    cases = {  # scene: (RK4 reference h, [(integrator, h, label, options)])
        "cloth": ("2.5e-5", [("symplectic_euler", h, "symplectic Euler", "") for h in ("1.5e-4", "1e-4")]
                  + [("rk4", h, "RK4", "") for h in ("2e-4", "1e-4")]
                  + [("implicit_euler", H, f"PD, {n} its", f"-snes_type pd -snes_pd_fixed -snes_max_it {n}") for n in (5, 10, 20, 50, 100, 200)]
                  + [("implicit_euler", H, f"PD + Anderson, {n} its", f"-snes_type pd -snes_pd_fixed -snes_pd_anderson 5 -snes_max_it {n}") for n in (10, 20, 50, 100)]
                  + [("implicit_euler", H, f"L-BFGS, {n} its", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it {n}") for n in (5, 10, 20, 50, 100)]
                  + [("implicit_euler", H, "Baraff-Witkin", "-snes_type ksponly -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps")]
                  + [("implicit_euler", H, f"Newton-CG PD factor, |dx| < {d}", f"{NEWTON_CG_PD} {LOOSE} -msim_step_atol {d} -snes_max_it 20") for d in ("1e-2", "1e-3", "1e-4", "1e-5")]
                  + [("implicit_euler", H, "Newton MUMPS, |dx| < 1e-3", f"-snes_type newtonls -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps {LOOSE} -msim_step_atol 1e-3 -snes_max_it 20")]
                  + [("implicit_euler", h, "PD, 10 its", "-snes_type pd -snes_pd_fixed -snes_max_it 10") for h in ("0.0166666666666667", "0.00833333333333333")]),
        "rope": ("1e-5", [("symplectic_euler", h, "symplectic Euler", "") for h in ("8e-4", "4e-4", "2e-4", "1e-4")]
                 + [("rk4", h, "RK4", "") for h in ("1e-3", "5e-4", "2.5e-4", "1.25e-4")]
                 + [("implicit_euler", h, "PD, 10 its", "-snes_type pd -snes_pd_fixed -snes_max_it 10") for h in (H, "0.01", "0.001")]
                 + [("implicit_euler", H, f"PD, {n} its", f"-snes_type pd -snes_pd_fixed -snes_max_it {n}") for n in (5, 20, 50, 100, 200)]
                 + [("implicit_euler", H, f"L-BFGS, {n} its", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it {n}") for n in (5, 10, 20, 50)]
                 + [("implicit_euler", h, "Newton-CG PD factor, |dx| < 1e-3", f"{NEWTON_CG_PD} {LOOSE} -msim_step_atol 1e-3 -snes_max_it 20") for h in (H, "0.01", "0.001")]),
        # the beam: omega_max = 2753 rad/s (-msim_spectrum), so symplectic Euler is stable below
        # 2 / omega_max = 7.3e-4 s and RK4 below 2.8 / omega_max = 1.0e-3 s
        "solid": ("1e-5", [("symplectic_euler", h, "symplectic Euler", "") for h in ("5e-4", "2.5e-4", "1.25e-4")]
                  + [("rk4", h, "RK4", "") for h in ("8e-4", "4e-4", "2e-4")]
                  + [("implicit_euler", h, "PD, 10 its", "-snes_type pd -snes_pd_fixed -snes_max_it 10") for h in (H, "0.01")]
                  + [("implicit_euler", H, f"PD, {n} its", f"-snes_type pd -snes_pd_fixed -snes_max_it {n}") for n in (5, 20, 50, 100, 200)]
                  + [("implicit_euler", H, f"L-BFGS, {n} its", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it {n}") for n in (5, 10, 20, 50)]
                  + [("implicit_euler", H, "Baraff-Witkin", "-snes_type ksponly -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps")]
                  + [("implicit_euler", H, f"Newton-CG GAMG, |dx| < {d}", f"-snes_type newtonls -ksp_type cg -pc_type gamg -snes_ksp_ew {LOOSE} -msim_step_atol {d} -snes_max_it 20") for d in ("1e-2", "1e-3", "1e-4")]
                  + [("implicit_euler", h, "Newton-CG PD factor, |dx| < 1e-3", f"{NEWTON_CG_PD} {LOOSE} -msim_step_atol 1e-3 -snes_max_it 20") for h in (H, "0.01")]),
    }
    rows = []
    for scene, (href, runs) in cases.items():
        if scene not in scenes:
            continue
        ref = run_traj(scene, "rk4", href, "", f"{scene}_rk4_ref")
        tight = {}
        for integrator, h, label, opts in runs:
            if integrator == "implicit_euler" and h not in tight:
                tight[h] = run_traj(scene, "implicit_euler", h, TIGHT, f"{scene}_tight_{h}", np_=2)
                x, e, _, n = tight[h]
                rows.append(dict(scene=scene, integrator="implicit_euler", h=h, method="implicit Euler, tight (reference)", steps=n, ms_per_step="",
                                 cost_s_per_sim_s="", error_vs_tight_m=0, error_vs_rk4_m=f"{distance(x, ref[0]):.3e}",
                                 energy_vs_rk4_J=f"{e[-1] - ref[1][-1]:.3e}", energy_lost_per_s_J=f"{(e[0] - e[-1]) / T_END[scene]:.4e}"))
                print(rows[-1], flush=True)
            got = run_traj(scene, integrator, h, opts, f"{scene}_{integrator}_{h}_{len(rows)}")
            if got is None:
                continue
            x, e, t, n = got
            vs_tight = distance(x, tight[h][0]) if integrator == "implicit_euler" else ""
            rows.append(dict(scene=scene, integrator=integrator, h=h, method=label, steps=n, ms_per_step=round(t * T_END[scene] / n * 1e3, 3), cost_s_per_sim_s=round(t, 4),
                             error_vs_tight_m=f"{vs_tight:.3e}" if vs_tight != "" else "", error_vs_rk4_m=f"{distance(x, ref[0]):.3e}",
                             energy_vs_rk4_J=f"{e[-1] - ref[1][-1]:.3e}", energy_lost_per_s_J=f"{(e[0] - e[-1]) / T_END[scene]:.4e}"))
            print(rows[-1], flush=True)
    merge(os.path.join(HERE, "trajectory.csv"), rows, scenes)


def plot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    if not all(os.path.exists(os.path.join(HERE, f)) for f in ("per_step.csv", "trajectory.csv")):
        print("plot: run the steps and trajectory parts first")
        return
    with open(os.path.join(HERE, "per_step.csv")) as f:
        rows = list(csv.DictReader(f))
    shown = [sc for sc in SCENES if any(r["scene"] == sc for r in rows)]
    fig, axes = plt.subplots(len(shown), len(STEPS), figsize=(4.2 * len(STEPS), 4 * len(shown)), sharey=True, squeeze=False)
    for r_, scene in enumerate(shown):
        for c, step in enumerate(STEPS):
            ax = axes[r_][c]
            for name, _ in PER_STEP:
                sel = [r for r in rows if r["scene"] == scene and int(r["step"]) == step and r["method"] == name]
                if not sel:
                    continue
                ax.plot([max(float(r["wall_s"]), 1e-4) for r in sel], [max(float(r["relative_energy"]), 1e-16) for r in sel],
                        marker="o" if len(sel) < 4 else None, ms=3, label=name)
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.axhline(1e-6, color="k", lw=0.6, ls=":")
            ax.set_title(f"{scene}, step {step}")
            ax.set_xlabel("wall time (s)")
            ax.grid(True, alpha=0.3)
        axes[r_][0].set_ylabel("(Phi_k - Phi*) / (Phi_0 - Phi*)")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "per_step.png"), dpi=100)

    with open(os.path.join(HERE, "trajectory.csv")) as f:
        traj = [r for r in csv.DictReader(f)]
    fig, axes = plt.subplots(2, 2, figsize=(13, 10))
    panels = [("cloth", "error_vs_rk4_m", "cloth: error at T = 0.2 s against RK4 (discretisation + solver)"),
              ("cloth", "error_vs_tight_m", "cloth: against implicit Euler solved tightly (solver error)"),
              ("rope", "error_vs_rk4_m", "rope: error at T = 1 s against RK4"),
              ("solid", "error_vs_rk4_m", "tet beam: error at T = 0.5 s against RK4")]
    for ax, (scene, col, title) in zip(axes.flat, panels):
        families = {}
        for r in traj:
            if r["scene"] != scene or not r[col] or not r["cost_s_per_sim_s"]:
                continue
            fam = r["method"].split(",")[0] + (f" (h = {float(r['h']):.3g})" if r["integrator"] == "implicit_euler" and "PD, 10" in r["method"] else "")
            families.setdefault(fam, []).append((float(r["cost_s_per_sim_s"]), max(float(r[col]), 1e-12)))
        for fam, pts in families.items():
            pts.sort()
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", ms=4, label=fam)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("cost: wall seconds per simulated second (1 rank)")
        ax.set_ylabel("largest vertex distance at T (m)")
        ax.set_title(title, fontsize=9)
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "work_precision.png"), dpi=100)

    fig, ax = plt.subplots(figsize=(6.5, 4.3))
    for scene in SCENES:
        pts = sorted((int(r["method"].split()[1]), float(r["energy_lost_per_s_J"])) for r in traj
                     if r["scene"] == scene and r["method"].startswith("PD, ") and r["h"] == H)
        tight = [float(r["energy_lost_per_s_J"]) for r in traj if r["scene"] == scene and "tight" in r["method"] and r["h"] == H]
        line = ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=f"{scene}: PD")
        if tight:
            ax.axhline(tight[0], color=line[0].get_color(), ls="--", lw=1, label=f"{scene}: implicit Euler solved tightly")
    ax.set_xscale("log")
    ax.set_xlabel("PD iterations per step (h = 1/30 s)")
    ax.set_ylabel("energy lost per simulated second (J/s)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "energy_loss.png"), dpi=100)


def main():
    os.makedirs(TMP, exist_ok=True)
    part = sys.argv[1] if len(sys.argv) > 1 else "all"
    scenes = sys.argv[2:] or list(SCENES)
    if part in ("steps", "all"):
        per_step(scenes)
    if part in ("median", "all"):
        median_steps()
    if part in ("trajectory", "all"):
        trajectory(scenes)
    if part == "hessian":  # an experiment, printed only: study.py hessian [steps, e.g. 2 6]
        initial_hessian([int(k) for k in sys.argv[2:]] or [2, 6])
        return
    plot()


if __name__ == "__main__":
    main()
