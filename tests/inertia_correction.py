#!/usr/bin/env python3
"""Newton with inertia correction (-msim_inertia_correction) converges to minima of Phi where plain
Newton converges to saddles. The case: a chain held at both ends, compressed to 0.95 of its rest
length, pulled along its axis by gravity with a small sideways component (1% of it) so that it can
buckle. Plain Newton's first step ends at a saddle (tests/saddle.py checks msim's count of
negative eigenvalues against one derived by hand on the straight chain); with inertia correction,
at 1 and at 2 ranks:
  - every step converges to |g| <= 1e-8 |g0| and msim warns of nothing;
  - the exact Hessian at each solution has no negative eigenvalue (the saddle check finds none);
  - the correction was needed (some iterations factored H + delta M with delta > 0);
  - the first step, from the same start as plain Newton's, ends at lower Phi than its saddle;
  - both rank counts reach the same Phi in each step.
Usage: inertia_correction.py path/to/msim"""
import os
import re
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
SCENE = ["-msim_scene", "chain", "-msim_chain_n", "40", "-msim_chain_length", "1", "-msim_mass", "1", "-msim_stiffness", "1000",
         "-msim_fix", "corners", "-msim_prestretch", "0.95", "-msim_gravity", "-50,-0.5,0", "-msim_integrator", "implicit_euler",
         "-msim_dt", "0.01", "-snes_type", "newtonls", "-msim_psd", "0", "-ksp_type", "preonly", "-pc_type", "cholesky",
         "-pc_factor_mat_solver_type", "mumps", "-snes_rtol", "1e-8", "-snes_max_it", "100", "-msim_view"]


def run(np, steps, correct, tmp):
    mon = os.path.join(tmp, f"mon_{np}_{steps}_{correct}.csv")
    r = mt.run(MSIM, SCENE + ["-msim_steps", str(steps), "-msim_inertia_correction", str(correct), "-msim_monitor_csv", mon], np)
    saddle = re.search(r"steps converged to a saddle point of Phi \(negative pivots in the exact Hessian's LDL\^T\): (\d+), at most (\d+)", r.stdout)
    shifted = re.search(r"inertia correction: (\d+) Newton iterations factored H \+ delta M", r.stdout)
    rows = mt.read_csv(mon)[1:] if os.path.exists(mon) else []
    return dict(rc=r.returncode, stderr=r.stderr.strip(), saddle=int(saddle.group(1)) if saddle else None,
                shifted=int(shifted.group(1)) if shifted else None, phi=[float(x["phi"]) for x in rows],
                its=[int(x["nonlinear_its"]) for x in rows])


def main():
    check = mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        phis = {}
        for np in (1, 2):
            plain = run(np, 1, 0, tmp)
            check(plain["rc"] == 0 and plain["saddle"] == 1, f"np={np}: plain Newton's first step ends at a saddle (steps at a saddle: {plain['saddle']})")
            fixed = run(np, 3, 1, tmp)
            check(fixed["rc"] == 0 and fixed["stderr"] == "" and len(fixed["phi"]) == 3,
                  f"np={np}: with inertia correction 3 steps converge, no warning (its {fixed['its']}; stderr {fixed['stderr'][:200]!r})")
            check(fixed["saddle"] == 0, f"np={np}: no step ends at a saddle (steps at a saddle: {fixed['saddle']})")
            check((fixed["shifted"] or 0) > 0, f"np={np}: the correction was needed ({fixed['shifted']} shifted iterations)")
            if plain["phi"] and fixed["phi"]:
                check(fixed["phi"][0] < plain["phi"][0], f"np={np}: first step's Phi {fixed['phi'][0]:.9e} below the saddle's {plain['phi'][0]:.9e}")
            phis[np] = fixed["phi"]
        agree = len(phis[1]) == len(phis[2]) == 3 and all(abs(a - b) <= 1e-9 * abs(a) for a, b in zip(phis[1], phis[2]))
        check(agree, f"1 and 2 ranks reach the same Phi: {phis[1]} / {phis[2]}")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
