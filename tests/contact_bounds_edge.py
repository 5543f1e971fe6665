#!/usr/bin/env python3
"""A box's face as VI bounds holds a vertex only over the box (-msim_contact_bounds): a 21 x 21
cloth (1 m, nothing fixed, frictionless) dropped 3 cm onto examples/cloth_table.opts's table, the
box [-1, 0.55] x [-1, 2] x [-1, -0.03], whose edge x = 0.55 it slides off; implicit Euler at
h = 0.02 s, 50 steps. Each vertex keeps, within a step, the half-space of the face it was farthest
outside at the step's start; the top's half-space z >= -0.03 reaches past the edge, and a vertex
that slid past the edge in the step used to end held there, on nothing: in 7 frames a row of 21
vertices lay at the top's height up to 4.05 cm past the edge, carrying up to 26.2 N of contact
force (the cloth weighs 9.81 N; the barrier, without bounds, puts at most 3.9e-3 N on a vertex 1 cm
past the edge, within its reach dhat). Such a vertex now takes the face it is beyond
(src/contact/contact_bounds.cpp, ConvergedOnBox). Checked at each rank count, in every frame
(written every step):
- the 50 steps run;
- no vertex lies at the top's height (to 1e-9 m) past the edge;
- no vertex past the edge carries a vertical contact force: there only the side face x >= 0.55 can
  hold it, and it pushes along x (|f_z| <= 1e-9 N; it was 16.2 N on one row at step 30)."""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

MSIM = mt.msim_path()
STEPS = 50
EDGE, TOP = 0.55, -0.03
ARGS = ["-msim_cloth_n", "21", "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.02",
        "-msim_steps", str(STEPS), "-msim_contact_box", f"-1,{EDGE},-1,2,-1,{TOP}", "-msim_contact_bounds"]


def main():
    check = mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            out = os.path.join(tmp, f"edge_{np_}")
            r = mt.run(MSIM, ARGS + ["-msim_output", out, "-msim_output_every", "1"], np_)
            files = mt.frames(out) if r.returncode == 0 else []
            check(r.returncode == 0 and len(files) == STEPS + 1, f"np={np_}: the cloth off the table's edge, {STEPS} steps run" + ("" if r.returncode == 0 else ": " + r.stderr.strip()[-300:]))
            held, force = [], []  # (m past the edge, frame) of vertices at the top's height; (N, frame) of vertical force past the edge
            for i, f in enumerate(files):
                d = vtu.read_vtu(os.path.join(out, f))
                p, fz = d["points"], d["contact_force"][:, 2]
                past = p[:, 0] > EDGE
                on = past & (np.abs(p[:, 2] - TOP) <= 1e-9)
                if on.any():
                    held.append((float(p[on, 0].max()) - EDGE, i))
                if past.any():
                    force.append((float(np.abs(fz[past]).max()), i))
            check(files and not held, f"np={np_}: no vertex at the top's height past the edge in any of {len(files)} frames ({len(held)} frames{'' if not held else f', up to {max(held)[0]:.3g} m past it at frame {max(held)[1]}'})")
            most = max(force, default=(0.0, 0))
            check(files and most[0] <= 1e-9, f"np={np_}: no vertical contact force on a vertex past the edge (at most {most[0]:.3g} N, frame {most[1]})")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
