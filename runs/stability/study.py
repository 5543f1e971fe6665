#!/usr/bin/env python3
"""Stability study: where each integrator fails, and whether SLEPc predicted it.
For a fixed-fixed chain, a hanging cloth and a tet solid (the bunny held by its ears), msim
-msim_spectrum gives omega_max at the initial
state; the predicted limits are symplectic Euler h < 2/omega, RK4 h <= 2 sqrt(2)/omega, explicit
Euler (with air drag, rate gamma = c/m) h <= gamma/omega^2. Each method is run across h around its
limit (and the implicit ones far beyond) with msim's divergence detection; a stiffness sweep checks
h ~ 1/sqrt(k), and implicit Euler's numerical energy loss is measured against h.
Writes runs/stability/{runs.csv, stiffness.csv, energy_loss.csv, thresholds.png, energy.png,
stiffness.png}. Usage: /usr/bin/python3 runs/stability/study.py"""
import csv
import math
import os
import re
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT  # noqa: E402
TMP = "/tmp/msim_stability"
os.makedirs(TMP, exist_ok=True)

SCENES = {
    "chain": "-msim_scene chain -msim_chain_n 22 -msim_fix corners -msim_gravity 0,0,0 -msim_perturb 1e-3 -msim_stiffness 1000 -msim_mass 0.22",
    "cloth": "-msim_cloth_n 12 -msim_fix corners -msim_perturb 1e-3 -msim_stiffness 1000 -msim_mass 0.144",
    # examples/bunny.opts without gravity: TetGen's tets of the bunny surface, springs from E = 20 kPa,
    # masses by volume (1100 kg/m^3), the ears held, 1 um pseudo-random initial displacement (its
    # shortest spring is 1.8 mm: the motion stays linear, as the chain's and cloth's do)
    "bunny": "-msim_scene tet -msim_mesh_file examples/meshes/bunny.off -msim_mesh_scale 0.01 -msim_fix_box -1,1,0.09,1,-1,1 "
             "-msim_gravity 0,0,0 -msim_density 1100 -msim_young 2e4 -msim_perturb 1e-6",
}
# simulated time per run: the bunny's highest modes are 10x faster than the chain's, and an unstable
# one outgrows the divergence threshold within tens of steps; 0.2 s is 570 steps at its limit
T_SCENE = {"chain": 2.0, "cloth": 2.0, "bunny": 0.2}
# explicit Euler needs drag to have a stable step, and its predicted limit gamma / omega_max^2
# takes one drag rate c / m: on the bunny the masses, lumped by volume, differ from vertex to vertex,
# so that prediction does not apply there
SKIP = {("bunny", "explicit_euler")}
GAMMA = 500.0  # 1/s: drag rate c/m of the explicit Euler runs. Above the limit a mode grows at
               # about (h/h_pred - 1) gamma/2 per second, so a large gamma makes a 2% excess visible
               # within T_END (the highest mode stays underdamped: gamma < 2 omega_max).
T_END = 2.0  # s simulated per run


def msim(args, csv_path=None):
    cmd = [MSIM] + args.split() + ["-msim_spectrum_check", "0", "-msim_divergence_check_every", "1"]
    if csv_path:
        cmd += ["-msim_monitor_csv", csv_path]
    r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
    return r


def omega_max(scene):
    r = msim(scene + " -msim_spectrum")
    return float(re.search(r"omega_max = (\S+)", r.stdout).group(1))


def energy(csv_path):
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    return [float(x["t"]) for x in rows], [float(x["total"]) for x in rows]


def run(scene, method, h, steps, tag):
    csv_path = os.path.join(TMP, f"{tag}.csv")
    if os.path.exists(csv_path):
        os.remove(csv_path)
    r = msim(f"{scene} {method} -msim_dt {h:.10g} -msim_steps {steps}", csv_path)
    diverged = r.returncode != 0 and "diverged at step" in r.stderr
    if r.returncode != 0 and "the nonlinear solver failed at step" in r.stderr:
        diverged = "solver failed"
    elif r.returncode != 0 and not diverged:
        sys.exit(f"msim failed: {r.stderr}")
    t, e = energy(csv_path) if os.path.exists(csv_path) else ([0], [0])
    return diverged, t, e


