#!/usr/bin/env python3
"""Self-contact (-msim_self_contact, msim/self_contact.h), checked by an independent numpy test of
every frame (runs/tools/intersections.py: segment-triangle tests over every pair of triangles that
share no vertex; no msim code):
- the scene: a 21 x 21 cloth (1 m) standing on its edge on the plane y >= -0.01 with friction,
  falling under gravity -y (perturbed 1 cm out of its plane so that it buckles), crumples onto
  itself; without the feature its surface passes through itself (pairs > 0 in some frame; run at
  1 rank: at more, the halo check below shows the same run failing where the fold crosses ranks);
- with it, zero intersecting pairs in every frame for Newton (PSD Hessian, CG; at several ranks
  with ICC on the Jacobi blocks), PD and L-BFGS (at 3 ranks Newton alone), and at 1 rank for
  PETSc's VI Newton with the plane held as bounds (every frame);
- PD with Anderson acceleration (1 and 2 ranks), BDF2 on a 13 x 13 cloth over 50 steps: no
  intersecting pair in any frame. Its mixed iterate combines earlier ones, so it can lie past a
  barrier where Phi is lower again: it is taken only where CCD clears the way to it (before, one
  edge passed through a triangle from step 42 on);
- 2 ranks agree with one: Newton on the exact direct solve (MUMPS), converged each step, gives
  the same final positions to 1e-6 m (the same minimizations; only roundoff differs; 3 ranks
  against 1: tests/self_contact_ranks.py);
- the halo (ranks > 1): with -msim_self_contact_halo 0 (other ranks' elements left out, a switch
  for this test only) the same run has intersecting pairs where the fold crosses the partition;
  with the halo, none;
- explicit integrators refuse -msim_self_contact in one line naming it.
Usage: self_contact.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import msimtest as mt

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "runs", "tools"))
import intersections  # noqa: E402
import vtu  # noqa: E402

# FOLD's cloth at 13 x 13 over 50 steps with BDF2 and PD + Anderson (examples/cloth_fold.opts with
# the README's BDF2 + PD choice): there a mixed iterate that CCD had not checked crossed
ANDERSON = ["-msim_cloth_n", "13", "-msim_fix", "none", "-msim_gravity", "0,-9.81,0", "-msim_perturb", "0.01", "-msim_dt", "0.02",
            "-msim_steps", "50", "-msim_contact_plane", "0,1,0,-0.01", "-msim_friction", "0.5", "-msim_self_contact",
            "-msim_integrator", "bdf2", "-snes_type", "pd", "-snes_pd_anderson", "5", "-snes_max_it", "30", "-snes_pd_fixed"]
FOLD = ["-msim_cloth_n", "21", "-msim_fix", "none", "-msim_gravity", "0,-9.81,0", "-msim_perturb", "0.01",
        "-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-msim_steps", "35",
        "-msim_contact_plane", "0,1,0,-0.01", "-msim_friction", "0.5"]


def pairs_per_frame(out):
    counts = []
    for _, path in vtu.read_pvd(os.path.join(out, "series.pvd")):
        x = vtu.read_vtu(path)["points"]
        counts.append(intersections.intersecting_pairs(x, intersections.cloth_triangles(len(x))))
    return counts


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_self_contact_")
    for np_ in mt.ranks():
        # Newton-CG with msim's default PC at every rank count (block Jacobi's blocks get ICC, whose
        # positive-definite shift the contact blocks need: implicit.cpp's BlockJacobiICC)
        solvers = {"newton": [], "pd": ["-snes_type", "pd", "-snes_max_it", "50"], "lbfgs": ["-snes_type", "qn"]}
        if np_ > 2:  # PD's and L-BFGS's parallel paths are 2 ranks' too; 3 ranks add the partitions' halos, which Newton, the halo check and the direct comparison see
            solvers = {"newton": []}
        if np_ == 1:
            out = os.path.join(tmp, f"off_{np_}")
            r = mt.run(exe, FOLD + ["-msim_output", out, "-msim_output_every", "5"], np_)
            if check(r.returncode == 0, f"np {np_}: the fold without self-contact runs ({r.stderr.strip()[-300:]})"):
                counts = pairs_per_frame(out)
                check(max(counts) > 0, f"np {np_}: without self-contact the cloth passes through itself (intersecting pairs per frame {counts})")
        for name, extra in solvers.items():
            out = os.path.join(tmp, f"{name}_{np_}")
            r = mt.run(exe, FOLD + extra + ["-msim_self_contact", "-msim_output", out, "-msim_output_every", "5"], np_)
            if not check(r.returncode == 0, f"np {np_}: {name} with self-contact runs ({r.stderr.strip()[-300:]})"):
                continue
            counts = pairs_per_frame(out)
            check(len(counts) == 8 and max(counts) == 0, f"np {np_}: {name} with self-contact: no intersecting pair in any of {len(counts)} frames ({counts})")
        if np_ <= 2:
            out = os.path.join(tmp, f"anderson_{np_}")
            r = mt.run(exe, ANDERSON + ["-msim_output", out, "-msim_output_every", "5"], np_)
            if check(r.returncode == 0, f"np {np_}: PD + Anderson with self-contact runs ({r.stderr.strip()[-300:]})"):
                counts = pairs_per_frame(out)
                check(len(counts) == 11 and max(counts) == 0, f"np {np_}: PD + Anderson with self-contact: no intersecting pair in any of {len(counts)} frames ({counts})")
        if np_ == 1:
            assert FOLD[-2] == "-msim_friction"
            # the plane held as VI bounds (-msim_contact_bounds): PETSc's VI search projects its
            # trial points onto the bounds, off the segment the barrier's pre-check cleared, and the
            # fold crossed itself (2 pairs from step 26) until the step it took was checked again
            out = os.path.join(tmp, f"bounds_{np_}")
            r = mt.run(exe, FOLD[:-2] + ["-msim_self_contact", "-msim_contact_bounds", "-msim_friction", "0.3", "-msim_output", out, "-msim_output_every", "1"], np_)
            if check(r.returncode == 0, f"np {np_}: self-contact with the plane as VI bounds runs ({r.stderr.strip()[-300:]})"):
                counts = pairs_per_frame(out)
                check(len(counts) == 36 and max(counts) == 0, f"np {np_}: self-contact with the plane as VI bounds: no intersecting pair in any of {len(counts)} frames ({counts})")
        if np_ > 1:
            out = os.path.join(tmp, f"nohalo_{np_}")
            r = mt.run(exe, FOLD + ["-msim_self_contact", "-msim_self_contact_halo", "0", "-msim_output", out, "-msim_output_every", "5"], np_)
            counts = pairs_per_frame(out) if r.returncode == 0 else []
            check(r.returncode == 0 and max(counts) > 0, f"np {np_}: without the halo the fold across ranks is missed (pairs per frame {counts}, exit {r.returncode}): the halo test can fail")
        if np_ == 2:  # 3 ranks against 1: tests/self_contact_ranks.py (the mesh paths, the same barrier and halo)
            # np_ ranks agree with one: converged exact-direct Newton, the first 20 steps (into the fold)
            direct = ["-msim_steps", "20", "-msim_self_contact", "-snes_max_it", "200", "-ksp_type", "preonly", "-pc_type", "cholesky",
                      "-pc_factor_mat_solver_type", "mumps"]
            args = FOLD + direct
            x1, _ = mt.final_positions(exe, args, 1, tmp, name="direct")
            xn, _ = mt.final_positions(exe, args, np_, tmp, name="direct")
            if check(x1 is not None and xn is not None, f"np {np_}: converged direct Newton with self-contact runs"):
                diff = float(abs(x1 - xn).max())
                check(diff < 1e-6, f"np {np_}: final positions equal those of 1 rank (max difference {diff:.2e} m < 1e-6)")
        # explicit integrators refuse it
        for integ in ("symplectic_euler", "rk4"):
            r = mt.run(exe, ["-msim_cloth_n", "5", "-msim_integrator", integ, "-msim_steps", "2", "-msim_self_contact"], np_)
            lines = [l for l in mt.lines(r.stderr) if "-msim_self_contact" in l]
            check(r.returncode != 0 and len(lines) == 1, f"np {np_}: -msim_integrator {integ} refuses -msim_self_contact in one line ({lines})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
