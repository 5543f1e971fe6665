#!/usr/bin/env python3
"""One rule for vertex ids, every format: the ids -msim_fix_list takes are the file's own order
from 0, whatever vertices msim drops. Each file below has vertices no cell uses (Gmsh nodes on the
model's points, curves and surfaces, OBJ loose vertices, a TetGen point, a Medit vertex, an OFF
vertex); an independent reader here finds which, and then, at each rank count:
- msim prints one note saying how many of the file's vertices were dropped (the count from here);
- fixing file ids (a few kept ones, spread over the file) under gravity leaves exactly those
  vertices at the file's coordinates in -msim_view_final (whose rows are the kept vertices in the
  file's order) and moves every other one;
- fixing a dropped id is one error line naming the id and the file; an id past the file's count
  is an error naming the range.
Usage: mesh_ids.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import msimtest as mt

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "data", "corpus")
MESHES = os.path.join(HERE, "data", "meshes")


def gmsh41_ascii(path, dim):
    """(coordinates in $Nodes order, the set of node positions used by elements of dimension dim)"""
    lines = open(path).read().split("\n")
    i = lines.index("$Nodes")
    nblocks = int(lines[i + 1].split()[0])
    k, tags, xyz = i + 2, [], []
    for _ in range(nblocks):
        d, e, param, n = map(int, lines[k].split())
        tags += [int(lines[k + 1 + j]) for j in range(n)]
        xyz += [tuple(map(float, lines[k + 1 + n + j].split()[:3])) for j in range(n)]
        k += 1 + 2 * n
    place = {t: q for q, t in enumerate(tags)}
    i = lines.index("$Elements")
    nblocks = int(lines[i + 1].split()[0])
    k, used = i + 2, set()
    for _ in range(nblocks):
        d, e, etype, n = map(int, lines[k].split())
        if d == dim:
            for j in range(n):
                used.update(place[int(t)] for t in lines[k + 1 + j].split()[1:])
        k += 1 + n
    return xyz, used


def obj(path):
    """(vertex coordinates, the set of 0-based ids the faces use; negative ids count back)"""
    xyz, used = [], set()
    for line in open(path):
        t = line.split("#")[0].split()
        if t and t[0] == "v":
            xyz.append(tuple(map(float, t[1:4])))
        elif t and t[0] == "f":
            for c in t[1:]:
                i = int(c.split("/")[0])
                used.add(i - 1 if i > 0 else len(xyz) + i)
    return xyz, used


def tetgen(stem):
    """.node/.ele: (coordinates, used ids), the first point's id deciding 0- or 1-based"""
    def rows(path):
        return [l.split("#")[0].split() for l in open(path) if l.split("#")[0].strip()]
    node, ele = rows(stem + ".node"), rows(stem + ".ele")
    base = int(node[1][0])
    xyz = [tuple(map(float, r[1:4])) for r in node[1:]]
    used = {int(v) - base for r in ele[1:] for v in r[1:5]}
    return xyz, used


def medit(path):
    """Vertices and the vertices of Tetrahedra (ids from 1), tokens read across lines"""
    tok = [t for l in open(path) for t in l.split("#")[0].split()]
    xyz, used, k = [], set(), 0
    while k < len(tok):
        key = tok[k]
        k += 1
        if key == "Vertices":
            n = int(tok[k])
            xyz = [tuple(map(float, tok[k + 1 + 4 * j:k + 4 + 4 * j])) for j in range(n)]
            k += 1 + 4 * n
        elif key == "Tetrahedra":
            n = int(tok[k])
            used |= {int(tok[k + 1 + 5 * j + q]) - 1 for j in range(n) for q in range(4)}
            k += 1 + 5 * n
    return xyz, used


def off(path):
    tok = [t for l in open(path) for t in l.split("#")[0].split()]
    nv, nf = int(tok[1]), int(tok[2])
    xyz = [tuple(map(float, tok[4 + 3 * i:7 + 3 * i])) for i in range(nv)]
    used, k = set(), 4 + 3 * nv
    for _ in range(nf):
        n = int(tok[k])
        used.update(int(x) for x in tok[k + 1:k + 1 + n])
        k += 1 + n
    return xyz, used