METHODS = {
    "explicit_euler": ("-msim_integrator explicit_euler -msim_drag {drag}", "drag"),
    "symplectic_euler": ("-msim_integrator symplectic_euler", 2.0),
    "rk4": ("-msim_integrator rk4", 2.0 * math.sqrt(2.0)),
    "implicit_newton": ("-msim_integrator implicit_euler -snes_type newtonls -ksp_type preonly -pc_type cholesky -snes_rtol 1e-8", None),
    "implicit_pd": ("-msim_integrator implicit_euler -snes_type pd -snes_max_it 20 -snes_pd_fixed", None),
}


def predicted(scene_name, method, w, nv):
    opt, lim = METHODS[method]
    if lim == "drag":
        return GAMMA / w**2
    return lim / w if lim else None


def threshold_sweep():
    rows, curves = [], {}
    fractions = [0.5, 0.8, 0.9, 0.95, 0.98, 1.02, 1.05, 1.1, 1.25, 1.5, 2.0]
    for sname, scene in SCENES.items():
        nv = {"chain": 22, "cloth": 144}.get(sname)
        w = omega_max(scene)
        h_symp = 2.0 / w
        print(f"{sname}: omega_max = {w:.6g} rad/s")
        mass = float(re.search(r"-msim_mass (\S+)", scene).group(1)) / nv if nv else None
        for method, (opt, lim) in METHODS.items():
            if (sname, method) in SKIP:
                continue
            opt = opt.format(drag=GAMMA * mass if mass else 0)
            hp = predicted(sname, method, w, nv)
            if hp is None:  # implicit: from the symplectic limit to 1000 times it (the bunny's Newton from 10 x)
                hs = [h_symp * f for f in ((0.5, 1, 2, 5, 10, 30, 100, 300, 1000) if sname != "bunny" else (10, 30, 100, 300, 1000))]
            else:
                hs = [hp * f for f in fractions]
            for h in hs:
                steps = max(20, min(20000, int(round(T_SCENE[sname] / h))))
                div, t, e = run(f"{scene}", opt, h, steps, f"{sname}_{method}_{h:.4g}")
                scale = max(abs(v) for v in e) if e else 1.0
                drift = (e[-1] - e[0]) / max(1e-300, abs(e[0]) if e[0] else scale)
                rows.append(dict(scene=sname, method=method, omega_max=w, h=h, h_predicted=hp if hp else "", h_over_predicted=h / hp if hp else "",
                                 h_over_symplectic_limit=h / h_symp, steps=steps, diverged=int(div is True), solver_failed=int(div == "solver failed"),
                                 energy_drift=drift if not div else ""))
                if hp and abs(h / hp - 0.98) < 1e-9 or hp and abs(h / hp - 1.02) < 1e-9:
                    curves[(sname, method, round(h / hp, 2))] = (t, e)
                print(f"  {method:17s} h = {h:.4e} ({'h/pred = %.2f' % (h / hp) if hp else 'h/h_symp = %.0f' % (h / h_symp)}): {'SOLVER FAILED' if div == 'solver failed' else 'DIVERGED' if div else 'stable'}", flush=True)
    return rows, curves


def observed_threshold(rows, scene, method):
    sel = sorted((r for r in rows if r["scene"] == scene and r["method"] == method), key=lambda r: r["h"])
    stable = [r["h"] for r in sel if not r["diverged"] and not r["solver_failed"]]
    first_bad = next((r["h"] for r in sel if r["diverged"]), None)
    last_good = max((h for h in stable if first_bad is None or h < first_bad), default=None)
    return last_good, first_bad


def bisect_limit(scene, opt, lo, hi, iters=7, t_end=T_END):
    """Largest stable h in [lo, hi] (lo stable, hi diverged), by bisection on log h."""
    for _ in range(iters):
        mid = math.sqrt(lo * hi)
        div, _, _ = run(scene, opt, mid, max(20, min(40000, int(round(t_end / mid)))), "bisect")
        lo, hi = (lo, mid) if div else (mid, hi)
    return math.sqrt(lo * hi)


