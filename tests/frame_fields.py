#!/usr/bin/env python3
"""The fields in every frame (-msim_output), read back from both series formats and checked against
values this script computes itself from the frames' positions and an independent rest state:
- `file_id` (point data): the input ids 0..nv-1 for generated scenes; for a mesh file, the file's
  node at that id (read here from the file) is the vertex's rest position, also for a Gmsh file
  with nodes on no tet (dropped by the reader: the file ids are then the nodes the tets name);
- `velocity` (point data): symplectic and implicit Euler both end a step with v_n = (x_n - x_{n-1})/h,
  so every frame's velocity is the backward difference of two consecutive frames' positions (to
  roundoff); at t = 0 it is 0, and the fixed vertices move with -msim_fix_velocity;
- `strain` (cell data on the springs, l/L - 1): the rest lengths L are the spring ends' distances in
  the frame 0 of the same scene unstretched (-msim_prestretch 1, no perturbation); at t = 0 with
  -msim_prestretch p every spring's strain is p - 1;
- `volume_ratio` (cell data on tets, V/V0 with signed volumes): V0 from the same rest frame; p^3 at
  t = 0; negative for the tets a large -msim_perturb inverts;
- the springs drawn: a cloth's are the cells (structural 2n(n-1), shear 2(n-1)^2, bending 2n(n-2)),
  a tet mesh's are a second piece (part 1 of each .pvd timestep, the grid "springs" of each XDMF
  frame) holding exactly the tets' unique edges;
- the HDF5/XDMF series holds the same values as the .vtu series (to roundoff), and every dataset
  series.xdmf names exists with the dimensions it states.
Each scene runs at every rank count given (default 1 and 2). The .vtu files are parsed here (raw
appended binary, UInt64 headers); the HDF5 files with h5py.
Usage: frame_fields.py path/to/msim [--np N]"""
import os
import re
import struct
import sys
import tempfile
import xml.etree.ElementTree as ET

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
MESHES = os.path.join(mt.ROOT, "tests", "data", "meshes")
check = mt.Checks()
DTYPES = {"Float64": np.float64, "Int64": np.int64, "UInt8": np.uint8}


# ---------------------------------------------------------------- reading the series

def read_vtu(path):
    """{'points': (n,3), 'cells': (m,k), 'point': {name: array}, 'cell': {name: array}}"""
    with open(path, "rb") as f:
        data = f.read()
    start = data.index(b"_", data.index(b"<AppendedData")) + 1
    header = data[:start].decode("latin-1")

    def arrays(section):
        m = re.search(rf"<{section}>(.*?)</{section}>", header, re.S)
        found = {}
        for a in re.finditer(r'<DataArray type="(\w+)"(?: Name="(\w+)")?(?: NumberOfComponents="(\d+)")? format="appended" offset="(\d+)"/>', m.group(1) if m else ""):
            pos = start + int(a.group(4))
            (nbytes,) = struct.unpack("<Q", data[pos:pos + 8])
            arr = np.frombuffer(data[pos + 8:pos + 8 + nbytes], dtype=DTYPES[a.group(1)])
            ncomp = int(a.group(3) or 1)
            found[a.group(2) or "points"] = arr.reshape(-1, ncomp) if ncomp > 1 else arr
        return found

    cells = arrays("Cells")
    sizes = np.diff(np.concatenate([[0], cells["offsets"]]))
    k = int(sizes[0])
    assert (sizes == k).all(), f"{path}: cells of mixed sizes"
    return {"points": arrays("Points")["points"], "cells": cells["connectivity"].reshape(-1, k),
            "point": arrays("PointData"), "cell": arrays("CellData")}


def read_pvd(out):
    """[(time, [piece dict by part])]"""
    frames = {}
    for d in ET.parse(os.path.join(out, "series.pvd")).getroot().iter("DataSet"):
        frames.setdefault(float(d.get("timestep")), {})[int(d.get("part"))] = read_vtu(os.path.join(out, d.get("file")))
    return [(t, [parts[p] for p in sorted(parts)]) for t, parts in sorted(frames.items())]


