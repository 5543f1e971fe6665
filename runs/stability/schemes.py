#!/usr/bin/env python3
"""Stability of the second-order schemes (issue 33): where each fails or damps, against SLEPc's
spectrum.

long: a cloth (default 31 x 31, two corners held, gravity, k = 1000 N/m, 1 kg) at h = 1/30 s for
  150 steps (5 s), every scheme with Newton to convergence (exact Hessian, MUMPS LDL^T) and with
  PD-10, and PETSc TS alpha2 (radius 1 and 0.5): total energy per step, the step where msim's
  divergence check (every step) or the solver stopped it. omega_max from -msim_spectrum at the
  initial state, so h omega_max says how far the step is from resolving the stiffest mode.
sweep: the stability study's undamped fixed-fixed chain (22 vertices, no gravity, 1 mm
  pseudo-random start; its motion stays nearly linear) and a hanging 12 x 12 cloth, h = r x
  2/omega_max for r = 0.5 ... 1000, 2 s each, every scheme under Newton: finished or not, and
  E(T)/E(0) (the chain; a linear oscillator's energy is conserved by midpoint and Newmark and
  damped by BDF2 and implicit Euler in the modes with h omega >> 1) or E(T) - E(0) (the cloth).
Writes schemes_long.csv, schemes_sweep.csv, schemes_long.png, schemes_sweep.png, and
schemes_theory.csv: each scheme's amplification per step on a linear oscillator at h omega = 0.1,
1, 10 and the long run's h omega_max (how fast it damps a mode the step does not resolve).
Usage: /usr/bin/python3 runs/stability/schemes.py [long|sweep|plot|all] [--msim PATH] [--cloth-n 31]
  [--steps 150] [--ratios 0.5,1,3,10,30,100,1000] [--schemes implicit_euler,bdf2,...,ts] (the rows of
  the schemes run replace theirs in the CSVs; the others stay)"""
import csv
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, ROOT, study_parser, write_csv  # noqa: E402
from plots import SCHEME_COLORS as COLORS, energy_drift, pyplot, save, style  # noqa: E402

TMP = "/tmp/msim_stability_schemes"
H30 = 1 / 30
NEWTON = ("-snes_type newtonls -msim_psd 0 -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps "
          "-msim_check_saddle 0 -snes_rtol 1e-9 -snes_atol 1e-12 -snes_stol 0 -snes_max_it 100")
PD10 = "-snes_type pd -snes_pd_fixed -snes_max_it 10"
# discrete_gradient: nonsymmetric Jacobian, no objective (PD, L-BFGS refused): Newton with MUMPS LU
DG_NEWTON = "-snes_type newtonls -ksp_type preonly -pc_type lu -pc_factor_mat_solver_type mumps -snes_rtol 1e-9 -snes_atol 1e-12 -snes_stol 0 -snes_max_it 100"
WANT = set()  # --schemes
SCHEMES = ["implicit_euler", "bdf2", "implicit_midpoint", "newmark", "discrete_gradient"]
TS = {"ts alpha2 r=1": "-msim_integrator ts -ts_type alpha2 -ts_alpha_radius 1 -ts_adapt_type none",
      "ts alpha2 r=0.5": "-msim_integrator ts -ts_type alpha2 -ts_alpha_radius 0.5 -ts_adapt_type none"}
SWEEP_SCENES = {
    "chain": "-msim_scene chain -msim_chain_n 22 -msim_fix corners -msim_gravity 0,0,0 -msim_perturb 1e-3 -msim_stiffness 1000 -msim_mass 0.22",
    "cloth12": "-msim_cloth_n 12 -msim_fix corners -msim_perturb 1e-3 -msim_stiffness 1000 -msim_mass 0.144",
}


def msim(exe, args, tag):
    mon = os.path.join(TMP, f"{tag}.csv")
    if os.path.exists(mon):
        os.remove(mon)
    r = subprocess.run([exe] + args.split() + ["-msim_spectrum_check", "0", "-msim_divergence_check_every", "1", "-msim_monitor_csv", mon],
                       capture_output=True, text=True, env=ENV, cwd=ROOT)
    rows = list(csv.DictReader(open(mon))) if os.path.exists(mon) else []
    why = ""
    if r.returncode:
        m = re.search(r"(diverged at step \d+|nonlinear solver failed at step \d+[^\n]*)", r.stderr)
        why = m.group(1)[:120] if m else (r.stderr.strip().splitlines() or ["failed"])[-1][:120]
    return rows, why


def omega_max(exe, base):
    r = subprocess.run([exe] + base.split() + ["-msim_spectrum"], capture_output=True, text=True, env=ENV, cwd=ROOT)
    return float(re.search(r"omega_max = (\S+)", r.stdout).group(1))


