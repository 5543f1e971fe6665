#!/usr/bin/env python3
"""Self-contact on meshes: N ranks give the same run as 1 rank, frame by frame (tests/self_contact.py
checks this for the cloth generator; here the mesh paths: a surface mesh's triangles, and a tet
mesh's boundary faces found at the directory rank of their least vertex, with their halo).
The scenes are tests/self_contact_mesh.py's: an 11 x 11 sheet read from an OFF file and a tet slab
(-msim_scene box, -msim_volume), each standing on its edge and folding onto itself, 20 steps of
h = 0.02 s (into the fold: the barrier acts, checked against the same run without self-contact),
Newton converged each step (-snes_max_it 200) on the exact direct solve (MUMPS Cholesky), a frame
every step.
Tolerance: the runs make the same minimizations from the same start; the partition changes only the
order of sums (the gradient's ghost and halo sums, MUMPS's pivot order), a roundoff of eps |x| =
2.2e-16 m per operation (|x| ~ 1 m), which each step's solve amplifies by its Hessian's condition
number: H = M + h^2 K, with a vertex's mass ~ 1/121 kg and h^2 times its springs' stiffness ~ 3
(6-8 springs of 1000 N/m at h = 0.02 s), about 400, so ~1e-13 m per step and ~2e-12 m summed over
20 steps. The barrier's blocks are as stiff as a vertex's mass term at dhat / 2 and stiffer closer,
and a step can grow the error carried in the velocity: a factor 50 on top gives 1e-10 m. A pair
that one partition computed and another missed would move its vertices by the barrier's force
over a step, orders above that: with -msim_self_contact_halo 0 (other ranks' elements left out) the
slab's fold departs from 1 rank's by 1.9e-4 m at 2 ranks and by 2e-2 m at 3 (or its solve fails
there: the runs are not bit-identical from one try to the next, ADD_VALUES sums arrive in any
order), so the comparison sees the halo.
Usage: self_contact_ranks.py path/to/msim [--np N] (2 and 3 ranks against 1, whose runs are made once;
N > 1: N ranks alone; 1: nothing to compare)"""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt
import self_contact_mesh as scm

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

TOL = 1e-10  # m, derived above
STEPS = "20"


def frames(exe, args, np_, out):
    r = mt.run(exe, args + ["-msim_output", out, "-msim_output_every", "1"], np_)
    if r.returncode != 0:
        return None, r.stderr.strip()[-300:]
    return [vtu.read_vtu(p)["points"] for _, p in vtu.read_pvd(os.path.join(out, "series.pvd"))], ""


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_self_contact_ranks_")
    sheet = os.path.join(tmp, "sheet.off")
    scm.write_sheet(sheet, 11)
    common = list(scm.COMMON)
    common[common.index("-snes_max_it") + 1] = "200"
    common[common.index("-msim_steps") + 1] = STEPS
    direct = ["-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps"]
    scenes = {"sheet": common + scm.UP_Y + ["-msim_scene", "mesh", "-msim_mesh_file", sheet] + direct,
              "slab": common + scm.SLAB[len(scm.COMMON):] + direct}
    for name, args in scenes.items():
        one, why = frames(exe, args + ["-msim_self_contact"], 1, os.path.join(tmp, f"{name}_1"))
        if not check(one is not None, f"{name}: 1 rank runs ({why})"):
            continue
        off, why = frames(exe, args, 1, os.path.join(tmp, f"{name}_off"))
        if check(off is not None, f"{name}: 1 rank without self-contact runs ({why})"):
            acted = float(abs(off[-1] - one[-1]).max())
            check(acted > 1e3 * TOL, f"{name}: the barrier acts over the {STEPS} steps (final positions {acted:.2e} m from the run without it)")
        for np_ in [n for n in mt.ranks((2, 3)) if n > 1]:
            many, why = frames(exe, args + ["-msim_self_contact"], np_, os.path.join(tmp, f"{name}_{np_}"))
            if not check(many is not None and len(many) == len(one), f"np {np_}: {name} runs, {len(one)} frames ({why})"):
                continue
            diff = [float(abs(a - b).max()) for a, b in zip(one, many)]
            print(f"np {np_}: {name}: max |x_N - x_1| per frame: " + " ".join(f"{d:.1e}" for d in diff))
            check(max(diff) < TOL, f"np {np_}: {name}: every frame equals 1 rank's (max difference {max(diff):.2e} m < {TOL:g})")
            if name == "slab":  # the comparison sees the halo: without it the fold across ranks differs (or fails)
                nohalo, why = frames(exe, args + ["-msim_self_contact", "-msim_self_contact_halo", "0"], np_, os.path.join(tmp, f"nohalo_{np_}"))
                worst = max(float(abs(a - b).max()) for a, b in zip(one, nohalo)) if nohalo else float("inf")
                check(worst > 1e3 * TOL, f"np {np_}: slab without the halo (-msim_self_contact_halo 0) departs from 1 rank ({'max difference %.2e m' % worst if nohalo else 'failed: ' + why[-120:]}): the comparison can fail")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