def main():
    msim, check = mt.msim_path(), mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        # an OFF square of two triangles whose first and fourth vertices no face uses: every kept
        # vertex's input index differs from its file id
        loose_off = os.path.join(tmp, "loose.off")
        open(loose_off, "w").write("OFF\n6 2 0\n9 9 9\n0 0 0\n1 0 0\n5 5 5\n1 1 0\n0 1 0\n3 1 2 4\n3 1 4 5\n")
        cases = [  # file, scene, (coordinates, used ids), ids to fix, noun, cell
            (os.path.join(CORPUS, "gmsh_t2.msh"), "tet", gmsh41_ascii(os.path.join(CORPUS, "gmsh_t2.msh"), 3), None, "nodes", "tet"),
            (os.path.join(CORPUS, "tinyobj_cornell_box.obj"), "mesh", obj(os.path.join(CORPUS, "tinyobj_cornell_box.obj")), None, "vertices", "face"),
            (os.path.join(MESHES, "cube5_loose.ele"), "tet", tetgen(os.path.join(MESHES, "cube5_loose")), [0, 7], "points", "tet"),
            (os.path.join(MESHES, "cube5.mesh"), "tet", medit(os.path.join(MESHES, "cube5.mesh")), [1, 7], "vertices", "tet"),
            (loose_off, "mesh", off(loose_off), [1, 4], "vertices", "face"),
        ]
        for path, scene, (xyz, used), fix, noun, cell in cases:
            name = os.path.basename(path)
            kept = sorted(used)
            dropped = sorted(set(range(len(xyz))) - used)
            check(dropped, f"{name}: the file has vertices no {cell} uses (here: {len(dropped)})")
            if fix is None:  # spread over the file: the second kept id, one near the middle, the last
                fix = [kept[1], kept[len(kept) // 2], kept[-1]]
            row = {f: q for q, f in enumerate(kept)}  # file id -> row of -msim_view_final
            base = ["-msim_scene", scene, "-msim_mesh_file", path, "-msim_steps", "3", "-msim_dt", "1e-5", "-msim_gravity", "0,0,-9.81"]
            for np in mt.ranks():
                pos, r = mt.final_positions(msim, base + ["-msim_fix_list", ",".join(map(str, fix))], np, tmp, name=name)
                if not check(pos is not None, f"np={np} {name}: runs with -msim_fix_list {fix}"):
                    continue
                notes = [l for l in mt.lines(r.stderr) if l.startswith("msim: note: ") and "dropped" in l]
                want = f"{len(dropped)} of {len(xyz)} {noun} belong{'s' if len(dropped) == 1 else ''} to no {cell}"
                check(len(notes) == 1 and want in notes[0] and name.rsplit(".", 1)[0] in notes[0], f"np={np} {name}: one note '{want}', got {notes}")
                check(len(pos) == len(kept), f"np={np} {name}: {len(pos)} vertices, want the {len(kept)} the {cell}s use")
                still = [q for q in range(min(len(pos), len(kept))) if tuple(pos[q]) == xyz[kept[q]]]
                check(sorted(still) == sorted(row[f] for f in fix) and all(tuple(pos[row[f]]) == xyz[f] for f in fix),
                      f"np={np} {name}: the vertices at rest are file ids {[kept[q] for q in still]}, want {fix} at the file's coordinates")
                # a dropped id, and one past the file's
                r = mt.run(msim, base + ["-msim_fix_list", f"{fix[0]},{dropped[0]}"], np)
                errors = [l for l in mt.lines(r.stderr) if l.startswith("msim: error: ")]
                check(r.returncode != 0 and len(errors) == 1 and f"vertex {dropped[0]} of " in errors[0] and name in errors[0] and "dropped" in errors[0],
                      f"np={np} {name}: fixing dropped id {dropped[0]} is one error naming it and the file, got {errors}")
                r = mt.run(msim, base + ["-msim_fix_list", str(len(xyz))], np)
                errors = [l for l in mt.lines(r.stderr) if l.startswith("msim: error: ")]
                check(r.returncode != 0 and len(errors) == 1 and f"vertex {len(xyz)} is out of range [0, {len(xyz) - 1}]" in errors[0],
                      f"np={np} {name}: id {len(xyz)} is out of range [0, {len(xyz) - 1}], got {errors}")
        # refinement after dropping: a kept vertex keeps its file id, the midpoints take the ids
        # after the file's (the first: len(xyz)); the vertices that do not move between a run of 1
        # step and one of 3 are the fixed ones: those two
        path = os.path.join(CORPUS, "gmsh_t2.msh")
        xyz, used = gmsh41_ascii(path, 3)
        kept = sorted(used)
        for np in mt.ranks():
            runs = [mt.final_positions(msim, ["-msim_scene", "tet", "-msim_mesh_file", path, "-msim_refine", "1", "-msim_steps", str(steps), "-msim_dt", "1e-5",
                                              "-msim_gravity", "0,0,-9.81", "-msim_fix_list", f"{kept[1]},{len(xyz)}"], np, tmp, name=f"refined{steps}")[0] for steps in (1, 3)]
            if check(runs[0] is not None and runs[1] is not None and len(runs[0]) == len(runs[1]), f"np={np} gmsh_t2.msh refined: runs"):
                still = [q for q in range(len(runs[0])) if tuple(runs[0][q]) == tuple(runs[1][q])]
                check(still == [1, len(kept)] and tuple(runs[1][1]) == xyz[kept[1]],
                      f"np={np} refined: rows at rest {still}, want 1 (file id {kept[1]}, at the file's coordinates) and {len(kept)} (the first midpoint, file id {len(xyz)})")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
