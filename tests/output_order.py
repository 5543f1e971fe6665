#!/usr/bin/env python3
"""The cells and springs of every series come in the scene's own order at any rank count, so that a
series restarted at another rank count stays right:
- at 1, 2 and 3 ranks, the HDF5 series' mesh.h5 holds the same `cells` and `springs` datasets, the
  .vtu series the same cells in every piece, and every frame the same per-cell `volume_ratio` and
  `strain` (to the roundoff the rank counts' solves differ by), for the bunny tetrahedralized by
  TetGen, a Gmsh tet file refined once (the children follow their parent) and the bunny as a surface
  with bending springs (cells spread by their first vertex and springs found at their lower end's
  rank; the bending springs after the edges);
- a tet series written at 2 ranks to a checkpoint and continued at 1 rank (which rewrites mesh.h5):
  every frame's volume_ratio, those before the checkpoint too, is V/V0 of mesh.h5's cells at that
  frame's positions (V0 at frame 0's, the rest state);
- a restart from an earlier checkpoint with another -msim_output_every: one note names the frames
  of the abandoned run that leave series.pvd and are not written again, whose files stay; a restart
  with the other -msim_output_format in the same directory is refused in one line naming the
  format to give, and writes nothing there.
Usage: output_order.py path/to/msim [--no-tetgen]"""
import os
import shutil
import sys
import tempfile

import numpy as np

import msimtest as mt
import frame_fields as ff  # the series readers

MSIM = mt.msim_path()
check = mt.Checks()
BUNNY = os.path.join(mt.ROOT, "examples", "meshes", "bunny.off")
CUBE5 = os.path.join(mt.ROOT, "tests", "data", "meshes", "cube5.msh")
STEP = ["-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"]


def h5(path, name):
    import h5py
    with h5py.File(path, "r") as f:
        return f[name][:]


def write(args, np_, out, fmt):
    r = mt.run(MSIM, args + ["-msim_output", out, "-msim_output_format", fmt, "-msim_output_every", "1"], np_)
    check(r.returncode == 0, f"{os.path.basename(out)}: runs" + ("" if r.returncode == 0 else ": " + r.stderr[-800:]))
    return r.returncode == 0


def series(name, args, tmp, cellfield, tol):
    """the scene at 1, 2, 3 ranks in both formats: topology equal, per-cell fields equal to tol"""
    got = {}
    for np_ in (1, 2, 3):
        h, v = os.path.join(tmp, f"{name}_h5_{np_}"), os.path.join(tmp, f"{name}_vtu_{np_}")
        if not (write(args, np_, h, "hdf5") and write(args, np_, v, "vtu")):
            return
        frames = sorted(f for f in os.listdir(h) if f.startswith("frame_") and f.endswith(".h5"))
        got[np_] = {"cells": h5(os.path.join(h, "mesh.h5"), "cells"), "springs": h5(os.path.join(h, "mesh.h5"), "springs"),
                    "fields": {f: {k: h5(os.path.join(h, f), k) for k in (cellfield, "strain") if k} for f in frames},
                    "vtu": [[p["cells"] for p in pieces] for _, pieces in ff.read_pvd(v)]}
        x = h5(os.path.join(h, frames[-1]), "positions").reshape(-1, 3)
        if cellfield:  # the order is the data's: each value belongs to the cell at its index
            x0 = h5(os.path.join(h, frames[0]), "positions").reshape(-1, 3)
            cells = got[np_]["cells"]
            err = np.abs(got[np_]["fields"][frames[-1]][cellfield].reshape(-1) - ff.tet_volumes(x, cells) / ff.tet_volumes(x0, cells)).max()
            check(err < 1e-10, f"{name} np={np_}: {cellfield} of {frames[-1]} is V/V0 of mesh.h5's cells (max error {err:.1e})")
    one = got[1]
    for np_ in (2, 3):
        g = got[np_]
        check(np.array_equal(g["cells"], one["cells"]) and np.array_equal(g["springs"], one["springs"]),
              f"{name} np={np_}: mesh.h5's {len(one['cells'])} cells and {len(one['springs'])} springs as at 1 rank, in the same order")
        check(len(g["vtu"]) == len(one["vtu"]) and all(len(a) == len(b) and all(np.array_equal(p, q) for p, q in zip(a, b)) for a, b in zip(g["vtu"], one["vtu"])),
              f"{name} np={np_}: every .vtu piece's cells as at 1 rank, in the same order")
        err = max(np.abs(g["fields"][f][k] - one["fields"][f][k]).max() for f in one["fields"] for k in one["fields"][f]) \
            if g["fields"].keys() == one["fields"].keys() else np.inf
        check(err < tol, f"{name} np={np_}: every frame's per-cell fields as at 1 rank, cell by cell (max difference {err:.1e}, below {tol:g})")