def stiffness_sweep():
    rows = []
    base = "-msim_scene chain -msim_chain_n 22 -msim_fix corners -msim_gravity 0,0,0 -msim_perturb 1e-3 -msim_mass 0.22"
    for k in (10, 100, 1000, 10000, 100000):
        scene = f"{base} -msim_stiffness {k}"
        w = omega_max(scene)
        for method in ("symplectic_euler", "rk4"):
            opt, lim = METHODS[method]
            hp = lim / w
            h_obs = bisect_limit(scene, opt, 0.8 * hp, 1.25 * hp)
            rows.append(dict(k=k, method=method, omega_max=w, h_predicted=hp, h_observed=h_obs, ratio=h_obs / hp))
            print(f"k = {k:g}: {method} predicted {hp:.4e}, observed {h_obs:.4e} (ratio {h_obs / hp:.3f})")
        # implicit Euler at a step 100 times the symplectic limit: stable whatever k
        h = 100 * 2.0 / w
        for method in ("implicit_newton", "implicit_pd"):
            div, t, e = run(scene, METHODS[method][0], h, 50, f"stiff_{method}_{k}")
            rows.append(dict(k=k, method=f"{method} (h = 100 x symplectic limit)", omega_max=w, h_predicted="", h_observed="stable" if not div else str(div), ratio=""))
            print(f"k = {k:g}: {method} at h = {h:.3e} (100 x the symplectic limit): {'stable' if not div else div}")
    return rows


def solid_limits():
    """The bunny's largest stable step for symplectic Euler and RK4, by bisection, against SLEPc's
    prediction at its initial state, for a small initial displacement (1 um, linear) and a large one
    (0.1 mm, 5% of its shortest spring); and the guard's Gershgorin bound beside them."""
    rows = []
    for amp in (1e-6, 1e-4):
        scene = SCENES["bunny"].replace("-msim_perturb 1e-6", f"-msim_perturb {amp:g}")
        w = omega_max(scene)
        r = subprocess.run([MSIM] + scene.split() + ["-msim_integrator", "symplectic_euler", "-msim_dt", "1", "-msim_steps", "1"], capture_output=True, text=True, env=ENV, cwd=ROOT)
        g = re.search(r"omega_max <= (\S+) from the Gershgorin", r.stderr)
        for method in ("symplectic_euler", "rk4"):
            opt, lim = METHODS[method]
            hp = lim / w
            h_obs = bisect_limit(scene, opt, 0.7 * hp, 1.25 * hp, iters=8, t_end=T_SCENE["bunny"])
            rows.append(dict(scene="bunny", perturb=amp, method=method, omega_max=w, omega_gershgorin=float(g.group(1)) if g else "", h_predicted=hp, h_observed=h_obs, ratio=h_obs / hp))
            print(f"bunny, perturbation {amp:g} m: {method} predicted {hp:.5e}, observed {h_obs:.5e} (ratio {h_obs / hp:.4f}); Gershgorin bound {g.group(1) if g else '?'} rad/s")
    return rows


def energy_loss():
    """Implicit Euler damps: two masses on a spring (omega = sqrt(k/mu), motion stays on the axis, so
    the oscillator is exactly linear) lose energy by the factor 1/(1 + h^2 omega^2) per step, i.e.
    E(T)/E(0) = (1 + h^2 omega^2)^(-T/h). Measured for Newton and PD against that formula."""
    rows = []
    k, mass = 100.0, 2.0
    omega = math.sqrt(k / (mass / 4))  # reduced mass of two equal halves: mu = m/4 for total m
    scene = f"-msim_scene chain -msim_chain_n 2 -msim_fix none -msim_gravity 0,0,0 -msim_prestretch 1.1 -msim_stiffness {k} -msim_mass {mass}"
    for method in ("implicit_newton", "implicit_pd"):
        opt = METHODS[method][0] + (" -snes_pd_fixed 0 -snes_max_it 100000 -snes_rtol 1e-12" if method == "implicit_pd" else "")
        for h in (1e-4, 3e-4, 1e-3, 3e-3, 1e-2, 3e-2, 1e-1):
            steps = int(round(T_END / h))
            div, t, e = run(scene, opt, h, steps, f"loss_{method}_{h:g}")
            theory = (1 + h * h * omega * omega) ** (-steps)
            rows.append(dict(method=method, h=h, omega=omega, energy_ratio=e[-1] / e[0], theory=theory, diverged=int(bool(div))))
            print(f"{method} h = {h:g}: E({T_END:g} s)/E(0) = {e[-1] / e[0]:.6e}, (1 + h^2 w^2)^-n = {theory:.6e}")
    return rows


