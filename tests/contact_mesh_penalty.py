#!/usr/bin/env python3
"""The penalty of the explicit integrators and -msim_integrator ts on mesh obstacles, at each rank
count: a heavy cloth (11 x 11, 300 kg, so the landing sinks its vertices centimetres deep, deeper
than the band thickness + dhat within which a mesh decides its side for the barrier) dropped with
symplectic_euler and with ts beuler
- on a closed OBJ cube (12 triangles, written here): the mesh is the surface of the analytic
  -msim_contact_box, so the two runs' penalties are one function (up to roundoff): in every frame
  the least signed distance to the box (computed here) is the analytic run's within 1e-6 m (ts:
  1e-3 m, its Newton iterates taking the mesh's Hessian), and symplectic Euler's frames agree
  within 1e-6 m: the cloth stays on the cube, sunk as deep as the penalty lets it sink into the
  box (once, the vertices deeper than the band had no force and the cloth fell through the cube,
  exit 0);
- on an open sheet (two triangles at z = -0.1, wider than the cloth) with -msim_contact_thickness
  0.01: the landing takes vertices past the sheet's mid-surface, and the penalty pushes each back to
  the side it came from, so the run is the analytic box under the sheet's top face z = -0.09 (the
  same function where the cloth is), within the same tolerances (once, the penalty pushed such a
  vertex out below, towards the nearer side, and the cloth passed through the sheet, exit 0);
- a vertex that enters the shell from farther than the contact distance in one step (dhat 1e-4 m,
  a fall of ~1 mm a step), whose side the penalty cannot know: one error line, exit non-zero;
- that check adds no collective per force evaluation (at 2 ranks and more): it rides on the time
  loop's energy reduction, so 100 more steps of the sheet take as many more MPI reductions
  (-log_view's count) as the analytic box's (it took an allreduce per force evaluation: 120
  against 20).
Usage: contact_mesh_penalty.py path/to/msim [--np N]"""
import os
import re
import sys
import tempfile

import numpy as np

import msimtest as mt

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "runs", "tools"))
import vtu  # noqa: E402

CUBE = [0.2, 0.8, 0.2, 0.8, -0.5, -0.1]
SHEET_Z, THICK = -0.1, 0.01
SHEET_BOX = [-1, 2, -1, 2, -1, SHEET_Z + THICK]  # the shell's top side where the cloth is


def box_distance(p, b):
    """signed distance of points p (n, 3) to the solid box b (negative inside)"""
    lo, hi = np.array(b[0::2]), np.array(b[1::2])
    q = np.maximum(lo - p, p - hi)
    return np.where(q.max(axis=1) > 0, np.linalg.norm(np.maximum(q, 0), axis=1), q.max(axis=1))


