#!/usr/bin/env python3
"""The second-order implicit schemes (bdf2, implicit_midpoint, newmark), at 1 and 2 ranks:
- observed order 2 (within 0.15) against RK4 at h = 1e-5 (computed at 1 rank for every rank count:
  it stands for the exact solution; at 2 ranks its 30000 steps of these small scenes were mostly
  messages), Newton solved to roundoff (MUMPS; for
  discrete_gradient, whose residual has no objective, GMRES to 1e-12), of these three and of the
  energy-conserving discrete_gradient, on the
  chain of tests/order.py (8 vertices, corners fixed, gravity, T = 0.3 s, h = 2e-3, 1e-3, 5e-4) and
  on a 6 x 6 cloth with spring damping, drag, wind and handles moving at (0.5, 0, 1) m/s, where
  every term of the schemes' y and dissipation counts (same h: there the errors halve and quarter
  as the asymptotic range has them, 1e-4 to 1e-5 m);
- the same 20 steps of the damped cloth solved by Newton, by PD to convergence and by L-BFGS with the
  PD factor end within 1e-7 m of each other (each solved to |g| < 1e-12 kg m, about |g| / m = 1e-10 m
  per step for these 28 g vertices: the bound leaves a factor 50 for 20 steps' growth);
- BDF2 and Newmark (and midpoint and discrete_gradient) restarted from a checkpoint at step 10 end bit for bit where 20
  uninterrupted steps do, and the checkpoint carries the scheme's history (2 vectors for BDF2, 1 for
  Newmark: its size grows by that many vectors of 3 n doubles over implicit Euler's); restarted
  from a checkpoint that holds no history they can take (written with another
  -msim_implicit_guess, or by implicit_euler) they start as at step 1 and say so in one warning;
- BDF2's start-up step is stable far beyond the explicit limit: the undamped chain with its vertices
  displaced by up to 1 cm (every mode excited) at h = 0.1 s (h omega_max = 17) ends step 1 with at
  most 25/16 of its energy (the square of the start-up's amplification bound 5/4 on a linear mode,
  src/implicit/schemes/bdf2.cpp) and runs 3 steps (the Taylor start-up it replaced gained about
  (h omega / 4)^2 and was stopped as diverged at step 1);
- BDF2 is exact under a constant acceleration, its start-up too: a 5 x 5 cloth falling free
  (nothing fixed, its springs at rest) at h = 0.01 s ends 100 steps at z = -g t^2/2 and v = -g t
  to 1e-10 (roundoff), its monitored total energy within 1e-9 J of 0 (the start-up was h^2/18 g
  short, a lag BDF2 carried to h^2 g/12 = 8.2e-5 m for good, the total energy up to
  M g^2 h^2/12 = 8.0e-4 J);
- implicit midpoint at a large step (21 x 21 cloth, h = 1/30 s, 12 steps) is PETSc's own implicit
  midpoint rule (TS theta 0.5 without endpoint): an independent implementation of the scheme where
  the springs are far from linear, the two within 1e-8 m (each solved to |g| < 1e-13);
- implicit midpoint on the undamped chain keeps its energy over 2000 steps of 5 ms: |E - E0| below
  0.5% of the largest kinetic energy, and no larger in the second half than 1.5 x the first half's,
  where implicit Euler loses more than half of it within 200 steps;
- -msim_step_atol with -snes_type pd (plain, Anderson, fixed count) or ksponly, which never test
  their step length, or ngmres, which hands the test a step length of 0, is refused in one line naming the option (it changed nothing there, and the
  unconverged-steps warning named the rule as if it had run)."""
