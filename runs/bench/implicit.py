#!/usr/bin/env python3
"""Implicit Euler on the benchmark cloth (101 x 101, 60,198 springs, 1 m, 1 kg, k = 1000 N/m, two
corners fixed, gravity, h = 1/30 s): ms per step and max RSS at 1 and 2 ranks for each method, and
the one-off PD factorization. Per-step time is PETSc's MSimStep event; the one-off MSimPDSetUp
(assembly + factorization of the PD matrix) is done in the setup stage, or, where a solver builds it
in its first step, taken out of the steps' time; best of 5 runs (2 for
Baraff-Witkin, 1 over 10 steps for Newton): timings on this shared 2-core machine vary by up to 40 % between runs.
Newton on the exact Hessian with MUMPS also counts the steps that converged to a saddle point of
Phi (negative eigenvalues of the Hessian at the solution, from one more LDL^T per step, which the
time includes). Writes implicit.csv.
Usage: implicit.py [ranks, e.g. 1,2] [steps] [only methods containing this text: their rows
replace those in an existing implicit.csv]"""
import csv
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, BENCH_CLOTH, event  # noqa: E402
SCENE = BENCH_CLOTH
METHODS = [
    ("PD, 10 iterations", "-snes_type pd -snes_max_it 10 -snes_pd_fixed"),
    ("PD, 10 iterations, MUMPS factor", "-snes_type pd -snes_max_it 10 -snes_pd_fixed -pd_pc_type cholesky -pd_pc_factor_mat_solver_type mumps"),
    ("PD, 10 iterations, CG + GAMG global step", "-snes_type pd -snes_max_it 10 -snes_pd_fixed -pd_ksp_type cg -pd_pc_type gamg"),
    ("PD + safeguarded Anderson (m=5), 10 iterations", "-snes_type pd -snes_max_it 10 -snes_pd_fixed -snes_pd_anderson 5"),
    ("PETSc Anderson-PD, 10 iterations", "-snes_type anderson -snes_anderson_m 5 -npc_snes_type pd -npc_snes_max_it 1 -npc_snes_pd_fixed -snes_rtol 0 -snes_atol 0 -snes_stol 0 -snes_max_it 10"),
    ("L-BFGS (PD Hessian), 10 iterations", "-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 -snes_rtol 0 -snes_atol 0 -snes_stol 0 -snes_max_it 10"),
    ("Baraff-Witkin (MUMPS Cholesky)", "-snes_type ksponly -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps"),
    ("Newton, |dx| < 1e-3 (at most 20), CG + PD factor, Eisenstat-Walker", "-snes_type newtonls -ksp_type cg -msim_pc_pd -snes_ksp_ew -msim_step_atol 1e-3 -snes_rtol 0 -snes_atol 0 -snes_max_it 20"),
    ("Newton, |dx| < 1e-3 (at most 20), CG + ICC, Eisenstat-Walker", "-snes_type newtonls -ksp_type cg -pc_type icc -snes_ksp_ew -msim_step_atol 1e-3 -snes_rtol 0 -snes_atol 0 -snes_max_it 20"),
    ("Newton, |dx| < 1e-3 (at most 20), PSD Hessian, MUMPS Cholesky", "-snes_type newtonls -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -msim_step_atol 1e-3 -snes_rtol 0 -snes_atol 0 -snes_max_it 20"),
    ("Newton, |dx| < 1e-3 (at most 20), exact Hessian, MUMPS LDL^T", "-snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -msim_step_atol 1e-3 -snes_rtol 0 -snes_atol 0 -snes_max_it 20"),
    ("Newton to 1e-8, exact Hessian, MUMPS LDL^T", "-snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -snes_rtol 1e-8 -snes_atol 0 -snes_max_it 200"),
    ("Newton to 1e-8, exact Hessian + inertia correction, MUMPS LDL^T", "-snes_type newtonls -msim_psd 0 -msim_inertia_correction -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -snes_rtol 1e-8 -snes_atol 0 -snes_max_it 200"),
    ("Newton to 1e-8, PSD Hessian, CG + PD factor", "-snes_type newtonls -ksp_type cg -msim_pc_pd -snes_ksp_ew -snes_rtol 1e-8 -snes_atol 0 -snes_max_it 400"),
    ("Newton to 1e-8, trust region, exact Hessian, Steihaug CG + PD factor", "-snes_type ntr -snes_rtol 1e-8 -snes_atol 0 -snes_max_it 400"),
]


