#!/usr/bin/env python3
"""PD + L-BFGS (-snes_type pd -snes_pd_lbfgs 8, src/solvers/pd_lbfgs.cpp) on the benchmark cloth
dropped on the ball with friction (issue 34), 31 x 31, PD-10 a step, 120 steps (the cloth comes to
rest), at each rank count. L-BFGS's step was shortened to the barrier's feasible set by one alpha
for all vertices: near the ball that left t ~ 1e-3 at every iteration, each such crawl passed
Armijo's test, and 10 iterations ended far above the step's minimum: this run gained 2.8 J of
total energy at step 7 at 1 rank and diverged at step 59 at 2 ranks (51 x 51 with -snes_pd_fixed:
59 J, contact forces of 3000 N against m g = 9.81 N). A step that would leave the feasible set is
now replaced by the plain PD step. Checked:
- implicit Euler with a static ball and friction does not create energy: the total energy (monitor
  column `total`) never rises above its start (1e-9 J for roundoff);
- Phi never rises from one iteration to the next within a solve (-info's L-BFGS lines), beyond
  1e-12 |Phi| and what the inertia term resolves with positions of order 1 m;
- no vertex inside the ball in any frame (the barrier's guarantee), and the cloth reaches the ball;
- at rest the ball carries the weight: |F_contact - (0, 0, M g)| within the bound momentum gives,
  (|p_n+1| + |p_n|) / h + sqrt(vertices) |g| / h^2 (|p| = sqrt(2 M KE), |g| the last iterate's
  residual, read through PD's residual path: the same iterates as -snes_pd_fixed, its tolerances 0),
  as tests/contact_ntr.py does.
Usage: contact_pd_lbfgs.py path/to/msim [--np N]"""
import math
import os
import re
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

MSIM = mt.msim_path()
N, STEPS, H, MASS, G = 31, 120, 0.0333333333333, 1.0, 9.81
CENTRE, RADIUS = np.array([0.5, 0.5, -0.4]), 0.3
RUN = ["-msim_cloth_n", N, "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.0333333333333", "-msim_steps", STEPS,
       "-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_friction", "0.3",
       "-snes_type", "pd", "-snes_max_it", "10", "-snes_atol", "0", "-snes_rtol", "0", "-snes_stol", "0", "-snes_pd_lbfgs", "8"]
INFO = re.compile(r"^\[0\] <snes> SNESSolve_PD\(\): pd: L-BFGS iteration (\d+) Phi (\S+)$", re.M)


def main():
    check = mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            csv, out = os.path.join(tmp, f"m_{np_}.csv"), os.path.join(tmp, f"frames_{np_}")
            r = mt.run_info(MSIM, RUN + ["-msim_monitor_csv", csv, "-msim_output", out, "-msim_output_every", 1], np_, "snes")
            rows = mt.read_csv(csv) if r.returncode == 0 else []
            if not check(len(rows) == STEPS + 1, f"np={np_}: {STEPS} PD + L-BFGS-8 steps on the ball" + ("" if r.returncode == 0 else ": " + r.stderr.strip()[-300:])):
                continue
            e = [float(x["total"]) for x in rows]
            k = int(np.argmax(e))
            check(e[k] <= e[0] + 1e-9, f"np={np_}: total energy never above its start: largest {e[k]:.6g} J (step {k}) <= {e[0]:.3g} J")
            floor = MASS * np.finfo(float).eps ** 2
            worst, n, prev = -np.inf, 0, None
            for it, phi in ((int(a), float(b)) for a, b in INFO.findall(r.info)):
                if it > 0 and prev is not None:
                    worst = max(worst, (phi - prev) / (1e-12 * abs(prev) + floor))
                    n += 1
                prev = phi
            check(n > 0 and worst <= 1, f"np={np_}: Phi never rises within a solve over {n} iterations (largest rise {worst:.3g} x the allowance)")
            least, nf = np.inf, 0
            for _, fr in vtu.read_pvd(os.path.join(out, "series.pvd")):
                least = min(least, float((np.linalg.norm(vtu.read_vtu(fr)["points"] - CENTRE, axis=1) - RADIUS).min()))
                nf += 1
            check(nf == STEPS + 1 and least > 0, f"np={np_}: no vertex inside the ball in any of {nf} frames (least distance {least:.3g} m)")
            check(max(int(x["contact_n"]) for x in rows) > 0, f"np={np_}: the cloth reached the ball")
            last, prev_ = rows[-1], rows[-2]
            f = np.array([float(last[c]) for c in ("contact_fx", "contact_fy", "contact_fz")])
            err = float(np.abs(f - np.array([0, 0, MASS * G])).max())
            bound = (math.sqrt(2 * MASS * float(last["kinetic"])) + math.sqrt(2 * MASS * float(prev_["kinetic"]))) / H + N * float(last["residual"]) / H**2
            check(err <= bound, f"np={np_}: at rest the ball carries the weight: contact force ({f[0]:.3g}, {f[1]:.3g}, {f[2]:.5g}) N off (0, 0, {MASS * G:g}) by {err:.3g} <= the derived bound {bound:.3g} N")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
