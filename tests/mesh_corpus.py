#!/usr/bin/env python3
"""Real-world mesh files (tests/data/corpus, sources and licences in its README.md) read by msim at
each rank count, with -msim_scene_view's vertices, cells, springs and volume or area checked
against a reader written here, independently of msim's:
- Gmsh 4.1 and 2.2 ASCII: the nodes, and the elements of the highest dimension; hexahedra and
  prisms split into tets and quadrangles into triangles by the rule msim documents (a fan from a
  polygon's smallest id; a cell as the cone from its smallest-id vertex over its other faces), so
  the counts of tets and of unique edges (springs) and the volume follow from the file; a binary
  file is the same mesh Gmsh wrote beside it in ASCII, and must give the same figures;
- OBJ (loose vertices, quadrangles, vt, t, o, usemtl, mtllib lines) and Medit (written by Gmsh).
Also: a mixed tet and prism file (Gmsh's tutorial t3) reads; the OBJ note lists the statements
skipped; the tet meshes are conforming (every triangle in at most two tets, and V - E + F - T
equals the number of pieces, each a ball, for the two-piece t2); the messages of issue 36 (a
pyramid, a second-order tet, a .node without its header, a quadrangle in an STL facet, a Medit id
out of range, Medit hexahedra; -msim_scene_view's bounding-box diagonal; -msim_young on a shell).
Usage: mesh_corpus.py path/to/msim [--np N]"""
import os
import re
import sys
import tempfile

import msimtest as mt

HERE = os.path.dirname(os.path.abspath(__file__))
CORPUS = os.path.join(HERE, "data", "corpus")

PER = {2: 3, 3: 4, 4: 4, 5: 8, 6: 6, 15: 1, 1: 2}
DIM = {1: 1, 2: 2, 3: 2, 4: 3, 5: 3, 6: 3, 15: 0}
HEX_FACES = [(0, 3, 2, 1), (4, 5, 6, 7), (0, 1, 5, 4), (3, 7, 6, 2), (0, 4, 7, 3), (1, 2, 6, 5)]
PRISM_FACES = [(0, 2, 1), (3, 4, 5), (0, 1, 4, 3), (0, 3, 5, 2), (1, 2, 5, 4)]


def fan(ids):
    s = ids.index(min(ids))
    r = ids[s:] + ids[:s]
    return [(r[0], r[k], r[k + 1]) for k in range(1, len(r) - 1)]


def cone(ids, faces):
    apex = min(ids)
    return [(apex,) + t for f in faces if apex not in [ids[q] for q in f] for t in fan([ids[q] for q in f])]


def split(etype, ids):
    if etype in (2, 4):
        return [tuple(ids)]
    if etype == 3:
        return fan(list(ids))
    return cone(list(ids), HEX_FACES if etype == 5 else PRISM_FACES)


def gmsh_ascii(path):
    """(coordinates in $Nodes order, [(type, node positions)] of the highest dimension)"""
    lines = open(path).read().split("\n")
    version = lines[lines.index("$MeshFormat") + 1].split()[0]
    i = lines.index("$Nodes")
    xyz, place, elems = [], {}, []
    if version == "4.1":
        nblocks, k = int(lines[i + 1].split()[0]), i + 2
        for _ in range(nblocks):
            d, e, param, n = map(int, lines[k].split())
            for j in range(n):
                place[int(lines[k + 1 + j])] = len(xyz)
                xyz.append(tuple(map(float, lines[k + 1 + n + j].split()[:3])))
            k += 1 + 2 * n
        i = lines.index("$Elements")
        nblocks, k = int(lines[i + 1].split()[0]), i + 2
        for _ in range(nblocks):
            d, e, etype, n = map(int, lines[k].split())
            elems += [(etype, [place[int(t)] for t in lines[k + 1 + j].split()[1:]]) for j in range(n)]
            k += 1 + n
    else:
        n = int(lines[i + 1])
        for j in range(n):
            t = lines[i + 2 + j].split()
            place[int(t[0])] = len(xyz)
            xyz.append(tuple(map(float, t[1:4])))
        i = lines.index("$Elements")
        for j in range(int(lines[i + 1])):
            t = list(map(int, lines[i + 2 + j].split()))
            elems.append((t[1], [place[v] for v in t[3 + t[2]:]]))
    top = max(DIM[t] for t, _ in elems)
    return xyz, [(t, ids) for t, ids in elems if DIM[t] == top]


