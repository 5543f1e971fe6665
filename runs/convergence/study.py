#!/usr/bin/env python3
"""Speed versus accuracy of the implicit solvers on the benchmark cloth (101 x 101, k = 1000 N/m,
h = 1/30 s): every method solves the same first step g(x) = 0 (from rest, x0 = x_n + h v_n).
-msim_monitor_convergence records Phi(x_k), |g(x_k)| and the solver's wall time per iteration
(monitoring excluded). Phi* is the lowest Phi any method reached (Newton converges to roundoff).
Plots relative energy (Phi_k - Phi*)/(Phi_0 - Phi*) against iterations and seconds, and reports
the time each method needs to reach 1e-6. Writes convergence.csv, summary.csv, convergence.png.
Usage: /usr/bin/python3 runs/convergence/study.py [ranks]"""
import csv
import os
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, BENCH_CLOTH  # noqa: E402
SCENE = BENCH_CLOTH + " -msim_steps 1"
LOOSE = "-snes_rtol 0 -snes_atol 0 -snes_stol 0"
METHODS = [
    ("PD", f"-snes_type pd -snes_pd_fixed -snes_max_it 20000"),
    ("PD + safeguarded Anderson (m=5)", f"-snes_type pd -snes_pd_fixed -snes_pd_anderson 5 -snes_max_it 1500"),
    ("PETSc Anderson-PD (m=5)", f"-snes_type anderson -snes_anderson_m 5 -npc_snes_type pd -npc_snes_max_it 1 -npc_snes_pd_fixed {LOOSE} -snes_max_it 400"),
    ("NGMRES-PD", f"-snes_type ngmres -npc_snes_type pd -npc_snes_max_it 1 -npc_snes_pd_fixed {LOOSE} -snes_max_it 400"),
    ("L-BFGS, PD initial Hessian (m=5)", f"-snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it 400"),
    ("Newton, exact Hessian, MUMPS", "-snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps -snes_rtol 1e-14 -snes_atol 1e-14 -snes_max_it 30"),
]


def main():
    np = int(sys.argv[1]) if len(sys.argv) > 1 else 1
    data = {}
    for name, opts in METHODS:
        path = f"/tmp/msim_conv_{len(data)}.csv"
        cmd = ["mpirun", "-n", str(np), MSIM] + SCENE.split() + opts.split() + ["-msim_monitor_convergence", path]
        r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
        if r.returncode:
            print(name, "failed:", r.stderr[-400:])
            continue
        with open(path) as f:
            rows = [(int(x["iteration"]), float(x["wall_s"]), float(x["phi"]), float(x["gnorm"])) for x in csv.DictReader(f)]
        data[name] = rows
        print(f"{name}: {len(rows)} iterations, final |g| {rows[-1][3]:.2e}", flush=True)
    phi_star = min(p for rows in data.values() for _, _, p, _ in rows)
    phi0 = next(iter(data.values()))[0][2]
    summary = []
    with open(os.path.join(HERE, "convergence.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["method", "iteration", "wall_s", "phi", "gnorm", "relative_energy"])
        for name, rows in data.items():
            for it, t, p, g in rows:
                w.writerow([name, it, f"{t:.6e}", f"{p:.17e}", f"{g:.6e}", f"{(p - phi_star) / (phi0 - phi_star):.6e}"])
    for name, rows in data.items():
        rel = [((p - phi_star) / (phi0 - phi_star), it, t) for it, t, p, _ in rows]
        hit = next(((it, t) for r, it, t in rel if r <= 1e-6), (None, None))
        per_it = rows[-1][1] / max(1, rows[-1][0])
        summary.append(dict(method=name, ranks=np, iterations_to_1em6=hit[0], seconds_to_1em6=hit[1], ms_per_iteration=round(per_it * 1e3, 3),
                            final_relative_energy=rel[-1][0]))
    pd = next((s for s in summary if s["method"] == "PD"), None)
    for s in summary:
        s["speedup_vs_PD_to_1em6"] = round(pd["seconds_to_1em6"] / s["seconds_to_1em6"], 1) if pd and pd["seconds_to_1em6"] and s["seconds_to_1em6"] else ""
        print(s)
    with open(os.path.join(HERE, "summary.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(summary[0].keys()))
        w.writeheader()
        w.writerows(summary)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.3))
    for name, rows in data.items():
        rel = [max((p - phi_star) / (phi0 - phi_star), 1e-16) for _, _, p, _ in rows]
        axes[0].plot([it for it, _, _, _ in rows], rel, label=name)
        axes[1].plot([max(t, 1e-4) for _, t, _, _ in rows], rel, label=name)
    for ax, xl in zip(axes, ("iteration", "wall time (s)")):
        ax.set_yscale("log")
        ax.set_xscale("log")
        ax.axhline(1e-6, color="k", lw=0.6, ls=":")
        ax.set_xlabel(xl)
        ax.set_ylabel("(Phi_k - Phi*) / (Phi_0 - Phi*)")
        ax.grid(True, which="major", alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[0].set_title(f"Benchmark cloth 101 x 101, first step, {np} rank(s)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "convergence.png"), dpi=110)


if __name__ == "__main__":
    main()
