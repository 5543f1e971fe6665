#!/usr/bin/env python3
"""Friction between surfaces in self-contact under IPC's lag iterations
(-msim_friction_lag_iterations, src/implicit/terms/self_friction.cpp's lag): each step solved again
with the pairs, normals and normal forces taken at the previous solve's result until they stop
changing. At the rank count given, a small square sheet (0.2 m, 4 free vertices) dropped 4 mm onto
a large fixed sheet (2 x 1 m), both one surface mesh, under gravity tilted by 0.3 rad (the large
sheet is an incline), mu 0.4 > tan 0.3, self-contact distance 1 mm:
- it sticks where it lands: its mean x after 0.4 s at a step of 0.02 s is within 0.3 mm of that at
  0.001 s (1.43 mm down the slope there; 1.36 mm at 0.02 s). Lagged at the step's start alone the
  landing step has no friction (the pairs are beyond the contact distance at its start), and the
  sheet slid 4.33 mm at 0.02 s (checked too, so that the scene tells the lag from none);
- BDF2 with PD-10 and lag iterations, checkpointed at step 10 in contact and restarted to 20,
  ends bit for bit as the uninterrupted run (a step's lag starts afresh from its x_n);
- the option is refused without friction to act on (no -msim_friction), and accepted with
  self-friction alone (no obstacle): before, it was refused where there was no obstacle.
Usage: self_friction_lag.py path/to/msim [--np N]"""
import math
import os
import sys
import tempfile

import msimtest as mt

THETA, G, DROP = 0.3, 9.81, 0.004
BIG = [(0, 0, 0), (2, 0, 0), (2, 1, 0), (0, 1, 0)]  # fixed, z = 0
SMALL = [(0.6, 0.05, DROP), (0.8, 0.05, DROP), (0.8, 0.25, DROP), (0.6, 0.25, DROP)]  # free
TRIS = [(0, 1, 2), (0, 2, 3), (4, 5, 6), (4, 6, 7)]


def write_off(path):
    with open(path, "w") as f:
        f.write(f"OFF\n{len(BIG) + len(SMALL)} {len(TRIS)} 0\n")
        for p in BIG + SMALL:
            f.write(" ".join(repr(float(c)) for c in p) + "\n")
        for t in TRIS:
            f.write("3 " + " ".join(str(i) for i in t) + "\n")


def scene(off, lag):
    return ["-msim_scene", "mesh", "-msim_mesh_file", off, "-msim_mass", "1", "-msim_fix_box", "-1,3,-1,2,-1e-6,1e-6",
            "-msim_self_contact", "-msim_self_contact_distance", "0.001", "-msim_gravity", f"{G * math.sin(THETA)},0,{-G * math.cos(THETA)}",
            "-msim_integrator", "implicit_euler", "-msim_friction", "0.4", "-msim_friction_lag_iterations", str(lag)]


def moved(p):
    """the small sheet's mean x displacement (the positions in the mesh file's order)"""
    start = sum(q[0] for q in SMALL) / len(SMALL)
    return float(p[len(BIG):, 0].mean()) - start


def main():
    exe, check = mt.msim_path(), mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        off = os.path.join(tmp, "sheets.off")
        write_off(off)
        for np_ in mt.ranks():
            x = {}
            for dt, lag in ((0.001, 10), (0.02, 10), (0.02, 1)):
                p, _ = mt.final_positions(exe, scene(off, lag) + ["-msim_dt", str(dt), "-msim_steps", str(int(round(0.4 / dt)))], np_, tmp, name=f"land{dt}_{lag}")
                if not check(p is not None and len(p) == len(BIG) + len(SMALL), f"np {np_}: the landing sheet runs at dt {dt}, {lag} lag solves at most"):
                    return check.exit_code()
                x[dt, lag] = moved(p)
            ref = x[0.001, 10]
            check(abs(x[0.02, 10] - ref) < 3e-4, f"np {np_}: with lag iterations the sheet sticks where it lands: {1e3 * x[0.02, 10]:.2f} mm down the slope at dt 0.02, {1e3 * ref:.2f} mm at 0.001 (within 0.3 mm)")
            check(abs(x[0.02, 1] - ref) > 1e-3, f"np {np_}: the scene tells the lag from none: lagged at the step's start alone it slides {1e3 * x[0.02, 1]:.2f} mm at dt 0.02 (more than 1 mm from {1e3 * ref:.2f})")
            # BDF2 with PD-10: its history in the checkpoint; the lag starts afresh each step
            s = scene(off, 10) + ["-msim_dt", "0.02", "-msim_integrator", "bdf2", "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"]
            ref_bin, rs_bin, ck = (os.path.join(tmp, f"{n}_{np_}") for n in ("ref.bin", "rs.bin", "run.ck"))
            runs = [mt.run(exe, s + ["-msim_steps", "20", "-msim_view_final", f"binary:{ref_bin}"], np_, cwd=tmp),
                    mt.run(exe, s + ["-msim_steps", "10", "-msim_checkpoint", ck, "-msim_checkpoint_every", "10"], np_, cwd=tmp),
                    mt.run(exe, s + ["-msim_steps", "20", "-msim_restart", ck, "-msim_view_final", f"binary:{rs_bin}"], np_, cwd=tmp)]
            if check(all(r.returncode == 0 for r in runs), f"np {np_}: bdf2 + PD with self-friction's lag iterations, checkpointed at step 10 and restarted, runs ({''.join(r.stderr for r in runs)[-600:]})"):
                check(mt.read_binary_vec(rs_bin) == mt.read_binary_vec(ref_bin), f"np {np_}: restarted at step 10, it ends bit for bit as the uninterrupted run")
            # the option needs friction to act on: refused in one line without it
            r = mt.run(exe, [a for a in scene(off, 10) if a not in ("-msim_friction", "0.4")] + ["-msim_dt", "0.02", "-msim_steps", "2"], np_, cwd=tmp)
            lines = mt.lines(r.stderr)
            check(r.returncode != 0 and len(lines) == 1 and "-msim_friction_lag_iterations acts on friction" in lines[0],
                  f"np {np_}: without -msim_friction the lag option is refused in one line ({lines})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