def medit(path):
    tok = [t for l in open(path) for t in l.split("#")[0].split()]
    xyz, elems, k = [], [], 0
    size = {"Edges": 3, "Triangles": 4, "Tetrahedra": 5, "Corners": 1, "Ridges": 1}
    while k < len(tok):
        key = tok[k]
        k += 1
        if key == "End":
            break
        if key in ("MeshVersionFormatted", "Dimension"):
            k += 1
        elif key == "Vertices":
            n = int(tok[k])
            xyz = [tuple(map(float, tok[k + 1 + 4 * j:k + 4 + 4 * j])) for j in range(n)]
            k += 1 + 4 * n
        else:
            n, per = int(tok[k]), size[key]
            if key in ("Triangles", "Tetrahedra"):
                elems += [(2 if key == "Triangles" else 4, [int(v) - 1 for v in tok[k + 1 + per * j:k + per + per * j]]) for j in range(n)]
            k += 1 + per * n
    top = 4 if any(t == 4 for t, _ in elems) else 2
    return xyz, [(t, ids) for t, ids in elems if t == top]


def obj(path):
    xyz, elems = [], []
    for line in open(path):
        t = line.split("#")[0].split()
        if t and t[0] == "v":
            xyz.append(tuple(map(float, t[1:4])))
        elif t and t[0] == "f":
            ids = [int(c.split("/")[0]) for c in t[1:]]
            elems.append((0, [i - 1 if i > 0 else len(xyz) + i for i in ids]))
    return xyz, elems


