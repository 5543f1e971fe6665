#!/usr/bin/env python3
"""Moving obstacles faster than the contact distance (-msim_contact_velocity), at each rank count:
an obstacle rising 6 cm a step (3 m/s, dt 0.02) through a 9 x 9 cloth whose contact distance dhat
is 1.41 cm comes farther in one step than its gap to the cloth, so between two steps it passes
vertices it never was within dhat of (the step's feasible start carried only those; the box rose
through the cloth, which was left under it, falling, with no contact force and exit 0). Now each
step's start also carries with the obstacle a vertex whose motion relative to it the obstacle's own
CCD sees cross it (src/implicit/terms/obstacles.cpp, FeasibleStart_Obstacles).
For a 2 cm thick box under the cloth pinned at its corners with Newton, PD and BDF2, and with
Newton a ball 30 cm across rising 32 cm a step under a free cloth in zero gravity (a pinned cloth
slips off a ball pulled that far), a plane under a free cloth, and the box as a closed OBJ mesh (at
thickness 0 and 5 mm: the shell's conservative advancement) and as an open OBJ square (its top
alone, thickness 0), and the open square rising 32 cm a step from 28 cm under a free cloth in zero
gravity, alone and as a 5 mm shell (it passes the cloth in the last fifth of its first step, 4 cm
past it, beyond dhat: a mesh's CCD asked up to 0.8 of the step searched no farther and left the
cloth under it with no contact force):
- the run exits 0 and the monitor's contact force is > 0 along +z at every step (the obstacle is
  under the cloth from the first step on; it was 0 from the first or second);
- in every frame, every vertex over the obstacle at the start (within its footprint in x, y; every
  vertex for the plane) is, wherever it is over it, above its top (and shell) where it is at that
  frame's time: the cloth stays on the side it started on (those the obstacles jumped were under
  them, 0.3 m and more). A plane cannot be jumped (a vertex it passes is inside it: carried as
  before), so its case guards the carry within dhat;
- the box carrying the cloth into a static box over it (a ceiling) is one error line: the vertex is
  squeezed between the two (the box passed through cloth and ceiling, exit 0); so is the box
  carrying it through a 5 mm ceiling or an open OBJ square there (the start's check at its end
  alone let the cloth through, exit 0).
Usage: contact_sweep.py path/to/msim [--np N]"""
import math
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

DT, STEPS = 0.02, 6
VZ = 3.0  # m/s: 6 cm a step
BOX = (0.3, 0.7, 0.3, 0.7, -0.05, -0.03)  # 2 cm thick, its top 3 cm under the cloth at z = 0
SPHERE, SPHERE_VZ = (0.5, 0.5, -0.16, 0.15), 16.0  # 30 cm across, 1 cm under the cloth, 32 cm a step
PLANE_Z = -0.05
SHELL = 0.005  # a mesh's thickness
FAR = 0.28  # the fast open square's depth under the cloth: 7/8 of its 32 cm step


def write_obj(path, V, F):
    with open(path, "w") as f:
        for v in V:
            f.write("v %r %r %r\n" % tuple(v))
        for t in F:
            f.write("f %d %d %d\n" % tuple(i + 1 for i in t))


def box_mesh(b):
    """closed box x0,x1,y0,y1,z0,z1 as 12 triangles, outward"""
    x0, x1, y0, y1, z0, z1 = b
    V = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
    Q = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    return V, [t for a, b_, c, d in Q for t in ((a, b_, c), (a, c, d))]


def box_top(p, t, vz):
    """which vertices are over the box (within its footprint in x, y) and their height above its top"""
    x0, x1, y0, y1, _, z1 = BOX
    return (p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1), p[:, 2] - (z1 + vz * t)


def shell_top(p, t, vz):
    """the same for the box's shell"""
    over, height = box_top(p, t, vz)
    return over, height - SHELL


def sphere_top(p, t, vz):
    cx, cy, cz, r = SPHERE
    rho2 = (p[:, 0] - cx) ** 2 + (p[:, 1] - cy) ** 2
    return rho2 < r * r, p[:, 2] - (cz + vz * t + np.sqrt(np.maximum(r * r - rho2, 0)))


def far_top(p, t, vz):
    """the same for the fast open square, at -FAR"""
    over, _ = box_top(p, t, vz)
    return over, p[:, 2] - (-FAR + vz * t)


def far_shell_top(p, t, vz):
    over, height = far_top(p, t, vz)
    return over, height - SHELL


