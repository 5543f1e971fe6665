#!/usr/bin/env python3
"""The seed corpus of each fuzz harness: every valid and malformed mesh file of its format under
tests/data (and examples/meshes); TetGen pairs joined as .node, a line '#ele', then .ele. The
options harness: every options file under examples/ and tests/data/bad/. The checkpoint harness:
checkpoints that msim writes of the harness's chain (MSIM_EXE, default build/msim), one at rest
and one moving, plus a cut one.
Usage: seeds.py OUTDIR [format ...] -> OUTDIR/<format>/ with one file per seed."""
import glob
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
EXT = {"off": ".off", "obj": ".obj", "stl": ".stl", "gmsh": ".msh", "medit": ".mesh"}
FORMATS = ["off", "obj", "stl", "tetgen", "gmsh", "medit", "options", "checkpoint"]
# fuzz_checkpoint.cpp's scene_options: the checkpoints must be of that scene
CHECKPOINT_SCENE = "-msim_scene chain -msim_chain_n 8 -msim_fix edge"


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
    elif fmt == "options":
        for f in sorted(glob.glob(os.path.join(ROOT, "examples", "*.opts")) + glob.glob(os.path.join(ROOT, "tests", "data", "bad", "*.opts"))):
            open(os.path.join(d, os.path.basename(os.path.dirname(f)) + "_" + os.path.basename(f)), "wb").write(open(f, "rb").read())
    elif fmt == "checkpoint":
        msim = os.environ.get("MSIM_EXE", os.path.join(ROOT, "build", "msim"))
        with tempfile.TemporaryDirectory() as tmp:
            for name, steps in (("rest", 1), ("moving", 30)):
                ck = os.path.join(tmp, name)
                subprocess.run([msim] + CHECKPOINT_SCENE.split() + ["-msim_steps", str(steps), "-msim_dt", "1e-3", "-msim_checkpoint", ck, "-msim_progress", "0"],
                               check=True, capture_output=True, cwd=tmp)
                data = open(ck, "rb").read()
                open(os.path.join(d, name + ".ck"), "wb").write(data)
            open(os.path.join(d, "cut.ck"), "wb").write(data[: len(data) // 2])
    else:
        for f in sources(EXT[fmt]):
            open(os.path.join(d, os.path.basename(os.path.dirname(f)) + "_" + os.path.basename(f)), "wb").write(open(f, "rb").read())
    return d


if __name__ == "__main__":
    for fmt in sys.argv[2:] or FORMATS:
        print(make(sys.argv[1], fmt), len(os.listdir(os.path.join(sys.argv[1], fmt))))
