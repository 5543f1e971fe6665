#!/usr/bin/env python3
"""The least time Newton with a direct linear solver can take per step on the benchmark cloth
(101 x 101, k = 1000 N/m, h = 1/30 s), from its parts: every Newton iteration assembles the Hessian
(MSimJacobian) and factors it (MatCholFctrNum), so a step that needs n iterations costs at least
n numeric factorizations, whatever the assembly, the line search and the solves add (the floor
leaves them out; assembly is listed beside it). Even a warm start cannot bring n below 2: one
Newton step squares the relative residual at best, and PD's 10 iterations leave about 1e-3 of |g0|
(30-500 PD + Anderson iterations before Newton, measured, still left 2-5 Newton iterations), so
two_factorizations_ms is the least any direct-solver Newton step to 1e-8 can cost here. The
Baraff-Witkin rows come from 5-step runs whose first, cold calls weigh more: inside Newton the same
MUMPS factorization is faster.
n is the fewest iterations any of the first 3 Newton steps needed to reach |g| <= 1e-8 |g0| (exact
Hessian, MUMPS LDL^T), and that run times its own factorizations and assemblies. The other
factorizations are timed on Baraff-Witkin steps (one assembly and one factorization per step, best
of 3 runs of 5 steps) on the PSD-projected Hessian, which has the same nonzero pattern (on the
exact one Baraff-Witkin diverges by step 3). MUMPS also reports the factor's size and flop count
(INFOG(29), RINFOG(3)) and the ordering it used (INFOG(7): 4 is PORD; this MUMPS build has no
METIS or SCOTCH and falls back to PORD when asked for them).
Writes newton_floor.csv. Usage: newton_floor.py [ranks, e.g. 1,2]"""
import csv
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, BENCH_CLOTH, event  # noqa: E402
SCENE = BENCH_CLOTH
NEWTON = "-snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -snes_rtol 1e-8 -snes_atol 0 -snes_max_it 200 -msim_check_saddle 0"
NEWTON_NAME = "MUMPS LDL^T, exact Hessian, inside Newton"
# (name, options, parallel?) on the PSD-projected Hessian (msim's default for Cholesky)
FACTORS = [
    ("MUMPS, PSD Hessian", "-pc_factor_mat_solver_type mumps", True),
    ("MUMPS, PSD Hessian, AMD ordering", "-pc_factor_mat_solver_type mumps -mat_mumps_icntl_7 0", True),
    ("CHOLMOD, PSD Hessian", "-pc_factor_mat_solver_type cholmod", False),
    ("PETSc Cholesky (nested dissection), PSD Hessian", "-pc_factor_mat_solver_type petsc -pc_factor_mat_ordering_type nd", False),
]
TARGET_MS = 150.0



def run(np, opts, steps, extra=()):
    log = "/tmp/msim_floor_log.txt"
    cmd = ["mpirun", "-n", str(np), MSIM] + SCENE.split() + opts.split() + ["-msim_steps", str(steps), "-log_view", f":{log}"] + list(extra)
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
    if r.returncode:
        sys.exit(f"newton_floor.py: {' '.join(cmd)} failed: {r.stderr.strip()[-300:]}")
    return r.stdout + r.stderr, open(log).read()


def parts(out, log):
    nf, tf = event(log, "MatCholFctrNum")
    nj, tj = event(log, "MSimJacobian")
    return tf / nf * 1e3, tj / nj * 1e3, out


def row(name, np, fewest, factor_ms, assembly_ms, out, opts):
    flops, entries, ordering = (re.search(rf"{key}.*\):\s*(\S+)\s*$", out, re.M) for key in (r"RINFOG\(3\)", r"INFOG\(29\)", r"INFOG\(7\)"))
    return dict(factorization=name, ranks=np, numeric_factorization_ms=round(factor_ms, 1), hessian_assembly_ms=round(assembly_ms, 1),
                factor_gflop=round(float(flops.group(1)) / 1e9, 2) if flops else "", factor_entries=entries.group(1) if entries else "",
                mumps_ordering_used=ordering.group(1) if ordering else "", fewest_newton_iterations=fewest,
                floor_ms_per_step=round(fewest * factor_ms, 1), two_factorizations_ms=round(2 * factor_ms, 1), one_factorization_over_target=round(factor_ms / TARGET_MS, 2),
                options=opts)


def main():
    ranks = [int(x) for x in (sys.argv[1].split(",") if len(sys.argv) > 1 else ["1", "2"])]
    rows = []
    for np in ranks:
        mon = "/tmp/msim_floor_mon.csv"
        factor_ms, assembly_ms, out = parts(*run(np, NEWTON, 3, ["-msim_monitor_csv", mon, "-ksp_view"]))
        with open(mon) as f:
            its = [int(r["nonlinear_its"]) for r in list(csv.DictReader(f))[1:]]
        print(f"{np} rank(s): Newton iterations in steps 1-3: {its}", flush=True)
        rows.append(row(NEWTON_NAME, np, min(its), factor_ms, assembly_ms, out, NEWTON))
        print({k: v for k, v in rows[-1].items() if k != "options"}, flush=True)
        for name, opts, parallel in FACTORS:
            if np > 1 and not parallel:
                continue
            base = f"-snes_type ksponly -ksp_type preonly -pc_type cholesky {opts}"
            best = min((parts(*run(np, base, 5, ["-ksp_view"] if "mumps" in opts else [])) for _ in range(3)), key=lambda p: p[0] + p[1])
            rows.append(row(name, np, min(its), *best, base))
            print({k: v for k, v in rows[-1].items() if k != "options"}, flush=True)
    with open(os.path.join(HERE, "newton_floor.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


if __name__ == "__main__":
    main()