def write(name, rows):
    with open(os.path.join(HERE, name), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


def charts(rows, curves, stiff, loss):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    methods = list(METHODS)
    fig, axes = plt.subplots(1, len(SCENES), figsize=(17, 4.2), sharey=True)
    for ax, sname in zip(axes, SCENES):
        for i, method in enumerate(methods):
            sel = [r for r in rows if r["scene"] == sname and r["method"] == method]
            if not sel:
                continue
            x = [r["h_over_symplectic_limit"] for r in sel]
            ok = [not r["diverged"] and not r["solver_failed"] for r in sel]
            ax.scatter([v for v, o in zip(x, ok) if o], [i] * sum(ok), marker="o", color="#2ca02c", s=28, label="stable" if i == 0 else None)
            ax.scatter([v for v, r in zip(x, sel) if r["diverged"]], [i] * sum(1 for r in sel if r["diverged"]), marker="x", color="#d62728", s=40, label="diverged" if i == 0 else None)
            ax.scatter([v for v, r in zip(x, sel) if r["solver_failed"]], [i] * sum(1 for r in sel if r["solver_failed"]), marker="^", color="#7f7f7f", s=36, label="Newton line search failed" if method == "implicit_newton" else None)
            hp = sel[0]["h_predicted"]
            if hp != "":
                ax.plot([hp / (2.0 / sel[0]["omega_max"])] * 2, [i - 0.35, i + 0.35], color="k", lw=2, label="SLEPc prediction" if i == 1 else None)
        ax.set_xscale("log")
        ax.set_yticks(range(len(methods)))
        ax.set_yticklabels(methods)
        ax.set_xlabel("h / (2 / omega_max)")
        ax.set_title(f"{sname}: omega_max = {rows[[r['scene'] for r in rows].index(sname)]['omega_max']:.4g} rad/s")
        ax.grid(True, which="both", axis="x", alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "thresholds.png"), dpi=110)

    fig, axes = plt.subplots(1, 3, figsize=(14, 3.8))
    for ax, method in zip(axes, ("explicit_euler", "symplectic_euler", "rk4")):
        for frac, style in ((0.98, "-"), (1.02, "--")):
            if ("chain", method, frac) in curves:
                t, e = curves[("chain", method, frac)]
                ax.plot(t, e, style, label=f"h = {frac} x predicted limit")
        ax.set_yscale("symlog", linthresh=1e-6)
        ax.set_xlabel("t (s)")
        ax.set_ylabel("total energy (J)")
        ax.set_title(f"chain, {method}")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "energy.png"), dpi=110)

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    ax = axes[0]
    for method, mk in (("symplectic_euler", "o"), ("rk4", "s")):
        sel = [r for r in stiff if r["method"] == method]
        ks = [r["k"] for r in sel]
        ax.plot(ks, [r["h_observed"] for r in sel], mk, label=f"{method} observed")
        ax.plot(ks, [r["h_predicted"] for r in sel], "-", label=f"{method} predicted (SLEPc)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("k (N/m)")
    ax.set_ylabel("largest stable h (s)")
    ax.set_title("Stiffness sweep (chain): h ~ 1/sqrt(k)")
    ax.legend(fontsize=8)
    ax = axes[1]
    for method, mk in (("implicit_newton", "o"), ("implicit_pd", "x")):
        sel = [r for r in loss if r["method"] == method]
        ax.plot([r["h"] for r in sel], [r["energy_ratio"] for r in sel], mk, label=f"{method} (measured)")
    sel = [r for r in loss if r["method"] == "implicit_newton"]
    ax.plot([r["h"] for r in sel], [r["theory"] for r in sel], "k-", lw=0.8, label="(1 + h^2 omega^2)^(-T/h)")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("h (s)")
    ax.set_ylabel(f"E({T_END:g} s) / E(0)")
    ax.set_title("Implicit Euler is stable but damps (two-mass oscillator)")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "stiffness.png"), dpi=110)


def main():
    rows, curves = threshold_sweep()
    write("runs.csv", rows)
    write("solid.csv", solid_limits())
    stiff = stiffness_sweep()
    write("stiffness.csv", stiff)
    loss = energy_loss()
    write("energy_loss.csv", loss)
    charts(rows, curves, stiff, loss)
    print("\nobserved thresholds (largest stable h in the sweep, first diverged h):")
    for sname in SCENES:
        for method in METHODS:
            if (sname, method) in SKIP:
                continue
            lo, hi = observed_threshold(rows, sname, method)
            hp = next(r["h_predicted"] for r in rows if r["scene"] == sname and r["method"] == method)
            print(f"  {sname:6s} {method:17s} predicted {hp if hp == '' else '%.4e' % hp:>11s}  stable up to {lo if lo is None else '%.4e' % lo}  diverged from {hi if hi is None else '%.4e' % hi}")


if __name__ == "__main__":
    main()