def main():
    ranks = [int(x) for x in (sys.argv[1].split(",") if len(sys.argv) > 1 else ["1", "2"])]
    steps = int(sys.argv[2]) if len(sys.argv) > 2 else 30
    only = sys.argv[3] if len(sys.argv) > 3 else None
    rows = []
    for name, opts in METHODS:
        if only and only not in name:
            continue
        for np in ranks:
            # Newton: 10 steps, not fewer. Its iteration count varies from step to step (7 to 100 on
            # this cloth, where compressed springs make Phi nonconvex), and the first 3 steps
            # are among the cheapest.
            steps_here = steps if "Newton to" not in name else min(steps, 10)
            log = "/tmp/msim_implicit_log.txt"
            cmd = ["mpirun", "-n", str(np), MSIM] + SCENE.split() + opts.split() + ["-msim_steps", str(steps_here), "-msim_monitor_csv", "/tmp/msim_implicit_mon.csv", "-log_view", f":{log}", "-memory_view"]
            best = None
            for rep in range(1 if "Newton to" in name or "MUMPS" in name else (2 if "Baraff" in name or "Newton" in name else 5)):
                r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
                if r.returncode:
                    break
                text = open(log).read()
                nstep, tstep = event(text, "MSimStep")
                # the PD factorization is set up with the integrator; a run that built it inside a
                # step (an NPC msim did not recognise as pd) has it taken out of that step
                _, tsetup = event(text, "MSimPDSetUp", "Stepping")
                if best is None or tstep - tsetup < best[1] - best[2]:
                    best = (nstep, tstep, tsetup, event(text, "MSimPDSetUp")[1], r.stdout, r.stderr)
            if r.returncode:
                print(name, np, "failed:", r.stderr.strip()[-300:])
                continue
            nstep, tstep, tsetup, tfactor, stdout, stderr = best
            r.stdout = stdout
            # Newton on the exact Hessian with MUMPS checks each converged step for a saddle of Phi
            checked = "newtonls" in opts and "-msim_psd 0" in opts and "mumps" in opts
            saddle = re.search(r"in (\d+) of \d+ steps Newton converged to a saddle point of Phi, not a minimum \(up to (\d+) negative", stderr)
            mem = re.search(r"Maximum \(over computational time\) process memory:\s+total\s+(\S+)\s+max\s+(\S+)", r.stdout)
            with open("/tmp/msim_implicit_mon.csv") as f:
                mon = list(csv.DictReader(f))[1:]
            its = sum(int(m["nonlinear_its"]) for m in mon) / len(mon)
            res = max(float(m["residual"]) for m in mon)
            rows.append(dict(method=name, ranks=np, steps=nstep, ms_per_step=round((tstep - tsetup) / nstep * 1e3, 2),
                             pd_factorization_ms=round(tfactor * 1e3, 1), mean_iterations=round(its, 1), max_final_residual=f"{res:.2e}",
                             max_rss_mb_total=round(float(mem.group(1)) / 2**20, 1), max_rss_mb_per_rank=round(float(mem.group(2)) / 2**20, 1),
                             saddle_steps=(saddle.group(1) if saddle else 0) if checked else "",
                             max_negative_eigenvalues=(saddle.group(2) if saddle else 0) if checked else "",
                             options=opts))
            print({k: v for k, v in rows[-1].items() if k != "options"}, flush=True)
    path = os.path.join(HERE, "implicit.csv")
    if only and os.path.exists(path):
        with open(path) as f:
            old = list(csv.DictReader(f))
        new = {(r["method"], str(r["ranks"])): r for r in rows}
        rows = [new.pop((r["method"], r["ranks"]), r) for r in old] + list(new.values())
        order = {name: i for i, (name, _) in enumerate(METHODS)}
        rows.sort(key=lambda r: (order.get(r["method"], len(order)), int(r["ranks"])))
    fields = []
    for r in rows:
        fields += [k for k in r if k not in fields]
    fields = [k for k in fields if k != "options"] + ["options"]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