def restart(tmp):
    """written at 2 ranks to step 4 and continued at 1 rank to step 6: every frame against mesh.h5"""
    out, ck = os.path.join(tmp, "restart"), os.path.join(tmp, "restart.ck")
    args = ["-msim_scene", "tet", "-msim_mesh_file", BUNNY, "-msim_mesh_scale", "0.01", "-msim_fix_plane", "y_max", "-msim_gravity", "0,-30,0",
            "-msim_young", "1e4", "-msim_density", "1000"] + STEP + ["-msim_checkpoint", ck]
    if not (write(args + ["-msim_steps", "4"], 2, out, "hdf5") and write(args + ["-msim_steps", "6", "-msim_restart", ck], 1, out, "hdf5")):
        return
    cells = h5(os.path.join(out, "mesh.h5"), "cells")
    V0 = ff.tet_volumes(h5(os.path.join(out, "frame_000000.h5"), "positions").reshape(-1, 3), cells)
    errs, spread = [], 0.0
    for k in range(7):
        f = os.path.join(out, f"frame_{k:06d}.h5")
        r = h5(f, "volume_ratio").reshape(-1)
        errs.append(np.abs(r - ff.tet_volumes(h5(f, "positions").reshape(-1, 3), cells) / V0).max())
        spread = max(spread, r.max() - r.min())
    check(max(errs) < 1e-10 and spread > 1e-4,
          f"restart 2 -> 1 rank: every frame's volume_ratio is V/V0 of mesh.h5's cells (max error by frame {', '.join(f'{e:.1e}' for e in errs)}; ratios spread {spread:.1e})")


def restart_series(tmp):
    out, ck, ck10 = (os.path.join(tmp, n) for n in ("stale", "stale.ck", "stale10.ck"))
    args = ["-msim_scene", "cloth", "-msim_cloth_n", "6", "-msim_integrator", "symplectic_euler", "-msim_dt", "1e-3", "-msim_spectrum_check", "0",
            "-msim_output", out]
    r = mt.run(MSIM, args + ["-msim_steps", "10", "-msim_output_every", "2", "-msim_checkpoint", ck10])
    shutil.copy(ck10, ck)
    r2 = mt.run(MSIM, args + ["-msim_steps", "14", "-msim_output_every", "2", "-msim_checkpoint", ck, "-msim_restart", ck])
    if not check(r.returncode == 0 and r2.returncode == 0, "cloth to step 10, then on to 14, every 2: runs"):
        return
    r = mt.run(MSIM, args + ["-msim_steps", "15", "-msim_output_every", "5", "-msim_restart", ck10])
    notes = [l for l in mt.lines(r.stderr) if l.startswith("msim: note:")]
    check(r.returncode == 0 and len(notes) == 1 and "frame_000012, frame_000014," in notes[0] and "stay on disk" in notes[0],
          f"restart from step 10 every 5: one note names frames 12 and 14 ({notes})")
    check(mt.frames(out) == [f"frame_{k:06d}.vtu" for k in (0, 2, 4, 6, 8, 10, 15)] and all(os.path.exists(os.path.join(out, f"frame_{k:06d}.vtu")) for k in (12, 14)),
          f"series.pvd lists frames 0-10 and 15 ({mt.frames(out)}); the files of 12 and 14 stay")
    before = sorted(os.listdir(out))
    r = mt.run(MSIM, args + ["-msim_steps", "20", "-msim_restart", ck10, "-msim_output_format", "hdf5"])
    err = mt.lines(r.stderr)
    check(r.returncode != 0 and len(err) == 1 and "-msim_output_format vtu" in err[0] and sorted(os.listdir(out)) == before,
          f"restart of a .vtu series with -msim_output_format hdf5: refused in one line, nothing written ({err})")


def main():
    tet = ["-msim_scene", "tet", "-msim_mesh_file", BUNNY, "-msim_mesh_scale", "0.01", "-msim_fix_plane", "y_max", "-msim_gravity", "0,-30,0",
           "-msim_young", "1e4", "-msim_density", "1000", "-msim_steps", "2"] + STEP
    refined = ["-msim_scene", "tet", "-msim_mesh_file", CUBE5, "-msim_refine", "1", "-msim_fix_plane", "z_min", "-msim_gravity", "0,0,-30",
               "-msim_steps", "2"] + STEP
    surface = ["-msim_scene", "mesh", "-msim_mesh_file", BUNNY, "-msim_mesh_scale", "0.01", "-msim_springs", "edge,bending", "-msim_fix_plane", "y_max",
               "-msim_integrator", "symplectic_euler", "-msim_dt", "1e-4", "-msim_steps", "2", "-msim_spectrum_check", "0"]
    with tempfile.TemporaryDirectory() as tmp:
        series("cube5 refined", refined, tmp, "volume_ratio", 1e-12)
        series("bunny surface", surface, tmp, None, 1e-12)
        restart_series(tmp)
        if not mt.without_tetgen("output_order.py"):
            series("bunny", tet, tmp, "volume_ratio", 1e-9)
            restart(tmp)
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