def plane_top(p, t, vz):
    return np.ones(len(p), dtype=bool), p[:, 2] - (PLANE_Z + vz * t)


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_contact_sweep_")
    box_obj, sheet_obj = os.path.join(tmp, "box.obj"), os.path.join(tmp, "sheet.obj")
    write_obj(box_obj, *box_mesh(BOX))
    x0, x1, y0, y1, _, z1 = BOX
    write_obj(sheet_obj, [(x0, y0, z1), (x1, y0, z1), (x1, y1, z1), (x0, y1, z1)], [(0, 1, 2), (0, 2, 3)])
    far_obj, ceiling_obj = os.path.join(tmp, "far.obj"), os.path.join(tmp, "ceiling.obj")
    write_obj(ceiling_obj, [(0.2, 0.2, 0.1), (0.8, 0.2, 0.1), (0.8, 0.8, 0.1), (0.2, 0.8, 0.1)], [(0, 1, 2), (0, 2, 3)])
    write_obj(far_obj, [(x0, y0, -FAR), (x1, y0, -FAR), (x1, y1, -FAR), (x0, y1, -FAR)], [(0, 1, 2), (0, 2, 3)])
    base = ["-msim_cloth_n", "9", "-msim_dt", str(DT), "-msim_steps", str(STEPS)]
    pinned, free = ["-msim_fix", "corners"], ["-msim_fix", "none"]
    box = ["-msim_contact_box", ",".join(map(str, BOX))]
    euler = ["-msim_integrator", "implicit_euler"]
    # a ball pulling a pinned cloth that far slips from under it (a point on a ball): it carries a
    # free cloth in zero gravity
    zero_g = free + ["-msim_gravity", "0,0,0"]
    ball = zero_g + ["-msim_contact_sphere", ",".join(map(str, SPHERE))]
    cases = (("box, Newton", pinned + euler + box, VZ, box_top),
             ("box, PD", pinned + euler + box + ["-snes_type", "pd", "-snes_max_it", "200"], VZ, box_top),
             ("box, BDF2", pinned + ["-msim_integrator", "bdf2"] + box, VZ, box_top),
             ("sphere, Newton", ball + euler, SPHERE_VZ, sphere_top),
             ("plane, Newton", free + euler + ["-msim_contact_plane", f"0,0,1,{PLANE_Z}"], VZ, plane_top),
             ("closed OBJ box, Newton", pinned + euler + ["-msim_contact_mesh", box_obj], VZ, box_top),
             ("closed OBJ box at thickness 5 mm, Newton", pinned + euler + ["-msim_contact_mesh", box_obj, "-msim_contact_thickness", str(SHELL)], VZ, shell_top),
             ("open OBJ square, Newton", pinned + euler + ["-msim_contact_mesh", sheet_obj], VZ, box_top),
             ("open OBJ square from 28 cm, Newton", zero_g + euler + ["-msim_contact_mesh", far_obj], SPHERE_VZ, far_top),
             ("open OBJ square from 28 cm at thickness 5 mm, Newton", zero_g + euler + ["-msim_contact_mesh", far_obj, "-msim_contact_thickness", str(SHELL)], SPHERE_VZ, far_shell_top))
    for np_ in mt.ranks():
        for label, args, vz, top in cases:
            out, mon = os.path.join(tmp, f"out_{np_}"), os.path.join(tmp, f"m_{np_}.csv")
            r = mt.run(exe, base + args + ["-msim_contact_velocity", f"0,0,{vz}", "-msim_output", out, "-msim_output_every", "1", "-msim_monitor_csv", mon], np_)
            if not check(r.returncode == 0, f"np {np_}: {label} rising {vz * DT * 100:.3g} cm a step through the cloth: runs ({r.stderr.strip()[-300:]})"):
                continue
            fz = [float(row["contact_fz"]) for row in mt.read_csv(mon)[1:]]
            check(len(fz) == STEPS and min(fz) > 0, f"np {np_}: {label}: the contact force pushes the cloth up at every step (fz {', '.join(f'{f:.3g}' for f in fz)} N)")
            # the vertices over it at the start (the 9 in the middle; every vertex for the plane),
            # wherever they are over it: those beside it (the pinned cloth draped down its sides)
            # may swing under it once it has risen above them, the contact being per vertex
            series = vtu.read_pvd(os.path.join(out, "series.pvd"))
            least, start = math.inf, None
            for t, path in series:
                over, height = top(vtu.read_vtu(path)["points"], t, vz)
                start = over if start is None else start
                if (over & start).any():
                    least = min(least, float(height[over & start].min()))
            check(len(series) == STEPS + 1 and least > 0, f"np {np_}: {label}: the {start.sum()} vertices over it at the start are above its top wherever over it, in all {len(series)} frames (least height {least:.3g} m)")
        # a static ceiling 10 cm up, over the box: the box carries the cloth's middle up to it by
        # the third step, where no start outside both exists (the box passed through cloth and
        # ceiling, exit 0)
        # a ceiling 5 mm thick or an open OBJ square there: carried through it in that step (no
        # vertex inside at its end, exit 0 with the cloth above the ceiling)
        ceiling = ",".join(map(str, BOX + (0.2, 0.8, 0.2, 0.8, 0.1, 0.3)))
        thin = ",".join(map(str, BOX + (0.2, 0.8, 0.2, 0.8, 0.1, 0.105)))
        # the line names the vertex and both obstacles, and no smaller -msim_dt: the carry keeps
        # the vertex's distance to the box whatever the step; the vertex is the first over the box
        # in input order (row 3, column 3 of 9) at every rank count
        squeezed = ["vertex 30 is squeezed between obstacles 0 (-msim_contact_box), which carries it, and 1 (-msim_contact_box) at t = 0.06 s", "whatever the step"]
        mesh_squeezed = [squeezed[0].replace("1 (-msim_contact_box)", "1 (-msim_contact_mesh)"), squeezed[1]]
        mt.refusals(check, exe, base, (("the box carrying the cloth into a static ceiling", pinned + euler + ["-msim_contact_box", ceiling, "-msim_contact_velocity", f"0,0,{VZ},0,0,0"], squeezed),
                                       ("the box carrying the cloth through a 5 mm ceiling", pinned + euler + ["-msim_contact_box", thin, "-msim_contact_velocity", f"0,0,{VZ},0,0,0"], squeezed),
                                       ("the box carrying the cloth through an open OBJ ceiling", pinned + euler + box + ["-msim_contact_mesh", ceiling_obj, "-msim_contact_velocity", f"0,0,{VZ},0,0,0"], mesh_squeezed)), np_)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