import math
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
CHAIN = ["-msim_scene", "chain", "-msim_chain_n", "8", "-msim_fix", "corners", "-msim_spectrum_check", "0"]
CLOTH = ["-msim_cloth_n", "6", "-msim_damping", "2", "-msim_drag", "0.05", "-msim_wind", "1,0,0", "-msim_fix_velocity", "0.5,0,1", "-msim_spectrum_check", "0"]
T = 0.3
HS = (2e-3, 1e-3, 5e-4)
EXACT = ["-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps", "-snes_rtol", "1e-14", "-snes_atol", "1e-15"]
SCHEMES = ("bdf2", "implicit_midpoint", "newmark")
# the order check also covers the energy-conserving scheme (tests/energy_conserving.py checks its
# energy): its residual has no objective, so Newton with GMRES and ILU or block Jacobi-ILU (named:
# msim's default for the scheme is MUMPS LU) and the l2 line search to tight tolerances, at 2 ranks
# 4 x faster than MUMPS LU on these small scenes
ORDER_RUNS = {s: EXACT for s in SCHEMES}
ORDER_RUNS["discrete_gradient"] = ["-ksp_type", "gmres", "-ksp_rtol", "1e-12", "-snes_rtol", "1e-14", "-snes_atol", "1e-15"]
TIGHT = ["-snes_rtol", "0", "-snes_atol", "1e-12", "-snes_stol", "0"]
SOLVERS = {"newton": ["-snes_type", "newtonls"] + EXACT[:6] + TIGHT,
           "pd": ["-snes_type", "pd", "-snes_max_it", "20000"] + TIGHT,
           "lbfgs": ["-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-snes_max_it", "2000"] + TIGHT}
check = mt.Checks()


def msim(np_, args, cwd=None):
    r = mt.run(MSIM, args, np_, cwd=cwd)
    if r.returncode:
        sys.exit(f"msim failed: {' '.join(args)}\n{r.stderr}")
    return r


def final(np_, scene, args, tmp, name):
    out = os.path.join(tmp, name + ".txt")
    msim(np_, scene + args + ["-msim_view_final", mt.view_ascii(out)])
    return np.array(mt.read_view(out))


def orders(np_, tmp):
    for label, scene in (("chain", CHAIN), ("damped cloth with moving handles", CLOTH)):
        ref = final(1, scene, ["-msim_integrator", "rk4", "-msim_dt", "1e-5", "-msim_steps", str(round(T / 1e-5))], tmp, "ref")
        for s, solver in ORDER_RUNS.items():
            err = [float(np.abs(final(np_, scene, ["-msim_integrator", s, "-msim_dt", repr(h), "-msim_steps", str(round(T / h))] + solver, tmp, f"{s}_{h}") - ref).max()) for h in HS]
            p = [math.log2(err[i] / err[i + 1]) for i in range(2)]
            check(all(abs(q - 2) < 0.15 for q in p),
                  f"np={np_}: {s} on the {label}: errors {', '.join(f'{e:.3e}' for e in err)} at h = {', '.join(f'{h:g}' for h in HS)}: observed order {p[0]:.3f}, {p[1]:.3f} (expected 2)")


def solvers(np_, tmp):
    base = CLOTH + ["-msim_dt", "0.01", "-msim_steps", "20"]
    for s in SCHEMES:
        x = {name: final(np_, base, ["-msim_integrator", s] + opts, tmp, f"{s}_{name}") for name, opts in SOLVERS.items()}
        diff = max(float(np.abs(x[a] - x["newton"]).max()) for a in ("pd", "lbfgs"))
        check(diff < 1e-7, f"np={np_}: {s}: Newton, PD and L-BFGS agree after 20 steps (largest difference {diff:.2e} m)")