def has(exe, name):
    r = subprocess.run([exe, "-help"], capture_output=True, text=True, env=ENV, cwd=ROOT)
    line = next((l for l in r.stdout.splitlines() if "-msim_integrator" in l), "")
    return re.search(rf"\b{name}\b", line) is not None


def runs_for(exe, solvers):
    out = []
    for s in SCHEMES:
        if s not in WANT or (s == "discrete_gradient" and not has(exe, s)):
            continue
        for solver, opts in solvers:
            if s == "discrete_gradient":
                if solver != "Newton":
                    continue
                opts = DG_NEWTON
            out.append((s, solver, f"-msim_integrator {s} {opts}"))
    return out + [(name, "Newton (TS)", opts) for name, opts in TS.items() if "ts" in WANT]


def long_runs(a, exe):
    base = f"-msim_cloth_n {a.cloth_n}"
    om = omega_max(exe, base)
    rows = []
    for scheme, solver, opts in runs_for(exe, [("Newton", NEWTON), ("PD-10", PD10)]):
        mon, why = msim(exe, f"{base} -msim_dt {H30:.16g} -msim_steps {a.steps} {opts}", "long")
        last = int(mon[-1]["step"]) if mon else 0
        print(f"cloth {a.cloth_n}: {scheme} {solver}: {last} of {a.steps} steps {why}; E {mon[0]['total'] if mon else '-'} -> {mon[-1]['total'] if mon else '-'}", flush=True)
        for m in mon:
            rows.append(dict(scene=f"cloth {a.cloth_n} x {a.cloth_n}", omega_max=f"{om:.6g}", h=f"{H30:.6g}", h_omega_max=f"{H30 * om:.4g}",
                             scheme=scheme, solver=solver, step=m["step"], t=m["t"], total=m["total"], kinetic=m["kinetic"],
                             nonlinear_its=m["nonlinear_its"], stopped=why))
    write(os.path.join(HERE, "schemes_long.csv"), rows)


def sweep(a, exe):
    rows = []
    for sname, base in SWEEP_SCENES.items():
        om = omega_max(exe, base)
        for ratio in [float(r) for r in a.ratios.split(",")]:
            h = ratio * 2 / om
            steps = max(1, round(2.0 / h))
            for scheme, solver, opts in runs_for(exe, [("Newton", NEWTON)]):
                mon, why = msim(exe, f"{base} -msim_dt {h:.10g} -msim_steps {steps} {opts}", "sweep")
                e0 = float(mon[0]["total"]) if mon else float("nan")
                e1 = float(mon[-1]["total"]) if mon else float("nan")
                emax = max((abs(float(m["total"]) - e0) for m in mon), default=float("nan"))
                rows.append(dict(scene=sname, omega_max=f"{om:.6g}", ratio_to_symplectic_limit=ratio, h=f"{h:.6g}", h_omega_max=f"{h * om:.4g}",
                                 steps=steps, scheme=scheme, solver=solver, steps_done=int(mon[-1]["step"]) if mon else 0, stopped=why,
                                 E0=f"{e0:.6e}", ET=f"{e1:.6e}", energy_ratio=f"{e1 / e0:.6e}" if e0 else "", max_energy_change=f"{emax:.4e}"))
                print(rows[-1], flush=True)
    write(os.path.join(HERE, "schemes_sweep.csv"), rows)


def amplification(scheme, hw, radius=1.0):
    """spectral radius per step of each scheme on an undamped linear oscillator x'' = -w^2 x at h w:
    how fast a mode the step does not resolve dies (1: kept; energy goes as its square)"""
    import numpy as np
    if scheme == "implicit_euler":
        return 1 / np.sqrt(1 + hw * hw)
    if scheme == "bdf2":  # (3 y1 - 4 y0 + y_-1) / (2h) = lambda y1, lambda = i w
        return max(abs(z) for z in np.roots([3 - 2j * hw, -4, 1]))
    if scheme.startswith("ts alpha2"):  # Chung-Hulbert generalized-alpha, rho_inf = radius
        r = radius
        am, af = (2 * r - 1) / (r + 1), r / (r + 1)
        g, b = 0.5 - am + af, 0.25 * (1 - am + af) ** 2
        # amplification matrix on (x, h v, h^2 a) from (1-am) a1 + am a0 = -w^2 ((1-af) x1 + af x0)
        # and Newmark's x1 = x0 + h v0 + h^2 ((1/2 - b) a0 + b a1), h v1 = h v0 + h^2 ((1 - g) a0 + g a1)
        w2 = hw * hw
        A = np.array([[1, 0, 0], [0, 1, 0], [w2 * (1 - af), 0, 1 - am]], dtype=float)
        B = np.array([[1, 1, 0.5 - b], [0, 1, 1 - g], [-w2 * af, 0, -am]], dtype=float)
        A[0, 2], A[1, 2] = -b, -g
        return max(abs(np.linalg.eigvals(np.linalg.solve(A, B))))
    return 1.0  # implicit_midpoint, newmark (average acceleration), discrete_gradient: energy kept


