#!/usr/bin/env python3
"""Setup, refinement and output that scale across ranks.
- The unit cube of 5 tets (8 vertices, 18 edges, 16 triangles: (4 T + B) / 2 with B = 12 on its
  surface), refined once: a midpoint on every edge (8 + 18 = 26 vertices), 8 children per tet (40);
  springs: the halves of the old edges (36), 3 new edges in each triangle (48) and the one diagonal
  inside each tet's octahedron (5): 89; at 1, 2, 3 ranks.
- The same final positions (to 1e-11 m) at 1, 2 and 3 ranks, with METIS, PT-Scotch and natural
  partitions, for a refined bunny (-msim_refine 1) and a tet box, 200 explicit steps.
- No rank holds the whole scene: at 3 ranks each rank's owned vertices and springs
  (-msim_partition_view) add up to the scene's and none has more than 60% of them.
- The parallel output (-msim_output_format hdf5: HDF5 frames and an XDMF index, written by every
  rank) reads back, with h5py, to exactly the positions -msim_view_final prints, at 1 and 3 ranks;
  every frame file the XDMF names exists and no temporary file is left.
Usage: scale.py path/to/msim [--no-tetgen]"""
import os
import re
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
TETGEN = "--no-tetgen" not in sys.argv
ROOT = mt.ROOT
CUBE5 = os.path.join(ROOT, "tests", "data", "meshes", "cube5.node")
BUNNY = os.path.join(ROOT, "examples", "meshes", "bunny.off")
check = mt.Checks(quiet=True)


def run(args, np_):
    return mt.run(MSIM, args, np_, cwd=ROOT)


def final_positions(args, np_, tmp):
    return mt.final_positions(MSIM, args, np_, tmp, cwd=ROOT)[0]


def test_refined_cube():
    for np_ in (1, 2, 3):
        r = run(["-msim_scene", "tet", "-msim_mesh_file", CUBE5, "-msim_refine", "1", "-msim_scene_view", "-msim_steps", "1", "-msim_gravity", "0,0,0"], np_)
        m = re.search(r"(\d+) vertices \(\d+ fixed\), (\d+) tets, (\d+) springs", r.stdout)
        got = tuple(int(g) for g in m.groups()) if m else None
        check(got == (26, 40, 89), f"refined cube at {np_} ranks: {got}, want (26, 40, 89)")


def test_same_positions(tmp):
    scenes = {"box": ["-msim_scene", "box", "-msim_box_n", "6,3,3", "-msim_box_size", "0.6,0.3,0.3", "-msim_fix_plane", "x_min", "-msim_young", "1e5", "-msim_density", "1000",
                      "-msim_dt", "2e-5", "-msim_steps", "200", "-msim_spectrum_check", "0"]}
    if TETGEN:
        scenes["refined bunny"] = ["-msim_scene", "tet", "-msim_mesh_file", BUNNY, "-msim_mesh_scale", "0.01", "-msim_refine", "1", "-msim_fix_box", "-1,1,0.09,1,-1,1",
                                   "-msim_gravity", "0,-9.81,0", "-msim_young", "2e4", "-msim_density", "1100", "-msim_dt", "2e-5", "-msim_steps", "200", "-msim_spectrum_check", "0"]
    for name, args in scenes.items():
        ref = final_positions(args, 1, tmp)
        check(ref is not None, f"{name}: runs at 1 rank")
        if ref is None:
            continue
        moved = np.abs(ref - final_positions(args + ["-msim_steps", "1", "-msim_dt", "1e-12"], 1, tmp)).max()
        check(moved > 1e-6, f"{name}: moves ({moved:.1e} m)")
        for np_ in (2, 3):
            for part in ("metis", "ptscotch", "natural"):
                x = final_positions(args + ["-msim_partition", part], np_, tmp)
                d = np.abs(x - ref).max() if x is not None else np.inf
                print(f"{name}: {np_} ranks, {part}: max |x - x(1 rank)| = {d:.1e} m")
                check(d < 1e-11, f"{name} at {np_} ranks with {part} differs by {d:.2e} m")


def test_parts():
    args = ["-msim_scene", "box", "-msim_box_n", "12,12,12", "-msim_partition_view", "-msim_steps", "1", "-msim_spectrum_check", "0"]
    r = run(args, 3)
    head = re.search(r"(\d+) vertices \((\d+) free, (\d+) fixed\), (\d+) tets, (\d+) springs \((\d+) with a free end\)", r.stdout)
    rows = [tuple(map(int, m.groups())) for m in re.finditer(r"^\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)\s+(\d+)$", r.stdout, re.M)]
    check(head is not None and len(rows) == 3, f"partition view at 3 ranks: {r.stdout[-800:]} {r.stderr[-500:]}")
    if head and len(rows) == 3:
        free, springs = int(head.group(2)), int(head.group(6))
        owned = [row[1] for row in rows]
        owned_springs = [row[3] for row in rows]
        check(sum(owned) == free, f"owned vertices {owned} add up to {sum(owned)}, not {free}")
        check(sum(owned_springs) == springs, f"owned springs {owned_springs} add up to {sum(owned_springs)}, not {springs}")
        check(max(owned) < 0.6 * free and max(owned_springs) < 0.6 * springs, f"a rank holds most of the scene: {owned} of {free}, {owned_springs} of {springs}")


def test_parallel_output(tmp):
    import h5py
    scene = ["-msim_scene", "box", "-msim_box_n", "5,3,3", "-msim_box_size", "0.5,0.3,0.3", "-msim_fix_plane", "x_min", "-msim_young", "1e5", "-msim_density", "1000",
             "-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "6"]
    for np_ in (1, 3):
        out = os.path.join(tmp, f"h5_{np_}")
        x = final_positions(scene + ["-msim_output", out, "-msim_output_every", "3", "-msim_output_format", "hdf5"], np_, tmp)
        check(x is not None, f"hdf5 output at {np_} ranks runs")
        if x is None:
            continue
        files = sorted(os.listdir(out))
        check(files == ["frame_000000.h5", "frame_000003.h5", "frame_000006.h5", "mesh.h5", "series.xdmf"], f"files at {np_} ranks: {files}")
        named = [d.text.split(":")[0] for d in ET.parse(os.path.join(out, "series.xdmf")).getroot().iter("DataItem")]
        check(all(os.path.exists(os.path.join(out, f)) for f in named), f"series.xdmf names missing files: {named}")
        with h5py.File(os.path.join(out, "frame_000006.h5"), "r") as f:
            y = f["positions"][:]
        with h5py.File(os.path.join(out, "mesh.h5"), "r") as f:
            cells, fixed = f["cells"][:], f["fixed"][:].reshape(-1)
        check(y.shape == x.shape and np.array_equal(x, y), f"frame 6 at {np_} ranks differs from -msim_view_final by {np.abs(x - y).max() if y.shape == x.shape else 'shape'}")
        check(cells.shape == (6 * 5 * 3 * 3, 4) and cells.min() == 0 and cells.max() == len(x) - 1, f"cells {cells.shape} at {np_} ranks")
        check(int(fixed.sum()) == 4 * 4 and np.all(x[fixed == 1][:, 0] == 0), f"fixed flags at {np_} ranks: {int(fixed.sum())} set")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        test_refined_cube()
        test_parts()
        test_parallel_output(tmp)
        test_same_positions(tmp)
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
