#!/usr/bin/env python3
"""The seed corpus of each fuzz harness: every valid and malformed mesh file of its format under
tests/data (and examples/meshes); TetGen pairs joined as .node, a line '#ele', then .ele.
Usage: seeds.py OUTDIR [format ...] -> OUTDIR/<format>/ with one file per seed."""
import glob
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXT = {"off": ".off", "obj": ".obj", "stl": ".stl", "gmsh": ".msh"}


def sources(ext):
    return sorted(glob.glob(os.path.join(ROOT, "tests", "data", "*", "*" + ext)) + glob.glob(os.path.join(ROOT, "examples", "meshes", "*" + ext)))


def make(out, fmt):
    d = os.path.join(out, fmt)
    os.makedirs(d, exist_ok=True)
    if fmt == "tetgen":
        for node in sources(".node"):
            ele = node[:-5] + ".ele"
            if os.path.exists(ele):
                data = open(node, "rb").read().rstrip(b"\n") + b"\n#ele\n" + open(ele, "rb").read()
                open(os.path.join(d, os.path.basename(node)[:-5] + ".tetgen"), "wb").write(data)
    else:
        for f in sources(EXT[fmt]):
            open(os.path.join(d, os.path.basename(os.path.dirname(f)) + "_" + os.path.basename(f)), "wb").write(open(f, "rb").read())
    return d


if __name__ == "__main__":
    for fmt in sys.argv[2:] or ["off", "obj", "stl", "tetgen", "gmsh"]:
        print(make(sys.argv[1], fmt), len(os.listdir(os.path.join(sys.argv[1], fmt))))
