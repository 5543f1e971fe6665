#!/usr/bin/env python3
"""Newton stopped on the length of its step, as graphics codes stop it (|dx| < 1e-3, at most 20
iterations), with msim's default line search on Phi:
- PETSc's -snes_stol (|dx| < stol |x|) stops every step before -snes_max_it, at the same iteration
  as with PETSc's bt line search (the energy line search used to report a stale step length, so
  -snes_stol never fired and every step ran all its iterations);
- -msim_step_atol d (absolute |dx|) stops before -snes_max_it too, takes fewer iterations for a
  looser d, and ends within a few d of the state solved to roundoff (Newton's error after a step
  of length |dx| is of order |dx|^2 / |dx_prev|, far below |dx| once it converges);
- a budget too small for the rule ends with the warning that names it;
- without a barrier in Phi the rule asks nothing of |g| (its force condition is for barriers,
  whose short steps hide their force): examples/cloth_newton_fast.opts's free cloth made 1000 times
  stiffer still ends every step by the rule, before its 20 iterations (with |g| <= M d asked of
  it, 9 of 10 steps ran to the cap: what is left of |g| after a short step grows with stiffness).
At 1 and 2 ranks (or with `--np N` at N alone: ctest's newton_step_tol_np1 and _np2, the 1-rank
half beside other tests), on a 31 x 31 cloth falling from two corners at h = 1/30 s (its springs compress
and buckle: Phi is nonconvex, the case that needs a line search)."""
import os
import re
import sys
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
STEPS = 4
SCENE = ["-msim_cloth_n", "31", "-msim_integrator", "implicit_euler", "-msim_dt", "0.0333333333333333", "-msim_steps", str(STEPS),
         "-snes_type", "newtonls", "-msim_psd", "0", "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps",
         "-msim_check_saddle", "0"]
LOOSE = ["-snes_rtol", "0", "-snes_atol", "0"]
MAXIT = 30


def run(np_, extra, tmp, tag):
    out = os.path.join(tmp, f"{tag}_{np_}.txt")
    r = mt.run(MSIM, SCENE + extra + ["-msim_monitor", "-msim_view_final", mt.view_ascii(out)], np_)
    its = [int(m.group(1)) for m in re.finditer(r"^step\s+[1-9]\d*\s.*\snl (\d+) ", r.stdout, re.M)]
    x = np.array(mt.read_view(out)) if r.returncode == 0 else None
    return r, its, x


def main():
    check = mt.Checks()

    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            _, its_ref, xref = run(np_, ["-snes_rtol", "1e-13", "-snes_atol", "0", "-snes_max_it", "200"], tmp, "ref")
            r, its_stol, _ = run(np_, ["-snes_stol", "1e-6"] + LOOSE + ["-snes_max_it", str(MAXIT)], tmp, "stol")
            _, its_bt, _ = run(np_, ["-snes_stol", "1e-6", "-snes_linesearch_type", "bt"] + LOOSE + ["-snes_max_it", str(MAXIT)], tmp, "bt")
            check(r.returncode == 0 and len(its_stol) == STEPS and max(its_stol) < MAXIT,
                  f"np={np_}: -snes_stol stops every step before -snes_max_it {MAXIT} (iterations {its_stol}; to roundoff {its_ref})")
            check(its_stol == its_bt, f"np={np_}: the same iterations as PETSc's bt line search ({its_bt})")
            prev = None
            for d in (1e-2, 1e-3, 1e-5):
                r, its, x = run(np_, ["-msim_step_atol", str(d)] + LOOSE + ["-snes_max_it", str(MAXIT)], tmp, f"atol{d}")
                err = float(np.linalg.norm(x - xref)) if x is not None else float("inf")
                check(r.returncode == 0 and len(its) == STEPS and max(its) < MAXIT and "warning" not in r.stderr,
                      f"np={np_}: -msim_step_atol {d:g} stops every step (iterations {its})")
                check(err < STEPS * d, f"np={np_}: |x - x_roundoff| = {err:.2e} < {STEPS} x {d:g}")
                if prev is not None:
                    check(sum(its) >= sum(prev), f"np={np_}: a tighter step tolerance takes at least as many iterations ({sum(its)} >= {sum(prev)})")
                prev = its
            r, its, _ = run(np_, ["-msim_step_atol", "1e-12"] + LOOSE + ["-snes_max_it", "2"], tmp, "budget")
            # with -snes_rtol 0 -snes_atol 0 the rule alone ends a solve: the warning names it and what
            # to raise (it said "before |g| <= max(0., 0. |g0|) or |dx| < ..." and told the user to set
            # the zero tolerances the run already had)
            check(r.returncode == 0 and "stopped at -snes_max_it 2 before |dx| < 1e-12 (raise -snes_max_it or -msim_step_atol)" in r.stderr and "max(0" not in r.stderr,
                  f"np={np_}: a budget too small for the rule is warned about, naming the rule alone: {r.stderr.strip()[:200]!r}")
            r = mt.run(MSIM, ["-options_file", os.path.join(mt.ROOT, "examples", "cloth_newton_fast.opts"), "-msim_cloth_n", "41", "-msim_steps", "10",
                              "-msim_stiffness", "1e6", "-msim_output", "", "-msim_monitor"], np_)
            its = [int(m.group(1)) for m in re.finditer(r"^step\s+[1-9]\d*\s.*\snl (\d+) ", r.stdout, re.M)]
            check(r.returncode == 0 and len(its) == 10 and max(its) < 20 and "warning" not in r.stderr,
                  f"np={np_}: a stiff free cloth (k = 1e6 N/m, no barrier): -msim_step_atol 1e-3 ends every step before the cap of 20 (iterations {its})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
