#!/usr/bin/env python3
"""Runs repeat at 3 ranks: no rank adds to another's matrix rows.
PETSc's matrix assembly sums the entries that several ranks send to one row in the order the
messages arrive, so at 3 ranks and more (a row can then hear from two others) two runs of one scene
differed in the last bits (a 13 x 13 cloth with BDF2 and PD: two outcomes in about 1 run in 3; a
4 x 4 x 4 tet box with the volume term and Newton-CG: 5 outcomes in 6 runs; the tet slab of
tests/self_contact_mesh.py folding onto itself with self-contact and friction: 6 in 6).
The springs' matrices and the volume term's Hessian are assembled by each rank into its own rows
(the halo springs and halo tets give a boundary row its other ranks' blocks), and self-contact's
and self-friction's rows that other ranks own are sent to them and added there in rank order, so
- PETSc's -info says every assembly of the PD matrix and of Newton's Jacobian stashed 0 entries
  for other ranks, at 3 ranks;
- runs of each at 3 ranks end bit for bit alike (4 runs of the PD case, 3 of the tets', 2 else).
Usage: ranks_repeat.py path/to/msim"""
import os
import re
import sys
import tempfile

import msimtest as mt
import self_contact_mesh as scm

MSIM = mt.msim_path()
check = mt.Checks()
CLOTH = ["-msim_cloth_n", "13", "-msim_fix", "none", "-msim_dt", "0.02", "-msim_steps", "3"]
# the volume term with its barrier (-msim_volume's defaults)
TETS = ["-msim_scene", "box", "-msim_box_n", "4,4,4", "-msim_box_size", "0.1,0.1,0.1", "-msim_fix_plane", "x_min",
        "-msim_young", "5e4", "-msim_gravity", "0,-30,0", "-msim_dt", "0.01", "-msim_steps", "2", "-msim_volume", "1"]
NEWTON_CG = ["-msim_integrator", "implicit_euler", "-snes_type", "newtonls", "-ksp_type", "cg"]
# tests/self_contact_mesh.py's slab (Newton capped at 15 iterations a step) with steps twice as long:
# it folds into self-contact within the 10
SLAB = list(scm.SLAB) + ["-msim_self_contact", "-snes_type", "newtonls", "-ksp_type", "cg"]
SLAB[SLAB.index("-msim_dt") + 1] = "0.04"
SLAB[SLAB.index("-msim_steps") + 1] = "10"
# name: (options, runs)
CASES = {"cloth, BDF2 with PD": (CLOTH + ["-msim_integrator", "bdf2", "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"], 4),
         "cloth, implicit Euler with Newton-CG": (CLOTH + NEWTON_CG + ["-msim_damping", "0.1"], 2),
         "tet box with the volume term, Newton-CG": (TETS + NEWTON_CG + ["-snes_max_it", "10"], 3),
         "tet slab folding in self-contact with friction, Newton-CG": (SLAB, 2)}


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for name, (args, runs) in CASES.items():
            r = mt.run_info(MSIM, args, 3, "mat")
            stash = [int(n) for n in re.findall(r"Stash has (\d+) entries", r.info)]
            check(r.returncode == 0 and len(stash) >= 3 and not any(stash),
                  f"{name}, 3 ranks: {len(stash)} assemblies' stashes hold {sum(stash)} entries for other ranks (every rank assembles its own rows)")
            finals = []
            for k in range(runs):
                path = os.path.join(tmp, f"final_{k}.bin")
                r = mt.run(MSIM, args + ["-msim_view_final", f"binary:{path}"], 3)
                finals.append(open(path, "rb").read() if r.returncode == 0 and os.path.exists(path) else None)
            check(finals[0] is not None and all(f == finals[0] for f in finals), f"{name}: {len(finals)} runs at 3 ranks end bit for bit alike")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
