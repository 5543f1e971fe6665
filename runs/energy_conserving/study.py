#!/usr/bin/env python3
"""Energy against time for the discrete-gradient scheme and the other implicit schemes (issue 33,
item 2): the undamped chain at 10 x its explicit limit for 10^4 steps, and an undamped 11 x 11
cloth at h = 1/30 s for 600 steps, each scheme solved by Newton to |r| < 1e-13 with a direct
factorization. Writes energy.csv (every step of the cloth, every 10th of the chain), summary.csv
and energy.png here; with "sweep", midpoint, Newmark and the discrete gradient on the chain at 0.5 ... 30 x
the explicit limit (sweep.csv); with "cloth31 [steps]", the discrete gradient on the 31 x 31 cloth of
runs/speed_accuracy's energy chart (msim's default cloth: two corners held, gravity, no damping or
drag) at h = 1/30 s, with msim's default solver for it and with MUMPS LU to |r| < 1e-12
(cloth31.csv, every step's energy, Newton iterations and |r|; cloth31.png; "cloth31 plot" redraws it
from the CSV).
Usage: /usr/bin/python3 runs/energy_conserving/study.py [path/to/msim [sweep | cloth31 [steps]]]."""
import math
import os
import subprocess
import sys
import tempfile

import numpy as np
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import msimrun as mr

HERE = os.path.dirname(os.path.abspath(__file__))
MSIM = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else mr.MSIM
SCHEMES = ("discrete_gradient", "implicit_midpoint", "newmark", "bdf2", "implicit_euler")
# fixed-fixed chain of 8 vertices (6 free masses of 0.125 kg), k = 1000 N/m:
# omega_max = 2 sqrt(k/m) sin(6 pi/14) = 174.40 rad/s (msim -msim_spectrum agrees), limit 2/omega_max
K, MASS, N = 1000.0, 1.0, 8
OMEGA = 2 * math.sqrt(K / (MASS / N)) * math.sin((N - 2) * math.pi / (2 * (N - 1)))
H_CHAIN = 10 * 2 / OMEGA
SCENES = {
    "chain": (["-msim_scene", "chain", "-msim_chain_n", str(N), "-msim_fix", "corners", "-msim_stiffness", repr(K), "-msim_mass", repr(MASS)], H_CHAIN, 10000, 10),
    "cloth": (["-msim_cloth_n", "11", "-msim_stiffness", repr(K), "-msim_mass", "1"], 1 / 30, 600, 1),
}
TOL = ["-snes_rtol", "0", "-snes_atol", "1e-13", "-snes_stol", "0", "-snes_max_it", "200", "-msim_spectrum_check", "0"]
# the residual scheme takes a nonsymmetric LU; the minimizations msim's Newton with MUMPS Cholesky
SOLVER = {"discrete_gradient": ["-ksp_type", "preonly", "-pc_type", "lu"]}
DEFAULT = ["-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps"]


def run(scene, scheme, tmp):
    args, h, steps, _ = SCENES[scene]
    csv = os.path.join(tmp, f"{scene}_{scheme}.csv")
    cmd = [MSIM] + args + ["-msim_integrator", scheme, "-msim_dt", repr(h), "-msim_steps", str(steps), "-msim_monitor_csv", csv] + TOL + SOLVER.get(scheme, DEFAULT)
    before = os.times()
    r = subprocess.run(cmd, capture_output=True, text=True, env=mr.ENV)
    after = os.times()
    rows = list(__import__("csv").DictReader(open(csv))) if os.path.exists(csv) else []
    err = r.stderr.strip().splitlines()[-1] if r.returncode and r.stderr.strip() else ""
    return cmd, rows, r.returncode, err, after.children_user - before.children_user


