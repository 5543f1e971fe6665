#!/usr/bin/env python3
"""The first iterate of each implicit step, -msim_implicit_guess (src/implicit/problem.cpp, each
scheme's predict op), for every scheme:
- free fall (a cloth with no fixed vertex at its rest shape: its springs exert nothing, gravity
  is the only force): extrapolate and filtered start every step at its solution (the first step
  from v_0 + h g, the later ones from 2 v_n - v_{n-1} = v_n + h g; filtered's PD solve leaves a
  uniform vector as it is, L 1 = 0), so Newton takes 0 iterations on every step;
  constant_velocity's x_n + h v_n misses by beta h^2 g and takes 1 or more;
- order: on a soft pendulum chain (motion resolved, h omega_max < 0.1) the residual |g| at the
  first iterate of the step ending at t = 0.1 s falls as h^2 with constant_velocity (its error is
  c h^2 a) and as h^3 with extrapolate and filtered (h = 0.005 and 0.0025 s: observed orders
  2 +- 0.1 and 2.7 ... 3.2);
- restart: with extrapolate and filtered, a run restarted from its checkpoint at step 10 ends
  step 20 bit for bit as the uninterrupted run (PD with 5 fixed iterations, which keeps the guess's
  mark on every step); the checkpoint carries one vector more than constant_velocity's (v_{n-1}),
  and a restart from a checkpoint without it (written with constant_velocity) does not repeat the
  run, so the vector is what makes the restart exact;
- contact: a cloth dropped on a sphere with extrapolate (implicit Euler and BDF2, Newton and PD)
  keeps every vertex outside in every frame (the guess's feasibility pull-back).
Usage: implicit_guess.py path/to/msim [--np N]"""
import math
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "runs", "tools"))
import vtu  # noqa: E402

SCHEMES = ("implicit_euler", "bdf2", "implicit_midpoint", "newmark", "discrete_gradient")
GUESSES = ("extrapolate", "filtered")


def its_per_step(exe, args, np_, tmp, name):
    mon = os.path.join(tmp, f"{name}.csv")
    r = mt.run(exe, list(args) + ["-msim_monitor_csv", mon], np_)
    if r.returncode or not os.path.exists(mon):
        print(r.stderr[-1500:])
        return None
    return [int(row["nonlinear_its"]) for row in mt.read_csv(mon)][1:]  # row 0: the initial state


def free_fall(exe, check, np_, tmp):
    base = ["-msim_cloth_n", "6", "-msim_fix", "none", "-msim_dt", "0.02", "-msim_steps", "6", "-msim_spectrum_check", "0"]
    for s in SCHEMES:
        cv = its_per_step(exe, base + ["-msim_integrator", s, "-msim_implicit_guess", "constant_velocity"], np_, tmp, f"ff_{s}_cv")
        check(cv is not None and min(cv) >= 1, f"np={np_}: {s}: free fall from x_n + h v_n takes Newton iterations on every step ({cv})")
        for g in GUESSES:
            its = its_per_step(exe, base + ["-msim_integrator", s, "-msim_implicit_guess", g], np_, tmp, f"ff_{s}_{g}")
            check(its is not None and max(its) == 0, f"np={np_}: {s}, {g}: free fall starts every step at its solution, 0 Newton iterations ({its})")


def first_residual(exe, args, np_, tmp, name, step):
    conv = os.path.join(tmp, f"{name}.csv")
    r = mt.run(exe, list(args) + ["-msim_monitor_convergence", conv], np_)
    if r.returncode or not os.path.exists(conv):
        print(r.stderr[-1500:])
        return float("nan")
    rows = [x for x in mt.read_csv(conv) if x["iteration"] == "0" and int(x["step"]) == step]
    return float(rows[0]["gnorm"]) if rows else float("nan")


def order(exe, check, np_, tmp):
    # a 10-vertex chain fixed at one end, k = 10 N/m: omega_max about 20 rad/s, h omega_max <= 0.1
    base = ["-msim_scene", "chain", "-msim_chain_n", "10", "-msim_fix", "edge", "-msim_stiffness", "10", "-msim_spectrum_check", "0"]
    for s in SCHEMES:
        for g in ("constant_velocity",) + GUESSES:
            r = [first_residual(exe, base + ["-msim_integrator", s, "-msim_implicit_guess", g, "-msim_dt", str(h), "-msim_steps", str(n)], np_, tmp, f"ord_{s}_{g}_{n}", n)
                 for h, n in ((0.005, 20), (0.0025, 40))]
            p = math.log2(r[0] / r[1]) if r[1] > 0 else float("nan")
            lo, hi = (1.9, 2.1) if g == "constant_velocity" else (2.7, 3.2)
            check(lo <= p <= hi, f"np={np_}: {s}, {g}: |g| at the first iterate of the step ending at t = 0.1 s: {r[0]:.3e} (h = 0.005), {r[1]:.3e} (h = 0.0025), order {p:.2f} in [{lo}, {hi}]")


