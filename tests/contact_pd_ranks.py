#!/usr/bin/env python3
"""PD with contact weights (-msim_contact_pd_weight, the default) gives the same run at 1 and 2
ranks. examples/bunny_drop.opts (the TetGen bunny landing on a plane; BDF2 with 30 fixed
PD iterations per step, Anderson off here: its safeguard's discrete choices amplify the partition's
roundoff already in the landing, 1e-7 to 3e-5 m after 11 steps with or without the weights) runs 11 steps, through its first contact (step 10: 23 vertices
within dhat, step 11: 377), at 1 and 2 ranks. PD's matrix A holds the barrier's
weights of the vertices within dhat, and a fixed-iteration PD step depends on A. When each rank
refreshed its weights only where its own set of such vertices had changed, A depended on the
partition: at 2 ranks one rank kept stale weights while the other's set changed, and the bunny
ended 1.2e-3 m from the 1-rank run one step after landing (6e-14 m the step before); with the
decision taken over all ranks (src/implicit/terms/obstacles.cpp) the two agree to roundoff. The
same comparison without the weights (-msim_contact_pd_weight 0) bounds what roundoff alone gives
(6e-13 m after 11 steps when measured). Later in the run, as the bunny flattens and bounces, the
unconverged PD steps with their discrete safeguards (Anderson's, the step cut at the plane)
amplify the partition's roundoff, so the whole 60 steps are not compared.
Usage: contact_pd_ranks.py path/to/msim [--no-tetgen]"""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

ARGS = ["-options_file", os.path.join(mt.ROOT, "examples", "bunny_drop.opts"), "-msim_steps", "11", "-msim_output_every", "1000", "-snes_pd_anderson", "0"]
# roundoff of another summation order through 11 unconverged PD steps and the landing (measured:
# 5.7e-13 m; one step later the flattening bunny amplifies it to ~6e-9 m with or without weights)
TOL = 1e-8


def main():
    exe, check = mt.msim_path(), mt.Checks()
    if mt.without_tetgen("contact_pd_ranks"):
        return 0
    tmp = tempfile.mkdtemp(prefix="msim_contact_pd_ranks_")
    for weight in ("1", "0"):
        x, counts = {}, None
        for np_ in (1, 2):
            mon = os.path.join(tmp, f"monitor_{weight}_{np_}.csv")
            frames = ["-msim_output", os.path.join(tmp, f"frames_{weight}_{np_}")]
            x[np_], r = mt.final_positions(exe, ARGS + frames + ["-msim_contact_pd_weight", weight, "-msim_monitor_csv", mon], np_, tmp, f"final_{weight}", cwd=mt.ROOT)
            check(x[np_] is not None, f"pd_weight {weight}, np {np_}: runs")
            if np_ == 1 and x[np_] is not None:
                counts = [int(row["contact_n"]) for row in mt.read_csv(mon)]
        if x[1] is None or x[2] is None:
            continue
        d = float(np.abs(x[1] - x[2]).max())
        check(d < TOL, f"pd_weight {weight}: 1 and 2 ranks agree after 11 steps, max |x1 - x2| = {d:.3g} m (< {TOL:g})")
        check(counts is not None and len(set(counts)) >= 3 and counts[-1] > 0,
              f"pd_weight {weight}: the bunny has landed and its contact set changed step by step (vertices within dhat: {counts})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