def sweep(tmp):
    """midpoint and the discrete gradient on the chain at h = 0.5 ... 30 x the explicit limit, 2000
    steps each: the largest |E - E0| relative to the largest kinetic energy, and where a run stops"""
    rows = []
    args = SCENES["chain"][0]
    for mult in (0.5, 1, 2, 3, 5, 10, 30):
        for scheme in ("discrete_gradient", "implicit_midpoint", "newmark"):
            csv = os.path.join(tmp, f"sweep_{scheme}_{mult}.csv")
            cmd = [MSIM] + args + ["-msim_integrator", scheme, "-msim_dt", repr(mult * 2 / OMEGA), "-msim_steps", "2000", "-msim_monitor_csv", csv] + TOL + SOLVER.get(scheme, DEFAULT)
            r = subprocess.run(cmd, capture_output=True, text=True, env=mr.ENV)
            mon = list(__import__("csv").DictReader(open(csv))) if os.path.exists(csv) else []
            e = np.array([float(x["total"]) for x in mon])
            k = np.array([float(x["kinetic"]) for x in mon])
            dev = np.abs(e - e[0])
            rows.append({"scheme": scheme, "h_over_limit": mult, "h": mult * 2 / OMEGA, "steps_done": len(mon) - 1, "diverged": int(r.returncode != 0),
                         "relative_drift": dev.max() / k.max(), "drift_first_half": dev[: len(dev) // 2].max() / k.max(), "drift_second_half": dev[len(dev) // 2:].max() / k.max()})
            print(f"sweep {scheme:18s} h = {mult:4g} x limit: steps {len(mon) - 1:4d} rel drift {rows[-1]['relative_drift']:.2e}{' (diverged)' if r.returncode else ''}", flush=True)
    mr.write_csv(os.path.join(HERE, "sweep.csv"), rows)


def cloth31(tmp, steps):
    """the 31 x 31 cloth at h = 1/30 s: msim's default Newton for the discrete gradient (GMRES with
    ILU, -snes_max_it 50, relative tolerance 1e-8) and Newton with MUMPS LU to |r| < 1e-12 and
    -snes_max_it 2000 (both with msim's l2 line search)"""
    variants = {"default": [],
                "LU": ["-ksp_type", "preonly", "-pc_type", "lu", "-pc_factor_mat_solver_type", "mumps", "-snes_rtol", "0", "-snes_atol", "1e-12", "-snes_stol", "0", "-snes_max_it", "2000"]}
    rows = []
    for name, opts in variants.items():
        csv = os.path.join(tmp, f"cloth31_{name}.csv")
        cmd = [MSIM, "-msim_cloth_n", "31", "-msim_integrator", "discrete_gradient", "-msim_dt", repr(1 / 30), "-msim_steps", str(steps), "-msim_monitor_csv", csv] + opts
        before = os.times()
        r = subprocess.run(cmd, capture_output=True, text=True, env=mr.ENV)
        user = os.times().children_user - before.children_user
        mon = list(__import__("csv").DictReader(open(csv))) if os.path.exists(csv) else []
        e0 = float(mon[0]["total"])
        for x in mon:
            rows.append({"solver": name, "step": int(x["step"]), "t": float(x["t"]), "total": float(x["total"]), "E_minus_E0": float(x["total"]) - e0,
                         "kinetic": float(x["kinetic"]), "newton_its": int(x["nonlinear_its"]), "linear_its": int(x["linear_its"]), "residual": float(x["residual"])})
        its = [int(x["nonlinear_its"]) for x in mon[1:]]
        dev = max(abs(float(x["total"]) - e0) for x in mon)
        print(f"cloth31 {name}: {len(mon) - 1}/{steps} steps, max |E - E0| {dev:.3e} J, largest kinetic {max(float(x['kinetic']) for x in mon):.3f} J, "
              f"Newton {np.mean(its):.0f}/step (max {max(its)}), user {user:.1f} s, exit {r.returncode}; {' '.join(os.path.relpath(c) if c == MSIM else c for c in cmd)}", flush=True)
    mr.write_csv(os.path.join(HERE, "cloth31.csv"), rows)
    plot_cloth31(rows)


def plot_cloth31(rows):
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6))
    for name, style in (("default", "tab:red"), ("LU", "tab:green")):
        sel = [r for r in rows if r["solver"] == name]
        t = np.array([float(r["t"]) for r in sel])
        label = "msim's default (GMRES + ILU, max 50 its)" if name == "default" else "MUMPS LU, |r| < 1e-12, max 2000 its"
        axes[0].plot(t, [abs(float(r["E_minus_E0"])) for r in sel], color=style, label=label)
        axes[1].plot(t[1:], [int(r["newton_its"]) for r in sel][1:], color=style, label=label)
    axes[0].set_yscale("log")
    axes[0].set_ylabel("|E(t) - E(0)| (J)")
    axes[1].set_yscale("log")
    axes[1].set_ylabel("Newton iterations in the step")
    for ax in axes:
        ax.set_xlabel("t (s)")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("discrete_gradient, undamped 31 x 31 cloth, h = 1/30 s", fontsize=10)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "cloth31.png"), dpi=110)