def read_xdmf(out, problems):
    """the same from series.xdmf and its HDF5 files; every DataItem's dataset must exist with the
    dimensions the XDMF states (else a line in problems)"""
    import h5py

    def item(d):
        file, name = d.text.strip().split(":")
        with h5py.File(os.path.join(out, file), "r") as f:
            if name not in f:
                problems.append(f"{file}:{name} missing")
                return None
            arr = f[name][:]
        dims = tuple(int(x) for x in d.get("Dimensions").split())
        if arr.size != int(np.prod(dims)):
            problems.append(f"{file}:{name} has shape {arr.shape}, the XDMF says {dims}")
        return arr.reshape(dims) if arr.size == int(np.prod(dims)) else arr

    def piece(g):
        p = {"cells": item(g.find("Topology/DataItem")), "points": item(g.find("Geometry/DataItem")), "point": {}, "cell": {}}
        for a in g.findall("Attribute"):
            v = item(a.find("DataItem"))
            p["point" if a.get("Center") == "Node" else "cell"][a.get("Name")] = v.reshape(-1) if a.get("AttributeType") == "Scalar" else v
        return p

    root = ET.parse(os.path.join(out, "series.xdmf")).getroot()
    series = root.find("Domain/Grid")
    frames = []
    for g in series.findall("Grid"):
        t = float(g.find("Time").get("Value"))
        pieces = [piece(g)] if g.get("GridType") == "Uniform" else [piece(c) for c in g.findall("Grid")]
        frames.append((t, pieces))
    return frames


def normalize(pieces):
    """one frame's pieces as {points, fixed, file_id, velocity, cells, k, springs, strain, ratio}"""
    p0 = pieces[0]
    f = {"points": p0["points"], "cells": p0["cells"], "fixed": p0["point"].get("fixed"), "file_id": p0["point"].get("file_id"),
         "velocity": p0["point"].get("velocity"), "ratio": p0["cell"].get("volume_ratio"), "npieces": len(pieces)}
    lines = p0 if p0["cells"].shape[1] == 2 else (pieces[1] if len(pieces) > 1 else None)
    f["springs"] = lines["cells"] if lines is not None else None
    f["strain"] = lines["cell"].get("strain") if lines is not None else None
    if len(pieces) > 1:  # the springs piece draws the same points and point fields
        f["same_points"] = all(np.array_equal(pieces[1][key], p0[key]) for key in ("points",)) and \
            all(np.array_equal(pieces[1]["point"].get(n), p0["point"].get(n)) for n in ("fixed", "file_id", "velocity"))
    return f


# ---------------------------------------------------------------- independent values

def tet_volumes(x, tets):
    a, b, c, d = (x[tets[:, q]] for q in range(4))
    return np.einsum("ij,ij->i", b - a, np.cross(c - a, d - a)) / 6.0


def lengths(x, springs):
    return np.linalg.norm(x[springs[:, 1]] - x[springs[:, 0]], axis=1)


def gmsh22_nodes(path):
    """node coordinates of an ASCII Gmsh 2.2 file in file order (ids from 0 in the order listed)"""
    with open(path) as f:
        text = f.read().split("$Nodes")[1].split("$EndNodes")[0].split("\n")
    n = int(text[1])
    return np.array([[float(v) for v in line.split()[1:4]] for line in text[2:2 + n]])


# cube5.msh with two nodes on no tet (a Gmsh model's points carry such nodes): the reader drops them,
# the others keep their ids in the file
DROPPED_MSH = """$MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
10
1 5 5 5
2 0 0 0
3 1 0 0
4 0 1 0
5 1 1 0
6 7 7 7
7 0 0 1
8 1 0 1
9 0 1 1
10 1 1 1
$EndNodes
$Elements
6
1 15 2 0 1 1
2 4 2 1 1 2 3 4 7
3 4 2 1 1 5 4 3 10
4 4 2 1 1 8 3 7 10
5 4 2 1 1 9 7 4 10
6 4 2 1 1 3 4 7 10
$EndElements
"""
DROPPED_USED = [1, 2, 3, 4, 6, 7, 8, 9]  # the nodes the tets name, from 0


def off_vertices(path):
    rows = [l.split("#")[0].split() for l in open(path)]
    rows = [r for r in rows if r]
    nv = int(rows[1][0])
    return np.array([[float(v) for v in r[:3]] for r in rows[2:2 + nv]])


# ---------------------------------------------------------------- one scene