def restart(exe, check, np_, tmp):
    base = ["-msim_cloth_n", "6", "-msim_dt", "0.01", "-snes_type", "pd", "-snes_pd_fixed", "-snes_max_it", "5", "-msim_spectrum_check", "0"]
    vec = 8 + 3 * 36 * 8  # a PETSc binary Vec of the 6 x 6 cloth, as checkpoints write it: class id, size, 3 x 36 doubles
    for s in ("implicit_euler", "bdf2", "newmark"):
        cv_ck = os.path.join(tmp, f"{s}_cv_ck")
        mt.run(exe, base + ["-msim_integrator", s, "-msim_steps", "10", "-msim_checkpoint", cv_ck], np_)
        for g in GUESSES:
            args = base + ["-msim_integrator", s, "-msim_implicit_guess", g]
            full, ck, part, other = (os.path.join(tmp, f"{s}_{g}_{k}") for k in ("full.bin", "ck", "part.bin", "other.bin"))
            mt.run(exe, args + ["-msim_steps", "20", "-msim_view_final", f"binary:{full}"], np_)
            mt.run(exe, args + ["-msim_steps", "10", "-msim_checkpoint", ck], np_)
            mt.run(exe, args + ["-msim_steps", "20", "-msim_restart", ck, "-msim_view_final", f"binary:{part}"], np_)
            mt.run(exe, args + ["-msim_steps", "20", "-msim_restart", cv_ck, "-msim_view_final", f"binary:{other}"], np_)
            ok = all(os.path.exists(p) for p in (full, part, other, ck, cv_ck))
            check(ok and open(full, "rb").read() == open(part, "rb").read(), f"np={np_}: {s}, {g}: restarted at step 10, step 20 is bit for bit the uninterrupted run's")
            check(ok and open(full, "rb").read() != open(other, "rb").read(), f"np={np_}: {s}, {g}: restarted from a checkpoint without v_(n-1) (constant_velocity's), it is not")
            # implicit Euler's constant_velocity checkpoint has no history at all, so not its name either
            expect = vec + (len(s) if s == "implicit_euler" else 0)
            grown = os.path.getsize(ck) - os.path.getsize(cv_ck) if ok else -1
            check(grown == expect, f"np={np_}: {s}, {g}: the checkpoint carries v_(n-1), one vector more than constant_velocity's ({grown} bytes, expected {expect})")


def contact(exe, check, np_, tmp):
    cloth = ["-msim_cloth_n", "7", "-msim_fix", "none", "-msim_dt", "0.02", "-msim_steps", "40", "-msim_implicit_guess", "extrapolate", "-msim_spectrum_check", "0"]
    centre, radius = np.array([0.5, 0.5, -0.6]), 0.4
    for s in ("implicit_euler", "bdf2"):
        for sname, sargs in (("newton", []), ("pd", ["-snes_type", "pd", "-snes_max_it", "200"])):
            out = os.path.join(tmp, f"contact_{s}_{sname}")
            r = mt.run(exe, cloth + sargs + ["-msim_integrator", s, "-msim_contact_sphere", "0.5,0.5,-0.6,0.4", "-msim_output", out, "-msim_output_every", "1"], np_)
            if not check(r.returncode == 0, f"np={np_}: {s}, {sname}, extrapolate: a cloth dropped on a sphere runs ({r.stderr.strip()[-300:]})"):
                continue
            frames = vtu.read_pvd(os.path.join(out, "series.pvd"))
            least = min(float(np.min(np.linalg.norm(vtu.read_vtu(path)["points"] - centre, axis=1))) - radius for _, path in frames)
            check(len(frames) == 41 and least > 0, f"np={np_}: {s}, {sname}, extrapolate: every vertex outside the sphere in all {len(frames)} frames (least distance {least:.3g} m > 0)")


def main():
    exe, check = mt.msim_path(), mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_implicit_guess_")
    for np_ in mt.ranks():
        free_fall(exe, check, np_, tmp)
        order(exe, check, np_, tmp)
        restart(exe, check, np_, tmp)
        contact(exe, check, np_, tmp)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