def restarts(np_, tmp):
    base = CLOTH + ["-msim_dt", "0.01"]
    pd = ["-snes_type", "pd", "-snes_max_it", "5", "-snes_pd_fixed"]
    sizes = {}
    # discrete_gradient has no objective for PD: its own default solver (Newton, GMRES)
    for s in ("implicit_euler",) + SCHEMES + ("discrete_gradient",):
        args = base + (pd if s != "discrete_gradient" else []) + ["-msim_integrator", s]
        full, ck, part = (os.path.join(tmp, f"{s}_{k}") for k in ("full.bin", "ck", "part.bin"))
        msim(np_, args + ["-msim_steps", "20", "-msim_view_final", f"binary:{full}"])
        msim(np_, args + ["-msim_steps", "10", "-msim_checkpoint", ck])
        sizes[s] = os.path.getsize(ck)
        msim(np_, args + ["-msim_steps", "20", "-msim_restart", ck, "-msim_view_final", f"binary:{part}"])
        if s != "implicit_euler":
            check(open(full, "rb").read() == open(part, "rb").read(), f"np={np_}: {s}: restarted at step 10, step 20 is bit for bit the uninterrupted run's")
    # the checkpoint of another guess (extrapolate adds v_(n-1) to what it carries) or of another
    # integrator holds no history this run can take: the scheme starts as at step 1, and says so
    for s, writer, guess in (("bdf2", "bdf2", "extrapolate"), ("newmark", "newmark", "filtered"), ("bdf2", "implicit_euler", "constant_velocity")):
        r = mt.run(MSIM, base + pd + ["-msim_integrator", s, "-msim_implicit_guess", guess, "-msim_steps", "12", "-msim_restart", os.path.join(tmp, f"{writer}_ck")], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode == 0 and len(lines) == 1 and "starts as at step 1" in lines[0],
              f"np={np_}: {s} with -msim_implicit_guess {guess} restarted from {writer}'s constant_velocity checkpoint, which holds no history it can take: one warning ({lines[:2]})")
    nv = 36
    vec = 8 + 3 * nv * 8  # a PETSc binary Vec: class id, size, 3 nv doubles
    for s, n in (("bdf2", 2), ("newmark", 1), ("implicit_midpoint", 0), ("discrete_gradient", 0)):
        grown = sizes[s] - sizes["implicit_euler"]
        check(grown == (n * vec + len(s) if n else 0), f"np={np_}: {s}'s checkpoint carries {n} history vector(s): {grown} bytes more than implicit Euler's")


def bdf2_startup(np_, tmp):
    mon = os.path.join(tmp, "startup.csv")
    r = mt.run(MSIM, CHAIN + EXACT + ["-msim_perturb", "0.01", "-msim_gravity", "0,0,0", "-msim_integrator", "bdf2", "-msim_dt", "0.1", "-msim_steps", "3", "-msim_monitor_csv", mon], np_)
    e = [float(x["total"]) for x in mt.read_csv(mon)] if os.path.exists(mon) else []
    check(r.returncode == 0 and len(e) == 4 and e[1] <= 25 / 16 * e[0],
          f"np={np_}: bdf2's start-up at h omega_max = 17 on the perturbed undamped chain: E(step 1) / E0 = {e[1] / e[0] if len(e) > 1 else float('nan'):.3g} (at most 25/16), {len(e) - 1} of 3 steps (exit {r.returncode})")


def bdf2_free_fall(np_, tmp):
    mon, out = os.path.join(tmp, "free_fall.csv"), os.path.join(tmp, "free_fall.bin")
    r = mt.run(MSIM, ["-msim_cloth_n", "5", "-msim_fix", "none", "-msim_integrator", "bdf2", "-msim_dt", "0.01", "-msim_steps", "100",
                      "-msim_monitor_csv", mon, "-msim_view_final", f"binary:{out}"], np_)
    rows = mt.read_csv(mon) if r.returncode == 0 else []
    z = np.array(mt.read_binary_vec(out))[2::3] if r.returncode == 0 else np.array([np.nan])
    e = max((abs(float(x["total"])) for x in rows), default=np.nan)
    v = math.sqrt(2 * float(rows[-1]["kinetic"]) / 1.0) if rows else np.nan  # the cloth's mass: 1 kg
    check(len(rows) == 101 and abs(z + 9.81 / 2).max() < 1e-10 and abs(v - 9.81) < 1e-10 and e < 1e-9,
          f"np={np_}: bdf2, free fall for 1 s at h = 0.01: z + g t^2/2 = {abs(z + 9.81 / 2).max():.2e} m, |v| - g t = {v - 9.81:.2e} m/s, largest |total energy| {e:.2e} J")