def frames(out):
    """the vertex positions of every frame the output directory out holds, in order"""
    return [vtu.read_vtu(path)["points"] for _, path in vtu.read_pvd(os.path.join(out, "series.pvd"))]


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_contact_mesh_penalty_")
    cube_obj = os.path.join(tmp, "cube.obj")
    mt.write_box_obj(cube_obj, CUBE)
    sheet_obj = os.path.join(tmp, "sheet.obj")
    with open(sheet_obj, "w") as f:
        f.write(f"v -1 -1 {SHEET_Z}\nv 2 -1 {SHEET_Z}\nv 2 2 {SHEET_Z}\nv -1 2 {SHEET_Z}\nf 1 2 3\nf 1 3 4\n")
    drop = ["-msim_cloth_n", "11", "-msim_fix", "none", "-msim_mass", "300", "-msim_output_every", "20", "-msim_progress", "0"]
    methods = {"symplectic_euler": ["-msim_integrator", "symplectic_euler", "-msim_dt", "1e-3", "-msim_steps", "600"],
               "ts beuler": ["-msim_integrator", "ts", "-ts_type", "beuler", "-msim_dt", "2e-3", "-msim_steps", "300"]}
    # the penalties are one function, so symplectic Euler's frames agree to roundoff; ts's Newton
    # takes the mesh's Hessian, which a vertex on a face's diagonal edge sees (the analytic box's is
    # 0), so its iterates and substeps differ, the cloth slides off the cube a few cm apart, and its
    # sink agrees within 1e-3 m
    tol = {"symplectic_euler": 1e-6, "ts beuler": 1e-3}
    scenes = {"closed cube": (["-msim_contact_mesh", cube_obj], CUBE),
              "open sheet": (["-msim_contact_mesh", sheet_obj, "-msim_contact_thickness", str(THICK)], SHEET_BOX)}
    for np_ in mt.ranks():
        for mname, margs in methods.items():
            for sname, (sargs, box) in scenes.items():
                runs = {}
                for label, args in (("mesh", sargs), ("box", ["-msim_contact_box", ",".join(map(str, box))])):
                    out = os.path.join(tmp, f"{mname.replace(' ', '_')}_{sname.replace(' ', '_')}_{label}_{np_}")
                    r = mt.run(exe, drop + margs + args + ["-msim_output", out], np_)
                    if check(r.returncode == 0, f"np {np_}: {mname} on the {sname} ({label}): runs ({r.stderr.strip()[-300:]})"):
                        runs[label] = frames(out)
                if len(runs) < 2:
                    continue
                fm, fb = runs["mesh"], runs["box"]
                dm = [float(box_distance(p, box).min()) for p in fm]
                db = [float(box_distance(p, box).min()) for p in fb]
                # the analytic run sinks some centimetres: the case the band alone did not hold
                check(min(db) < -THICK, f"np {np_}: {mname} on the {sname}: the analytic run sinks deeper than {THICK} m (least distance {min(db):.4g})")
                nframe = int(margs[margs.index("-msim_steps") + 1]) // 20 + 1
                if not check(len(fm) == len(fb) == nframe, f"np {np_}: {mname} on the {sname}: {nframe} frames each ({len(fm)}, {len(fb)})"):
                    continue
                gap = max(abs(a - b) for a, b in zip(db, dm))
                check(gap <= tol[mname], f"np {np_}: {mname} on the {sname}: in every frame the least distance to the surface is the analytic run's within {tol[mname]:g} m (mesh {min(dm):.4g}, box {min(db):.4g}, worst frame {gap:.2g} apart)")
                if mname == "symplectic_euler":
                    err = max(float(np.abs(a - b).max()) for a, b in zip(fm, fb))
                    check(err <= 1e-6, f"np {np_}: {mname} on the {sname}: every frame within 1e-6 m of the analytic run's (max difference {err:.2g} m)")
        # a vertex entering the shell from beyond the band in one step: its side is unknown
        r = mt.run(exe, drop + methods["symplectic_euler"] + scenes["open sheet"][0] + ["-msim_contact_distance", "1e-4"], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode != 0 and len(lines) == 1 and "entered the shell" in lines[0] and "cannot tell which side" in lines[0],
              f"np {np_}: a vertex entering the shell from beyond dhat in one step: one error line ({r.stderr.strip()[-400:]})")
        if np_ > 1:
            more = {}
            for label, args in (("sheet", scenes["open sheet"][0]), ("box", ["-msim_contact_box", ",".join(map(str, SHEET_BOX))])):
                n = []
                for steps in (100, 200):
                    r = mt.run(exe, drop[:6] + ["-msim_progress", "0", "-msim_integrator", "symplectic_euler", "-msim_dt", "1e-3", "-msim_steps", str(steps), "-log_view"] + args, np_)
                    m = re.search(r"MPI Reductions:\s+(\S+)", r.stdout)
                    n.append(float(m.group(1)) if r.returncode == 0 and m else float("nan"))
                more[label] = n[1] - n[0]
            check(more["sheet"] == more["box"], f"np {np_}: 100 more steps on the sheet take as many more MPI reductions as on the analytic box ({more['sheet']:g}, {more['box']:g})")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