def series(args, np_, tmp, name, fmt):
    out = os.path.join(tmp, f"{name}_{fmt}_{np_}")
    r = mt.run(MSIM, args + ["-msim_output", out, "-msim_output_format", fmt], np_)
    if not check(r.returncode == 0, f"{name} np={np_} {fmt}: runs"):
        print(r.stderr[-1500:])
        return None
    if fmt == "vtu":
        return [(t, normalize(p)) for t, p in read_pvd(out)]
    problems = []
    frames = [(t, normalize(p)) for t, p in read_xdmf(out, problems)]
    check(not problems, f"{name} np={np_} hdf5: every dataset series.xdmf names exists with its dimensions {problems[:3]}")
    return frames


def check_scene(name, args, np_, tmp, p=1.05, fix_velocity=(0.0, 0.0, 0.0), nspring=None, tets=False, file_nodes=None, used=None):
    base = args + ["-msim_output_every", "1", "-msim_fix_velocity", ",".join(str(v) for v in fix_velocity)]
    rest = series(args + ["-msim_steps", "1"], np_, tmp, name + "_rest", "vtu")
    runs = {fmt: series(base + ["-msim_prestretch", str(p)], np_, tmp, name, fmt) for fmt in ("vtu", "hdf5")}
    if rest is None or None in runs.values():
        return
    x0 = rest[0][1]["points"]
    nv = len(x0)
    for fmt, frames in runs.items():
        tag = f"{name} np={np_} {fmt}"
        f0 = frames[0][1]
        springs, cells = f0["springs"], f0["cells"]
        check(all(f["points"].shape == (nv, 3) for _, f in frames) and len(frames) >= 3, f"{tag}: {len(frames)} frames of {nv} points")
        if f0["npieces"] > 1:
            check(all(f["same_points"] for _, f in frames), f"{tag}: the springs piece has the cells' points and point fields")
        # file ids
        fid = f0["file_id"]
        if file_nodes is None:
            check(fid is not None and np.array_equal(fid, np.arange(nv)), f"{tag}: file_id is the input id")
        else:
            ok = fid is not None and fid.min() >= 0 and fid.max() < len(file_nodes)
            check(ok and np.abs(file_nodes[fid] - x0).max() < 1e-12, f"{tag}: file_id names the file's node at each vertex's rest position")
            if used is not None:
                check(ok and sorted(fid) == used, f"{tag}: file_id lists the file's nodes on cells, {used} (got {None if fid is None else list(fid)})")
        # the springs drawn
        if nspring is not None:
            check(springs is not None and len(springs) == nspring, f"{tag}: {None if springs is None else len(springs)} springs drawn, want {nspring}")
        if tets:
            edges = {tuple(sorted(e)) for t in cells for e in ((t[0], t[1]), (t[0], t[2]), (t[0], t[3]), (t[1], t[2]), (t[1], t[3]), (t[2], t[3]))}
            drawn = {tuple(sorted(s)) for s in springs} if springs is not None else set()
            check(f0["npieces"] == 2 and drawn == edges and len(drawn) == len(springs), f"{tag}: the springs piece holds the tets' {len(edges)} unique edges once each")
        L = lengths(x0, springs)
        V0 = tet_volumes(x0, cells) if tets else None
        # t = 0: the prestretch alone
        check(np.abs(f0["strain"] - (p - 1)).max() < 1e-12, f"{tag}: strain at t = 0 is prestretch - 1 = {p - 1:g} (max error {np.abs(f0['strain'] - (p - 1)).max():.1e})")
        if tets:
            check(np.abs(f0["ratio"] - p ** 3).max() < 1e-12, f"{tag}: volume ratio at t = 0 is prestretch^3 = {p ** 3:g}")
        fixed = f0["fixed"].astype(bool)
        v0 = np.where(fixed[:, None], np.array(fix_velocity)[None, :], 0.0)
        check(np.abs(f0["velocity"] - v0).max() == 0, f"{tag}: velocity at t = 0 is 0, the handles' at fixed vertices")
        # every frame: strain, volume ratio and velocity from the positions
        es = er = ev = 0.0
        moved = 0.0
        for (t0, a), (t1, b) in zip(frames, frames[1:]):
            x = b["points"]
            es = max(es, np.abs(b["strain"] - (lengths(x, springs) / L - 1)).max())
            if tets:
                er = max(er, np.abs(b["ratio"] - tet_volumes(x, cells) / V0).max())
            fd = (x - a["points"]) / (t1 - t0)
            ev = max(ev, np.abs(b["velocity"] - fd).max() / max(1.0, np.abs(fd).max()))
            moved = max(moved, np.abs(b["velocity"]).max())
        check(es < 1e-12, f"{tag}: strain = l/L - 1 in every frame (max error {es:.1e})")
        if tets:
            check(er < 1e-10, f"{tag}: volume ratio = V/V0 in every frame (max error {er:.1e})")
        check(moved > 1e-3 and ev < 1e-8, f"{tag}: velocity = backward difference of positions in every frame (max relative error {ev:.1e}, |v| up to {moved:.2g} m/s)")
    # both formats hold the same frames
    a, b = runs["vtu"], runs["hdf5"]
    same = len(a) == len(b) and all(ta == tb and all(np.abs(np.asarray(fa[k], float) - np.asarray(fb[k], float)).max() <= 1e-14
                                                      for k in ("points", "velocity", "strain", "file_id", "fixed") + (("ratio",) if tets else ()))
                                    and np.array_equal(fa["cells"], fb["cells"]) and np.array_equal(fa["springs"], fb["springs"])
                                    for (ta, fa), (tb, fb) in zip(a, b))
    check(same, f"{name} np={np_}: the HDF5 series holds the .vtu series' frames and fields")


