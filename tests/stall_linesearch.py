#!/usr/bin/env python3
"""The stall report with PETSc's line searches (-snes_linesearch_type bt, l2, cp), at the rank count
given. msim's own energy search asks the barrier's largest feasible step itself and reports it as
its lambda; PETSc's searches get Newton's direction already cut by msim's pre-check (the barrier's
max_step) and report lambda of the cut direction, so a step cut to nothing passed as converged.
The scene is tests/self_contact_start.py's locked cloth: examples/cloth_fold.opts at 41 x 41 with
its 1 cm perturbation, whose start crosses itself (6 intersecting triangle pairs, counted here by
the independent test of runs/tools/intersections.py), run with the start check off
(-msim_self_contact_start_check 0): the barrier keeps crossing elements locked through each other,
so every step's CCD cuts Newton's step to nothing while |g| stays near |g0|.
- bt with -snes_stol 1e-8: bt takes the cut direction whole (lambda = 1) and newtonls ends on
  -snes_stol; msim must warn once that the 2 steps stalled, and not that they converged (to a
  saddle point, the warning the unfixed build gave);
- bt with msim's -snes_stol (1e-12): bt fails on the cut direction (DIVERGED_LINE_SEARCH), and the
  one error line says the direction was cut by the barrier (at 1 rank; at 2 the partition's
  roundoff lets the cut fall below -snes_stol |x| first, and the stall is reported instead);
- l2: its secant steps took lambda past 1, beyond the pre-check's feasible step, and passed the 6
  crossing pairs through each other in one step. Now lambda <= 1 (cp's too): every frame has as
  many intersecting pairs as the start (locked pairs cannot uncross without touching, which the
  barrier forbids), and the stall is reported once;
- the same cloth perturbed 5 mm (no crossing) with bt and -snes_stol 1e-8 has no stall reported.
Usage: stall_linesearch.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import intersections  # noqa: E402
import vtu  # noqa: E402

FOLD = ["-options_file", os.path.join(mt.ROOT, "examples", "cloth_fold.opts"), "-msim_cloth_n", "41", "-msim_steps", "2"]
LOCKED = FOLD + ["-msim_self_contact_start_check", "0"]
STALL = "steps the solve stalled and did not converge"


def crossings(out):
    """intersecting triangle pairs in each frame written to out"""
    found = []
    for f in mt.frames(out):
        x = vtu.read_vtu(os.path.join(out, f))["points"]
        found.append(intersections.intersecting_pairs(x, intersections.cloth_triangles(len(x))))
    return found


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_stall_linesearch_")
    for np_ in mt.ranks():
        r = mt.run(exe, LOCKED + ["-snes_linesearch_type", "bt", "-snes_stol", "1e-8"], np_)
        err = mt.lines(r.stderr)
        stall = [l for l in err if STALL in l]
        check(r.returncode == 0 and len(stall) == 1 and "in 2 of 2 steps" in stall[0], f"np {np_}: bt: the locked cloth's 2 steps are reported once as stalled ({stall or err[-3:]})")
        check(not any("saddle" in l for l in err), f"np {np_}: bt: and not as converged to a saddle point")
        r = mt.run(exe, LOCKED + ["-snes_linesearch_type", "bt"], np_)
        err = [l for l in mt.lines(r.stderr) if "msim: step " not in l]  # not the progress line
        failed = r.returncode != 0 and len(err) == 1 and "DIVERGED_LINE_SEARCH on a direction cut to" in err[0] and "contact barrier" in err[0]
        stalled = r.returncode == 0 and len(err) == 1 and STALL in err[0]
        check(failed or stalled, f"np {np_}: bt at -snes_stol 1e-12: one line, an error naming the barrier's cut or the stall warning ({err[-2:]})")
        for ls in ("l2",):
            out = os.path.join(tmp, f"{ls}_{np_}")
            r = mt.run(exe, LOCKED + ["-snes_linesearch_type", ls, "-msim_output", out, "-msim_output_every", "1"], np_)
            err = mt.lines(r.stderr)
            stall = [l for l in err if STALL in l]
            check(r.returncode == 0 and len(stall) == 1 and "in 2 of 2 steps" in stall[0], f"np {np_}: {ls}: the locked cloth's 2 steps are reported once as stalled ({stall or err[-3:]})")
            if r.returncode == 0:
                found = crossings(out)
                check(len(found) == 3 and found[0] > 0 and all(n == found[0] for n in found), f"np {np_}: {ls}: no step passes elements through each other (intersecting pairs per frame {found})")
        r = mt.run(exe, FOLD + ["-msim_perturb", "0.005", "-snes_linesearch_type", "bt", "-snes_stol", "1e-8"], np_)
        err = mt.lines(r.stderr)
        check(r.returncode == 0 and not any("stalled" in l for l in err), f"np {np_}: bt: perturbed 5 mm (no crossing) it runs with no stall ({err[-2:]})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
