#!/usr/bin/env python3
"""Mesh input: every file of the malformed corpus (tests/data/bad) gets one error line naming the
file, the line (where the format has lines) and the fault, a non-zero exit and no output, at 1 and
2 ranks; every valid file (tests/data/meshes, examples/meshes) loads with the counts, volume and
mass derived here, independently of msim:
- a unit cube cut into 5 tets has 8 vertices and 18 edges (12 sides, 6 face diagonals), volume 1;
- a tet mesh of a ball (a closed surface's inside) has Euler characteristic V - E + F - T = 1, and
  with F = (4 T + B) / 2 (B: boundary triangles, those of the surface when TetGen adds no vertex on
  it, switch Y) that is V - E + T + B/2 = 1: a duplicated or missing spring breaks it;
- the bunny tetrahedralizes with msim's default switches to the counts of the tetgen program run
  on the same file (.node, .ele, .edge), twice the same; its tets' volume is the volume its
  surface encloses (divergence theorem, sum over triangles of a . (b x c) / 6); masses add up to
  -msim_mass, or to -msim_density times the volume;
- a surface's edges and bending springs on a regular sheet;
- partitions (-msim_partition_view) of the bunny: the owned vertices of all ranks add up to the
  free ones at 2 and 3 ranks, and METIS cuts at 2 parts far fewer springs (under a quarter) than
  contiguous blocks of TetGen's vertex order.
The corpus runs at 1 rank, and at 2 all but the files ONE_RANK lists (the same code reads them at
any rank count), or with `--np N` at N alone (ctest's mesh_input_corpus_np1 and _np2: the 1-rank
half runs beside other tests).
Usage: mesh_input.py path/to/msim corpus|valid [--no-tetgen] [--np N]"""
import os
import re
import shutil
import subprocess
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
TETGEN = "--no-tetgen" not in sys.argv
HERE = mt.HERE
ROOT = mt.ROOT
BAD = os.path.join(HERE, "data", "bad")
GOOD = os.path.join(HERE, "data", "meshes")
sys.path.insert(0, GOOD)
import make_gmsh_binary as gmsh_binary  # noqa: E402  (its 4.1 binary writer)