def check_inverted(np_, tmp, box):
    """a perturbation larger than the cells inverts some tets: their volume ratio is negative"""
    rest = series(box + ["-msim_steps", "1"], np_, tmp, "box_rest", "vtu")
    for fmt in ("vtu", "hdf5"):
        got = series(box + ["-msim_steps", "1", "-msim_perturb", "0.3"], np_, tmp, "box_inverted", fmt)
        if rest is None or got is None:
            return
        f, x0 = got[0][1], rest[0][1]["points"]
        want = tet_volumes(f["points"], f["cells"]) / tet_volumes(x0, f["cells"])
        check((want < 0).any() and np.abs(f["ratio"] - want).max() < 1e-10,
              f"np={np_} {fmt}: {(f['ratio'] < 0).sum()} of {len(want)} tets inverted, their ratio negative as recomputed (max error {np.abs(f['ratio'] - want).max():.1e})")


def main():
    n = 6
    cloth = ["-msim_scene", "cloth", "-msim_cloth_n", str(n), "-msim_fix", "corners", "-msim_integrator", "symplectic_euler",
             "-msim_dt", "1e-3", "-msim_steps", "4", "-msim_spectrum_check", "0"]
    box = ["-msim_scene", "box", "-msim_box_n", "2,2,2", "-msim_box_size", "0.2,0.2,0.2", "-msim_fix_plane", "z_min", "-msim_young", "1e5",
           "-msim_density", "1000", "-msim_integrator", "implicit_euler", "-msim_dt", "1e-3", "-msim_steps", "4", "-msim_gravity", "0,0,-30"]
    tetfile = ["-msim_scene", "tet", "-msim_mesh_file", os.path.join(MESHES, "cube5.msh"), "-msim_fix_plane", "z_min", "-msim_integrator", "implicit_euler",
               "-msim_dt", "1e-3", "-msim_steps", "3", "-msim_gravity", "0,0,-30"]
    surface = ["-msim_scene", "mesh", "-msim_mesh_file", os.path.join(MESHES, "cube.off"), "-msim_fix_plane", "z_min", "-msim_integrator", "symplectic_euler",
               "-msim_dt", "1e-4", "-msim_steps", "3", "-msim_spectrum_check", "0"]
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            check_scene("cloth", cloth, np_, tmp, fix_velocity=(0.0, 0.0, 0.5), nspring=2 * n * (n - 1) + 2 * (n - 1) ** 2 + 2 * n * (n - 2))
            check_scene("box", box, np_, tmp, fix_velocity=(0.1, 0.0, 0.0), tets=True)
            check_scene("cube5.msh", tetfile, np_, tmp, tets=True, file_nodes=gmsh22_nodes(os.path.join(MESHES, "cube5.msh")))
            dropped = os.path.join(tmp, "dropped.msh")
            with open(dropped, "w") as f:
                f.write(DROPPED_MSH)
            check_scene("dropped.msh", tetfile[:3] + [dropped] + tetfile[4:], np_, tmp, tets=True, file_nodes=gmsh22_nodes(dropped), used=DROPPED_USED)
            check_scene("cube.off", surface, np_, tmp, p=0.98, file_nodes=off_vertices(os.path.join(MESHES, "cube.off")))
            check_inverted(np_, tmp, box)
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