def figures(xyz, elems):
    """(vertices used, cells, unique edges, volume or area, cells as tuples)"""
    cells = [c for t, ids in elems for c in (fan(ids) if t == 0 else split(t, ids))]
    used = {v for c in cells for v in c}
    edges = {(min(c[a], c[b]), max(c[a], c[b])) for c in cells for a in range(len(c)) for b in range(a)}

    def sub(p, q):
        return [p[i] - q[i] for i in range(3)]

    def cross(u, w):
        return [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
    measure = 0.0
    for c in cells:
        a = xyz[c[0]]
        if len(c) == 4:
            u, w, z = sub(xyz[c[1]], a), sub(xyz[c[2]], a), sub(xyz[c[3]], a)
            measure += sum(x * y for x, y in zip(u, cross(w, z))) / 6
        else:
            n = cross(sub(xyz[c[1]], a), sub(xyz[c[2]], a))
            measure += 0.5 * sum(x * x for x in n) ** 0.5
    return len(used), len(cells), len(edges), measure, cells


def scene_view(msim, args, np):
    r = mt.run(msim, args + ["-msim_scene_view", "-msim_steps", "1", "-msim_dt", "1e-6"], np)
    m = re.search(r"(\d+) vertices \(\d+ fixed\), (\d+) (?:tets|triangles), (\d+) springs", r.stdout)
    vol = re.search(r"(?:volume|area) (\S+)", r.stdout)
    if r.returncode or not m:
        return None, r
    return (int(m.group(1)), int(m.group(2)), int(m.group(3)), float(vol.group(1))), r


def main():
    msim, check = mt.msim_path(), mt.Checks()
    # file, scene, its reader here (or the ASCII twin whose figures it must give)
    files = [
        ("gmsh_t2.msh", "tet", gmsh_ascii),
        ("gmsh_t2_22bin.msh", "tet", "gmsh_t2.msh"),
        ("gmsh_t2.mesh", "tet", medit),
        ("gmsh_t3.msh", "tet", gmsh_ascii),
        ("gmsh_hex_box.msh", "tet", gmsh_ascii),
        ("gmsh_hex_box_41bin.msh", "tet", "gmsh_hex_box.msh"),
        ("gmsh_prism_box.msh", "tet", gmsh_ascii),
        ("gmsh_prism_box_22bin.msh", "tet", "gmsh_prism_box.msh"),
        ("gmsh_quad_box_surface.msh", "mesh", gmsh_ascii),
        ("tinyobj_cornell_box.obj", "mesh", obj),
        ("tinyobj_catmark_torus_creases0.obj", "mesh", obj),
    ]
    listed = {f for f, _, _ in files}
    on_disk = {f for f in os.listdir(CORPUS) if not f.endswith((".md", ".geo"))}
    check(on_disk == listed, f"every mesh of tests/data/corpus is read here: {sorted(on_disk ^ listed)}")
    want = {}
    for name, scene, reader in files:
        path = os.path.join(CORPUS, name)
        if callable(reader):
            want[name] = figures(*reader(path))
        else:
            want[name] = want[reader]
        nv, nc, ne, measure, cells = want[name]
        if scene == "tet":
            # conforming: no triangle in more than two tets
            count = {}
            for c in cells:
                for o in range(4):
                    f = tuple(sorted(c[:o] + c[o + 1:]))
                    count[f] = count.get(f, 0) + 1
            check(max(count.values()) <= 2, f"{name}: every triangle in at most two tets (here)")
        for np in mt.ranks():
            got, r = scene_view(msim, ["-msim_scene", scene, "-msim_mesh_file", path], np)
            check(got is not None and got[:3] == (nv, nc, ne) and abs(got[3] - measure) <= 1e-12 * abs(measure),
                  f"np={np} {name}: msim {got}, this reader {(nv, nc, ne, measure)} (vertices, cells, springs, {'volume' if scene == 'tet' else 'area'})"
                  + ("" if got else f"\n{r.stderr[-800:]}"))
            notes = [l for l in mt.lines(r.stderr) if l.startswith("msim: note: ")]
            if name == "tinyobj_catmark_torus_creases0.obj":
                check(len(notes) == 1 and "vt (4 lines)" in notes[0] and "t (8 lines)" in notes[0], f"np={np} {name}: one note listing vt (4 lines) and t (8 lines): {notes}")
            if name == "tinyobj_cornell_box.obj":
                xyz = obj(path)[0]
                loose = f"{len(xyz) - nv} of {len(xyz)} vertices belong to no face"
                check(len(notes) == 2 and any("mtllib (1 line)" in n and "usemtl (10 lines)" in n and "o (9 lines)" in n for n in notes) and any(loose in n for n in notes),
                      f"np={np} {name}: notes on the skipped statements (mtllib, usemtl, o) and '{loose}': {notes}")
    # Euler's formula on a conforming tet mesh of balls: V - E + F - T = pieces (t2: two volumes
    # apart; the boxes: one); F = (4T + B) / 2 with B the triangles in one tet only
    for name, pieces in (("gmsh_t2.msh", 2), ("gmsh_hex_box.msh", 1), ("gmsh_prism_box.msh", 1)):
        nv, nc, ne, _, cells = want[name]
        count = {}
        for c in cells:
            for o in range(4):
                f = tuple(sorted(c[:o] + c[o + 1:]))
                count[f] = count.get(f, 0) + 1
        check(nv - ne + len(count) - nc == pieces, f"{name}: V - E + F - T = {nv - ne + len(count) - nc}, want {pieces}")
    # what msim refuses in Gmsh files names the element: a pyramid, a second-order tet
    with tempfile.TemporaryDirectory() as tmp:
        nodes = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n10\n" + "".join(f"{i + 1} {i % 2} {(i // 2) % 2} {i // 4}\n" for i in range(10)) + "$EndNodes\n"
        line = nodes.count("\n") + 3  # after $Elements and its count
        for body, message in (("1\n1 7 0 1 2 4 3 5\n", f"line {line}: a pyramid (element type 7): msim splits hexahedra and prisms into tets, not pyramids"),
                              ("1\n1 11 0 1 2 3 5 6 7 8 9 10 4\n", f"line {line}: a second-order tetrahedron (10 nodes) (element type 11): msim reads first-order elements")):
            path = os.path.join(tmp, "refused.msh")
            open(path, "w").write(nodes + "$Elements\n" + body + "$EndElements\n")
            for np in mt.ranks():
                r = mt.run(msim, ["-msim_scene", "tet", "-msim_mesh_file", path, "-msim_steps", "1"], np)
                errors = mt.lines(r.stderr)
                check(r.returncode and len(errors) == 1 and message in errors[0], f"np={np}: one error '{message}', got {errors}")
        # messages: each one line, at every rank count
        cube = "0 0 0 0\n1 1 0 0\n2 0 1 0\n3 1 1 0\n4 0 0 1\n5 1 0 1\n6 0 1 1\n7 1 1 1\n"
        tets = "5 4 0\n0 0 1 2 4\n1 3 2 1 7\n2 5 1 4 7\n3 6 4 2 7\n4 1 2 4 7\n"
        open(os.path.join(tmp, "noheader.node"), "w").write(cube)
        open(os.path.join(tmp, "noheader.ele"), "w").write(tets)
        # the case: real coordinates where the header's dimension should be
        open(os.path.join(tmp, "noheader_real.node"), "w").write("".join(f"{l.split()[0]} {float(l.split()[1]) - 0.31} {l.split()[2]} {l.split()[3]}\n" for l in cube.splitlines()))
        open(os.path.join(tmp, "noheader_real.ele"), "w").write(tets)
        stl = "solid q\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 1 1 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid q\n"
        open(os.path.join(tmp, "quad.stl"), "w").write(stl)
        medit_bad = "MeshVersionFormatted 1\nDimension 3\nVertices\n4\n0 0 0 0\n1 0 0 0\n0 1 0 0\n0 0 1 0\nTetrahedra\n1\n1 2 3 5 0\nEnd\n"
        open(os.path.join(tmp, "bad.mesh"), "w").write(medit_bad)
        open(os.path.join(tmp, "hex.mesh"), "w").write("MeshVersionFormatted 1\nDimension 3\nVertices\n0\nHexahedra\n0\nEnd\n")
        for path, scene, message in ((os.path.join(tmp, "noheader.ele"), "tet", "noheader.node line 1: the header line is missing"),
                                     (os.path.join(tmp, "noheader_real.ele"), "tet", "noheader_real.node line 1: the header line is missing"),
                                     (os.path.join(tmp, "quad.stl"), "mesh", "quad.stl line 7: expected 'endloop' (STL facets are triangles), found 'vertex'"),
                                     (os.path.join(tmp, "bad.mesh"), "tet", "bad.mesh line 11: the tet names vertex 5, outside [1, 4]"),
                                     (os.path.join(tmp, "hex.mesh"), "tet", "hex.mesh line 5: Medit Hexahedra: msim reads Medit's Tetrahedra")):
            for np in mt.ranks():
                r = mt.run(msim, ["-msim_scene", scene, "-msim_mesh_file", path, "-msim_steps", "1"], np)
                errors = mt.lines(r.stderr)
                check(r.returncode and len(errors) == 1 and message in errors[0], f"np={np}: one error '{message}', got {errors}")
        for np in mt.ranks():
            got, r = scene_view(msim, ["-msim_scene", "mesh", "-msim_mesh_file", os.path.join(CORPUS, "gmsh_quad_box_surface.msh"), "-msim_young", "1e5"], np)
            err = mt.lines(r.stderr)
            check("bounding-box diagonal 0.374166 m" in r.stdout and "diameter" not in r.stdout, f"np={np}: -msim_scene_view names the bounding-box diagonal (of the 0.3 x 0.2 x 0.1 box, 0.374166)")
            check(any("note: -msim_young does not apply to -msim_scene mesh" in l for l in err) and not any("never used" in l for l in err),
                  f"np={np}: -msim_young on a shell is a note that it does not apply, not an unused option: {err}")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