# file (in tests/data/bad), scene, what the one error line must say (file and line are added)
CORPUS = [
    ("truncated.ele", "tet", "line 5: the file ends after 3 of 5 tets"),
    ("wrong_count.ele", "tet", "wrong_count.node line 10: more lines than the 7 points"),
    ("index_range.ele", "tet", "line 4: tet 1 names point 9, outside [0, 7]"),
    ("negative_index.ele", "tet", "line 4: tet 1 names point -1, outside [0, 7]"),
    ("nan_coord.ele", "tet", "nan_coord.node line 5: coordinate nan is not finite"),
    ("inf_coord.off", "tet", "line 11: coordinate inf is not finite"),
    ("zero_length.ele", "tet", "line 6: the tet has an edge of zero length: vertices 6 and 7"),
    ("inverted.ele", "tet", "line 7: the tet is inverted"),
    ("zero_volume.ele", "tet", "line 8: the tet has zero volume"),
    ("empty.off", "tet", "empty.off: empty file"),
    ("garbage.stl", "tet", "garbage.stl: not an STL file"),
    ("count_overflow.ele", "tet", "count_overflow.node line 2: point count 3000000000 is too large for this build's 32-bit indices"),
    ("count_huge.ele", "tet", "count_huge.node line 2: point count 99999999999999999999999 is too large"),
    ("crlf_short_vertex.off", "tet", "line 5: vertex 1 needs 3 coordinates, found 2"),
    ("repeated_vertex.ele", "tet", "line 4: the tet uses vertex 2 twice"),
    ("open_surface.off", "tet", "line 12: the surface is not closed"),
    ("self_intersecting.off", "tet", "the surface intersects itself"),
    ("bad_corner.obj", "tet", "line 4: face corner 'abc' is not a vertex id"),
    ("zero_corner.obj", "mesh", "line 4: face corner 0 names no vertex"),
    ("no_header.off", "mesh", "line 1: not an OFF file"),
    ("truncated.stl", "tet", "line 30: the file ends inside a facet"),
    ("garbage.msh", "tet", "garbage.msh line 7: a node (tag, x, y, z) needs 4 values"),
    ("garbage_node.msh", "tet", "garbage_node.msh line 7: a node (tag, x, y, z) needs 4 values"),
    # PETSc's reader never returned on it (runs/fuzz): msim's check of the sections refuses it first
    # an entity's node count cut from 7 to 5, so coordinates are read as tags: PETSc's reader
    # asked for 4 GB (runs/fuzz); msim's ASCII reader finds the short line
    ("node_tags_shifted.msh", "tet", "node_tags_shifted.msh line 406: a node's coordinates"),
    # a physical name with one quote: PETSc's reader copied a negative length (runs/fuzz); the
    # reader msim uses for ASCII files refuses it too
    ("physical_name_unquoted.msh", "tet", "physical_name_unquoted.msh line 6: a physical name must be in double quotes"),
    ("comments_unclosed.msh", "tet", "comments_unclosed.msh line 15: section $Comments has no $EndComments line"),
    # binary Gmsh (made from make_gmsh_binary.py's cube5; PETSc's reader corrupted the heap on
    # malformed binary files, runs/fuzz): offsets counted from the format's layout
    ("binary_truncated.msh", "tet", "binary_truncated.msh byte 183: node count 8 is more than the rest of the file holds"),
    ("binary_count_huge.msh", "tet", "binary_count_huge.msh byte 183: node count 1099511627776 is more than the rest of the file holds"),
    ("binary_byte_order.msh", "tet", "binary_byte_order.msh byte 20: the byte-order mark is 2, not 1"),
    ("binary_missing_node.msh", "tet", "binary_missing_node.msh byte 420: node 9 is not in $Nodes"),
    ("version40.msh", "tet", "version40.msh line 2: an ASCII file of version 2.2 or 4.1 expected here"),
    ("quadratic.ele", "tet", "line 2: 10 nodes per tet"),
    ("nan_binary.stl", "tet", "nan_binary.stl: facet 2 (binary, counting from 0): a coordinate is NaN"),
    # a cell listed twice (in any vertex order) counted its area or volume twice (a surface scene,
    # an obstacle and a tet file ran on); a closed surface with one was called open. Lines and ids
    # as the files are written: a face's line, OBJ ids from 1 made ids from 0, an STL facet's
    # 'facet normal' line, a binary STL's facets counted from 1
    ("repeated_face.obj", "mesh", "line 9: the face repeats line 7: the same vertices 0 1 2 (its area would count twice"),
    ("repeated_face.off", "mesh", "line 18: the face repeats line 17: the same vertices"),
    ("repeated_face.off", "tet", "line 18: the face repeats line 17: the same vertices"),
    ("repeated_facet.stl", "mesh", "line 86: the facet repeats line 2: the same vertices"),
    ("repeated_facet.stl", "tet", "line 86: the facet repeats line 2: the same vertices"),
    ("repeated_facet_binary.stl", "mesh", "repeated_facet_binary.stl: facet 13 (counting from 1) repeats facet 1: the same vertices"),
    ("repeated_tet.ele", "tet", "line 8: the tet repeats line 4: the same vertices 2 1 3 7 (its volume would count twice"),
]
NEEDS_TETGEN = {"open_surface.off", "self_intersecting.off"}  # found while preparing TetGen's input
# left out at 2 ranks: rank 0 alone reads, checks and meshes a file (MSimCallOnRankZero in
# src/scene/tet.cpp and surface.cpp) and hands its one error to every rank, so a reader's fault is
# found by the same code at any rank count; kept at 2 ranks, each reader and each stage of rank 0's
# work through both call sites: TetGen .node/.ele (a line, the .node's count, an index), OFF, STL,
# OBJ, ASCII and binary Gmsh in a tet scene, the mesh check (inverted), the checks of TetGen's
# input (an open surface, one that intersects itself), and OBJ and OFF in a surface scene
ONE_RANK = {"negative_index.ele", "nan_coord.ele", "zero_length.ele", "zero_volume.ele", "empty.off", "count_overflow.ele", "count_huge.ele",
            "crlf_short_vertex.off", "repeated_vertex.ele", "truncated.stl", "garbage_node.msh", "node_tags_shifted.msh", "physical_name_unquoted.msh",
            "comments_unclosed.msh", "binary_count_huge.msh", "binary_byte_order.msh", "binary_missing_node.msh", "version40.msh", "quadratic.ele",
            "nan_binary.stl"}

