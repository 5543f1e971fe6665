#!/usr/bin/env python3
"""How fast rank 0 reads a tet mesh: Kuhn boxes of about 10^5, 10^6 and 10^7 tets written as TetGen
.node/.ele, as Gmsh 2.2 ASCII and as Gmsh 4.1 binary (one node block, one tet block), read by
msim on one rank. Times from -log_view: MSimMeshRead (parsing the file), MSimMeshCheck (every tet's volume and
edges), MSimMeshEdges (the unique edges), and the whole MSimSetup (the system built from the
springs, on one rank), with the file size and msim's max RSS. Each row is the best of 2 runs.
The files are made once under /tmp/msim_readers (about 0.9 GB for the largest box).
Usage: /usr/bin/python3 runs/bench/readers.py [sizes, default 22,47,101 cubes per side]
Writes runs/bench/readers.csv."""
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, event, write_csv  # noqa: E402

TMP = "/tmp/msim_readers"
PERM = [(0, 1, 2), (1, 2, 0), (2, 0, 1), (0, 2, 1), (2, 1, 0), (1, 0, 2)]


def kuhn_box(n):
    """vertices (n+1)^3 of the unit cube, 6 n^3 tets of positive volume (as msim's box scene)"""
    g = np.arange(n + 1) / n
    z, y, x = np.meshgrid(g, g, g, indexing="ij")
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1)
    i, j, k = np.meshgrid(np.arange(n), np.arange(n), np.arange(n), indexing="ij")
    base = np.stack([k.ravel(), j.ravel(), i.ravel()], axis=1)  # x fastest, as the ids
    vid = lambda c: c[:, 0] + (n + 1) * (c[:, 1] + (n + 1) * c[:, 2])
    tets = []
    for p, order in enumerate(PERM):
        c = base.copy()
        v = [vid(c)]
        for a in order:
            c[:, a] += 1
            v.append(vid(c))
        if p >= 3:
            v[1], v[2] = v[2], v[1]
        tets.append(np.stack(v, axis=1))
    return pts, np.concatenate(tets)


def write_lines(path, header, rows, fmt, footer=""):
    with open(path, "w") as f:
        f.write(header)
        for s in range(0, len(rows), 1 << 20):
            np.savetxt(f, rows[s:s + (1 << 20)], fmt=fmt)
        f.write(footer)


def make(n):
    stem = os.path.join(TMP, f"box{n}")
    if os.path.exists(stem + "_bin.msh"):
        return stem
    os.makedirs(TMP, exist_ok=True)
    pts, tets = kuhn_box(n)
    ids = np.arange(len(pts))[:, None]
    write_lines(stem + ".node", f"{len(pts)} 3 0 0\n", np.hstack([ids, pts]), "%d %.17g %.17g %.17g")
    write_lines(stem + ".ele", f"{len(tets)} 4 0\n", np.hstack([np.arange(len(tets))[:, None], tets]), "%d")
    # Gmsh 2.2: 1-based node tags; element "tag type(4 = tet) ntags(2) physical elementary nodes"
    write_lines(stem + ".msh.tmp", f"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{len(pts)}\n", np.hstack([ids + 1, pts]), "%d %.17g %.17g %.17g", "$EndNodes\n")
    ele = np.hstack([np.arange(1, len(tets) + 1)[:, None], np.tile([4, 2, 1, 1], (len(tets), 1)), tets + 1])
    with open(stem + ".msh.tmp", "a") as f:
        f.write(f"$Elements\n{len(tets)}\n")
        for s in range(0, len(ele), 1 << 20):
            np.savetxt(f, ele[s:s + (1 << 20)], fmt="%d")
        f.write("$EndElements\n")
    os.replace(stem + ".msh.tmp", stem + ".msh")
    # Gmsh 4.1 binary, 8-byte size_t, this machine's byte order (the layout read_gmsh_binary.cpp
    # documents): the nodes as one block of a volume entity, the tets as one block
    nn, nt = len(pts), len(tets)
    with open(stem + "_bin.msh.tmp", "wb") as f:
        f.write(b"$MeshFormat\n4.1 1 8\n" + np.array([1], np.int32).tobytes() + b"\n$EndMeshFormat\n$Nodes\n")
        f.write(np.array([1, nn, 1, nn], np.uint64).tobytes() + np.array([3, 1, 0], np.int32).tobytes() + np.array([nn], np.uint64).tobytes())
        f.write(np.arange(1, nn + 1, dtype=np.uint64).tobytes() + np.ascontiguousarray(pts, dtype=np.float64).tobytes())
        f.write(b"\n$EndNodes\n$Elements\n" + np.array([1, nt, 1, nt], np.uint64).tobytes() + np.array([3, 1, 4], np.int32).tobytes() + np.array([nt], np.uint64).tobytes())
        f.write(np.hstack([np.arange(1, nt + 1)[:, None], tets + 1]).astype(np.uint64).tobytes())
        f.write(b"\n$EndElements\n")
    os.replace(stem + "_bin.msh.tmp", stem + "_bin.msh")
    return stem


def measure(path):
    cmd = [MSIM, "-msim_scene", "tet", "-msim_mesh_file", path, "-msim_steps", "1", "-msim_gravity", "0,0,0", "-msim_spectrum_check", "0", "-log_view", "-memory_view"]
    best = None
    for _ in range(2):
        r = subprocess.run(["/usr/bin/time", "-f", "maxrss_kb %M wall_s %e"] + cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
        if r.returncode:
            sys.exit(f"msim failed on {path}: {r.stderr[-2000:]}")
        row = dict(read=event(r.stdout, "MSimMeshRead")[1], check=event(r.stdout, "MSimMeshCheck")[1], edges=event(r.stdout, "MSimMeshEdges")[1],
                   setup=event(r.stdout, "MSimSetup")[1], wall=float(re.search(r"wall_s (\S+)", r.stderr).group(1)),
                   rss_mb=int(re.search(r"maxrss_kb (\d+)", r.stderr).group(1)) / 1024)
        if best is None or row["wall"] < best["wall"]:
            best = row
    return best


def main():
    sizes = [int(s) for s in sys.argv[1].split(",")] if len(sys.argv) > 1 else [22, 47, 101]
    rows = []
    for n in sizes:
        stem = make(n)
        ntet = 6 * n ** 3
        formats = [("tetgen", stem + ".ele"), ("gmsh 2.2", stem + ".msh"), ("gmsh 4.1 bin", stem + "_bin.msh")]
        for fmt, path in formats:
            size = os.path.getsize(path) + (os.path.getsize(stem + ".node") if fmt == "tetgen" else 0)
            m = measure(path)
            rows.append(dict(format=fmt, cubes=n, tets=ntet, vertices=(n + 1) ** 3, file_mb=round(size / 2**20, 1), read_s=m["read"], check_s=m["check"], edges_s=m["edges"],
                             setup_s=m["setup"], wall_s=m["wall"], max_rss_mb=round(m["rss_mb"]), read_mtets_per_s=round(ntet / m["read"] / 1e6, 2)))
            print(f"{fmt:12s} {ntet:>10,} tets ({size / 2**20:7.1f} MB): read {m['read']:.3f} s ({ntet / m['read'] / 1e6:.2f} M tets/s), check {m['check']:.3f} s, "
                  f"edges {m['edges']:.3f} s, whole setup {m['setup']:.2f} s, wall {m['wall']:.1f} s, max RSS {m['rss_mb']:.0f} MB", flush=True)
    write_csv(os.path.join(HERE, "readers.csv"), rows)


if __name__ == "__main__":
    main()