def midpoint_vs_ts(np_, tmp):
    scene = ["-msim_cloth_n", "21", "-msim_dt", "0.0333333", "-msim_steps", "12", "-msim_spectrum_check", "0", "-snes_rtol", "1e-14", "-snes_atol", "1e-13"]
    ours = final(np_, scene, ["-msim_integrator", "implicit_midpoint", "-snes_max_it", "200"] + EXACT[:6], tmp, "midpoint_large")
    ts = final(np_, scene, ["-msim_integrator", "ts", "-ts_type", "theta", "-ts_theta_theta", "0.5", "-ts_theta_endpoint", "false", "-ts_adapt_type", "none"], tmp, "ts_midpoint")
    diff = float(np.abs(ours - ts).max())
    check(diff < 1e-8, f"np={np_}: implicit_midpoint at h = 1/30 on a 21 x 21 cloth is PETSc's TS theta 0.5 midpoint rule after 12 steps (largest difference {diff:.2e} m)")


def energy(np_, tmp):
    def run(s, steps):
        mon = os.path.join(tmp, f"energy_{s}.csv")
        msim(np_, CHAIN + EXACT + ["-msim_integrator", s, "-msim_dt", "5e-3", "-msim_steps", str(steps), "-msim_monitor_csv", mon])
        rows = mt.read_csv(mon)
        return np.array([float(r["total"]) for r in rows]), np.array([float(r["kinetic"]) for r in rows])
    e, k = run("implicit_midpoint", 2000)
    dev, half = np.abs(e - e[0]), len(e) // 2
    check(dev.max() < 5e-3 * k.max() and dev[half:].max() <= 1.5 * dev[:half].max(),
          f"np={np_}: implicit midpoint keeps the undamped chain's energy over 2000 steps: max |E - E0| {dev[:half].max():.3e} J in the first half, {dev[half:].max():.3e} J in the second, largest kinetic energy {k.max():.3f} J")
    # the contrast needs only the first 200 steps: implicit Euler has lost 0.80 of the largest
    # kinetic energy by then (0.52 at 100 steps, 1.21 at 2000), where midpoint's whole deviation
    # is 0.3% of it
    e, k = run("implicit_euler", 200)
    check(e[0] - e[-1] > 0.5 * k.max(), f"np={np_}: implicit Euler loses energy on the same chain in 200 steps: E0 - E = {e[0] - e[-1]:.3f} J (largest kinetic energy {k.max():.3f} J)")


def step_rule_refused(np_):
    base = CLOTH + ["-msim_dt", "0.01", "-msim_steps", "2", "-msim_step_atol", "1e-3"]
    cases = [(f"{s} {' '.join(solver)} -msim_step_atol", ["-msim_integrator", s, "-snes_type"] + solver, ["-msim_step_atol", f"-snes_type {solver[0]}", "not supported"])
             for s, solver in (("implicit_euler", ["pd"]), ("bdf2", ["pd", "-snes_pd_anderson", "3"]), ("implicit_midpoint", ["pd", "-snes_pd_fixed"]), ("newmark", ["ksponly"]),
                               ("implicit_euler", ["ngmres", "-npc_snes_type", "pd"]))]
    mt.refusals(check, MSIM, base, cases, np_)


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            orders(np_, tmp)
            solvers(np_, tmp)
            restarts(np_, tmp)
            bdf2_startup(np_, tmp)
            bdf2_free_fall(np_, tmp)
            midpoint_vs_ts(np_, tmp)
            energy(np_, tmp)
            step_rule_refused(np_)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