check = mt.Checks(quiet=True)


def run(args, np=1, cwd=None):
    return mt.run(MSIM, args, np, cwd=cwd)


def scene_view(args, np=1):
    """(vertices, cells, springs, measure, mass) from -msim_scene_view"""
    r = run(args + ["-msim_scene_view", "-msim_steps", "1", "-msim_gravity", "0,0,0", "-msim_spectrum_check", "0"], np)
    if r.returncode:
        return None, r.stderr.strip()
    m = re.search(r"(\d+) vertices \(\d+ fixed\), (?:(\d+) (?:tets|triangles), )?(\d+) springs", r.stdout)
    vol = re.search(r"(?:volume|area) (\S+)", r.stdout)
    mass = re.search(r"mass (\S+) kg", r.stdout)
    return (int(m.group(1)), int(m.group(2) or 0), int(m.group(3)), float(vol.group(1)) if vol else None, float(mass.group(1))), r.stdout


def read_off(path):
    tok = [t for line in open(path) for t in line.split("#")[0].split()]
    nv, nf = int(tok[1]), int(tok[2])
    pts = [tuple(map(float, tok[4 + 3 * i:7 + 3 * i])) for i in range(nv)]
    tris, k = [], 4 + 3 * nv
    for _ in range(nf):
        n = int(tok[k])
        ids = [int(x) for x in tok[k + 1:k + 1 + n]]
        tris += [(ids[0], ids[j], ids[j + 1]) for j in range(1, n - 1)]
        k += 1 + n
    return pts, tris


def enclosed_volume(pts, tris):
    v = 0.0
    for a, b, c in tris:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = pts[a], pts[b], pts[c]
        v += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    return v / 6


def test_corpus(tmp):
    files = sorted(f for f in os.listdir(BAD) if not f.endswith((".node", ".opts")))  # bad options files: bad_input.py
    listed = {f for f, _, _ in CORPUS}
    check(set(files) == listed, f"every file of tests/data/bad is in CORPUS: {sorted(set(files) ^ listed)}")
    for np in mt.ranks():
        for name, scene, message in CORPUS:
            if (name in NEEDS_TETGEN and not TETGEN) or (np > 1 and name in ONE_RANK):
                continue
            out = os.path.join(tmp, f"out_{np}")
            path = os.path.join("tests", "data", "bad", name)
            r = run(["-msim_scene", scene, "-msim_mesh_file", path, "-msim_output", out, "-msim_steps", "2"], np, cwd=ROOT)
            lines = mt.lines(r.stderr)
            stem = name.rsplit(".", 1)[0]
            good = (r.returncode != 0 and len(lines) == 1 and lines[0].startswith("msim: error: ") and message in lines[0]
                    and os.path.join("tests", "data", "bad", stem) in lines[0] and not os.path.exists(out) and r.returncode < 128)
            check(good, f"np={np} {name}: rc {r.returncode}, stderr {lines!r}, expected one line with '{message}'")
        # an obstacle goes through the same reader and check: a repeated face is refused there too
        out = os.path.join(tmp, f"out_{np}")
        path = os.path.join("tests", "data", "bad", "repeated_face.obj")
        r = run(["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_contact_mesh", path, "-msim_output", out, "-msim_steps", "1"], np, cwd=ROOT)
        lines = mt.lines(r.stderr)
        good = (r.returncode != 0 and len(lines) == 1 and lines[0].startswith("msim: error: " + path + " line 9: the face repeats line 7")
                and not os.path.exists(out) and r.returncode < 128)
        check(good, f"np={np} -msim_contact_mesh repeated_face.obj: rc {r.returncode}, stderr {lines!r}, expected one line naming its line 9")