def main():
    if len(sys.argv) > 3 and sys.argv[2] == "cloth31" and sys.argv[3] == "plot":
        plot_cloth31(list(__import__("csv").DictReader(open(os.path.join(HERE, "cloth31.csv")))))
        return
    if len(sys.argv) > 2 and sys.argv[2] == "cloth31":
        with tempfile.TemporaryDirectory() as tmp:
            cloth31(tmp, int(sys.argv[3]) if len(sys.argv) > 3 else 60)
        return
    if len(sys.argv) > 2 and sys.argv[2] == "sweep":
        with tempfile.TemporaryDirectory() as tmp:
            sweep(tmp)
        return
    energy, summary = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for scene, (_, h, steps, every) in SCENES.items():
            for scheme in SCHEMES:
                cmd, rows, rc, err, user = run(scene, scheme, tmp)
                e = np.array([float(x["total"]) for x in rows])
                k = np.array([float(x["kinetic"]) for x in rows])
                nl = np.array([int(x["nonlinear_its"]) for x in rows[1:]])
                for i, x in enumerate(rows):
                    if i % every == 0 or i == len(rows) - 1:
                        energy.append({"scene": scene, "scheme": scheme, "step": int(x["step"]), "t": float(x["t"]), "total": float(x["total"]), "kinetic": float(x["kinetic"]), "residual": float(x["residual"])})
                dev = np.abs(e - e[0])
                summary.append({"scene": scene, "scheme": scheme, "h": h, "steps_asked": steps, "steps_done": len(rows) - 1,
                                "status": "ok" if rc == 0 else err.replace(",", ";"),
                                "E0": e[0], "max_abs_dE": dev.max(), "final_dE": e[-1] - e[0], "max_kinetic": k.max(),
                                "relative_drift": dev.max() / k.max(), "mean_newton_its": nl.mean() if len(nl) else 0,
                                "cpu_user_s": round(user, 2), "command": " ".join(os.path.relpath(c) if c == MSIM else c for c in cmd)})
                print(f"{scene:5s} {scheme:18s} steps {len(rows) - 1:5d}/{steps} max|dE| {dev.max():.3e} J  rel {dev.max() / k.max():.2e}  "
                      f"Newton {summary[-1]['mean_newton_its']:.1f}/step  user {user:.1f} s  {err}", flush=True)
    mr.write_csv(os.path.join(HERE, "energy.csv"), energy)
    mr.write_csv(os.path.join(HERE, "summary.csv"), summary)
    plot(energy)


def plot(energy):
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8))
    for ax, scene in zip(axes, SCENES):
        h = SCENES[scene][1]
        for scheme in SCHEMES:
            rows = [r for r in energy if r["scene"] == scene and r["scheme"] == scheme]
            t = np.array([r["t"] for r in rows])
            e = np.array([r["total"] for r in rows])
            ax.plot(t, e - e[0], label=scheme, lw=1.6 if scheme == "discrete_gradient" else 1.0)
        ax.set_yscale("symlog", linthresh=1e-12)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("E(t) - E(0) (J)")
        title = (f"undamped chain, h = {h:.4f} s = 10 x 2/omega_max" if scene == "chain" else "undamped 11 x 11 cloth, k = 1000 N/m, h = 1/30 s")
        ax.set_title(title, fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "energy.png"), dpi=110)


if __name__ == "__main__":
    main()