def write(path, rows):
    """rows replace those of the schemes run (--schemes); the others' rows stay"""
    if os.path.exists(path) and "scheme" in rows[0]:
        rows = [r for r in csv.DictReader(open(path)) if r["scheme"].split()[0] not in WANT] + rows
    write_csv(path, rows)


def plot():
    plt = pyplot()
    path = os.path.join(HERE, "schemes_long.csv")
    if os.path.exists(path):
        rows = list(csv.DictReader(open(path)))
        # what linear theory says of the stiffest mode at this h (SLEPc's omega_max)
        hw = float(rows[0]["h_omega_max"])
        theory = []
        for scheme in dict.fromkeys(r["scheme"] for r in rows):
            for x in (0.1, 1.0, 10.0, hw):
                z = amplification(scheme, x, 0.5 if "0.5" in scheme else 1.0)
                theory.append(dict(scheme=scheme, h_omega=f"{x:.4g}", amplification_per_step=f"{z:.4g}",
                                   energy_left_after_1_s_at_h_1_30=f"{z ** (2 * 30):.3g}"))
        write_csv(os.path.join(HERE, "schemes_theory.csv"), theory)
        fig, axes = plt.subplots(1, 2, figsize=(13, 4.5))
        for ax, kind in zip(axes, ("Newton", "PD-10")):
            for key in dict.fromkeys((r["scheme"], r["solver"]) for r in rows):
                if (kind == "Newton") != key[1].startswith("Newton"):
                    continue
                rs = [r for r in rows if (r["scheme"], r["solver"]) == key]
                stop = f" ({rs[-1]['stopped'][:40]})" if rs[-1]["stopped"] else ""
                energy_drift(ax, rs, color=COLORS.get(key[0], "gray"), label=f"{key[0]}{stop}")
                if stop:
                    ax.plot([float(rs[-1]["t"])], [float(rs[-1]["total"]) - float(rs[0]["total"])], "x", color=COLORS.get(key[0], "gray"), ms=9)
            ax.set_yscale("symlog", linthresh=1e-2)
            style(ax, "t (s)", "E(t) - E(0) (J)", f"{rows[0]['scene']}, h = 1/30 s (h omega_max = {rows[0]['h_omega_max']}): {kind}", 9, legend=dict(fontsize=7))
        save(fig, os.path.join(HERE, "schemes_long.png"))
    path = os.path.join(HERE, "schemes_sweep.csv")
    if os.path.exists(path):
        rows = list(csv.DictReader(open(path)))
        scenes = list(dict.fromkeys(r["scene"] for r in rows))
        fig, axes = plt.subplots(1, len(scenes), figsize=(6.5 * len(scenes), 4.5), squeeze=False)
        for ax, sname in zip(axes[0], scenes):
            for scheme in dict.fromkeys(r["scheme"] for r in rows):
                rs = [r for r in rows if r["scene"] == sname and r["scheme"] == scheme]
                x = [float(r["h_omega_max"]) for r in rs]
                if sname == "chain":
                    y = [float(r["energy_ratio"]) if not r["stopped"] else float("nan") for r in rs]
                else:
                    y = [abs(float(r["ET"]) - float(r["E0"])) if not r["stopped"] else float("nan") for r in rs]
                ax.plot(x, y, marker="o", color=COLORS.get(scheme, "gray"), label=scheme)
                bad = [(xx, r) for xx, r in zip(x, rs) if r["stopped"]]
                for xx, r in bad:
                    ax.plot([xx], [1.0 if sname == "chain" else 1e-6], "x", color=COLORS.get(scheme, "gray"), ms=10)
            style(ax, "h omega_max (2 = symplectic Euler's limit); x: run stopped", "E(2 s) / E(0)" if sname == "chain" else "|E(2 s) - E(0)| (J)",
                  f"{sname}: Newton to convergence, 2 s", 9, xlog=True, ylog=True, legend=dict(fontsize=7))
        save(fig, os.path.join(HERE, "schemes_sweep.png"))


def main():
    p = study_parser(("long", "sweep", "plot", "all"))
    p.add_argument("--cloth-n", type=int, default=31)
    p.add_argument("--steps", type=int, default=150)
    p.add_argument("--ratios", default="0.5,1,3,10,30,100,1000")
    p.add_argument("--schemes", default=",".join(SCHEMES + ["ts"]), help="which schemes to run (ts: PETSc's alpha2)")
    a = p.parse_args()
    WANT.update(a.schemes.split(","))
    os.makedirs(TMP, exist_ok=True)
    exe = os.path.abspath(a.msim)
    if a.part in ("long", "all"):
        long_runs(a, exe)
    if a.part in ("sweep", "all"):
        sweep(a, exe)
    plot()


if __name__ == "__main__":
    main()