def test_valid():
    cube5 = ["cube5.node", "cube5.ele", "cube5_1based.ele", "cube5.msh", "cube5_41.msh", "cube5_41bin.msh", "cube5_22bin.msh", "cube5_41bin_swapped.msh"]
    for f in cube5:
        for np in (1, 2):
            got, text = scene_view(["-msim_scene", "tet", "-msim_mesh_file", os.path.join(GOOD, f), "-msim_mass", "2.5"], np)
            check(got is not None and got[:3] == (8, 5, 18) and abs(got[3] - 1) < 1e-14 and abs(got[4] - 2.5) < 1e-13,
                  f"np={np} {f}: want 8 vertices, 5 tets, 18 springs, volume 1, mass 2.5; got {got} {text if got is None else ''}")
    if TETGEN:
        for f in ["cube.off", "cube_crlf.off", "cube.obj", "cube_ascii.stl", "cube_binary.stl"]:
            got, text = scene_view(["-msim_scene", "tet", "-msim_mesh_file", os.path.join(GOOD, f), "-msim_density", "3"])
            ok = got is not None and got[0] >= 8 and abs(got[3] - 1) < 1e-14 and abs(got[4] - 3) < 1e-13 and got[0] - got[2] + got[1] + 12 // 2 == 1
            check(ok, f"{f}: want volume 1, mass 3 (density 3), V - E + T + B/2 = 1 with B = 12; got {got} {text if got is None else ''}")
    # a 3 x 3 sheet: 16 vertices, 18 triangles, 33 edges (24 sides, 9 diagonals), 21 shared by two
    # triangles: 21 bending springs (none joins vertices an edge already joins)
    for springs, want in (("edge", 33), ("edge,bending", 54)):
        got, text = scene_view(["-msim_scene", "mesh", "-msim_mesh_file", os.path.join(GOOD, "sheet.obj"), "-msim_springs", springs, "-msim_density", "0.2"])
        check(got is not None and got[:3] == (16, 18, want) and abs(got[3] - 1) < 1e-14 and abs(got[4] - 0.2) < 1e-14,
              f"sheet.obj {springs}: want 16 vertices, 18 triangles, {want} springs, area 1, mass 0.2; got {got} {text if got is None else ''}")
    # the Gmsh example: its tets and nodes counted here from the file itself (format 4.1, ASCII)
    beam = os.path.join(ROOT, "examples", "meshes", "beam.msh")
    nodes, tets = gmsh41_counts(beam)
    got, text = scene_view(["-msim_scene", "tet", "-msim_mesh_file", beam])
    check(got is not None and got[:2] == (nodes, tets) and abs(got[3] - 0.4 * 0.1 * 0.1) < 1e-15,
          f"beam.msh: want {nodes} vertices, {tets} tets, volume 0.004; got {got} {text if got is None else ''}")
    # the same mesh written here as binary 4.1 (both byte orders, size_t of 8 bytes and of 4 as a
    # 32-bit Gmsh writes it; 27 node blocks of points, lines, triangles and tets): the same scene,
    # to the last bit of its volume
    with tempfile.TemporaryDirectory() as tmp:
        for order, size in (("<", 8), (">", 8), ("<", 4)):
            path = os.path.join(tmp, "beam_bin.msh")
            open(path, "wb").write(gmsh41_binary(beam, order, size))
            bgot, text = scene_view(["-msim_scene", "tet", "-msim_mesh_file", path])
            check(bgot == got, f"beam.msh as binary ({order}, size_t of {size} bytes): want {got}, got {bgot} {text if bgot is None else ''}")


def gmsh41_counts(path):
    lines = open(path).read().split("\n")
    i = lines.index("$Nodes")
    nodes = int(lines[i + 1].split()[1])
    i = lines.index("$Elements")
    nblocks, tets, k = int(lines[i + 1].split()[0]), 0, i + 2
    for _ in range(nblocks):
        dim, tag, etype, n = map(int, lines[k].split())
        tets += n if etype == 4 else 0
        k += 1 + n
    return nodes, tets


def gmsh41_binary(path, order, size):
    """An ASCII 4.1 file's $Nodes and $Elements as a binary 4.1 file (size_t of `size` bytes)"""
    text = open(path).read()

    def section(name):
        return [int(t) if "." not in t and "e" not in t.lower() else float(t) for t in text.split("$" + name + "\n")[1].split("$End" + name)[0].split()]

    nodes, t, k = [], section("Nodes"), 4
    for _ in range(t[0]):
        dim, entity, param, n = t[k:k + 4]
        ncoord = n * (3 + (dim if param else 0))
        nodes.append((dim, entity, param, t[k + 4:k + 4 + n], t[k + 4 + n:k + 4 + n + ncoord]))
        k += 4 + n + ncoord
    elements, t, k = [], section("Elements"), 4
    for _ in range(t[0]):
        dim, entity, etype, n = t[k:k + 4]
        m = n * (1 + gmsh_binary.PER[etype])
        elements.append((dim, entity, etype, t[k + 4:k + 4 + m]))
        k += 4 + m
    return gmsh_binary.v41_blocks(nodes, elements, order, size)


def test_bunny(tmp):
    if not TETGEN:
        return
    bunny = os.path.join(ROOT, "examples", "meshes", "bunny.off")
    pts, tris = read_off(bunny)
    volume = enclosed_volume(pts, tris)
    runs = [scene_view(["-msim_scene", "tet", "-msim_mesh_file", bunny, "-msim_mass", "2"], np) for np in (1, 1, 2)]
    got = runs[0][0]
    check(got is not None and all(r[0] == got for r in runs), f"bunny: the same counts on every run: {[r[0] for r in runs]}")
    if got is None:
        return
    nv, nt, ne, vol, mass = got
    check(abs(vol - volume) <= 1e-12 * volume, f"bunny: tet volume {vol!r} vs the volume its surface encloses {volume!r}")
    check(abs(mass - 2) <= 1e-13, f"bunny: masses add up to {mass!r}, not 2")
    check(nv - ne + nt + len(tris) // 2 == 1, f"bunny: V - E + T + B/2 = {nv - ne + nt + len(tris) // 2}, not 1 (V {nv}, E {ne}, T {nt}, B {len(tris)})")
    # the tetgen program on the same surface with the same switches (and e: write the edges)
    tg = shutil.which("tetgen")
    check(tg is not None, "the tetgen program (Debian package tetgen) is installed")
    if tg:
        shutil.copy(bunny, os.path.join(tmp, "bunny.off"))
        sw = re.search(r"tetrahedralized by TetGen -(\S+)\)", runs[0][1]).group(1)
        subprocess.run([tg, "-" + sw + "eQ", "bunny.off"], cwd=tmp, check=True, stdout=subprocess.DEVNULL)
        counts = [int(open(os.path.join(tmp, "bunny.1." + ext)).readline().split()[0]) for ext in ("node", "ele", "edge")]
        check(counts == [nv, nt, ne], f"bunny: msim {nv} vertices, {nt} tets, {ne} springs; tetgen -{sw}e: {counts}")


def partition_view(args, np):
    r = run(args + ["-msim_partition_view", "-msim_steps", "1", "-msim_spectrum_check", "0"], np)
    if r.returncode:
        return None
    free = int(re.search(r"\((\d+) free", r.stdout).group(1))
    cut = int(re.search(r"edge cut: (\d+) springs", r.stdout).group(1))
    owned = [int(m.group(1)) for m in re.finditer(r"^\s+\d+\s+(\d+)\s+\d+\s+\d+\s+\d+$", r.stdout, re.M)]
    return free, cut, owned


def test_partition():
    if not TETGEN:
        return
    bunny = ["-msim_scene", "tet", "-msim_mesh_file", os.path.join(ROOT, "examples", "meshes", "bunny.off"), "-msim_fix_plane", "y_max", "-msim_fix_plane_tol", "1"]
    for np in (2, 3):
        got = partition_view(bunny, np)
        check(got is not None and len(got[2]) == np and sum(got[2]) == got[0] and min(got[2]) > 0,
              f"bunny at {np} ranks: owned vertices {got and got[2]} must add up to the free ones ({got and got[0]})")
    metis, natural = partition_view(bunny + ["-msim_partition", "metis"], 2), partition_view(bunny + ["-msim_partition", "natural"], 2)
    print(f"bunny at 2 ranks: edge cut METIS {metis and metis[1]}, natural {natural and natural[1]}")
    check(metis is not None and natural is not None and 4 * metis[1] < natural[1], f"bunny: METIS's edge cut {metis and metis[1]} is not under a quarter of natural order's {natural and natural[1]}")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        if "corpus" in sys.argv:
            test_corpus(tmp)
        if "valid" in sys.argv:
            test_valid()
            test_bunny(tmp)
            test_partition()
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
