#!/usr/bin/env python3
"""No vertex is inside any obstacle in any frame of every contact example: each examples/*.opts
with a -msim_contact_plane, _sphere or _box line runs at the rank count given, writing every
step's frame, and every vertex of every frame is checked against every obstacle with the signed
distances computed here from the options file (plane n.x - d with n normalised, |x - c| - r,
the solid box's distance): strictly positive, the implicit integrators' barrier's guarantee. Mesh
obstacles (-msim_contact_mesh) are not checked here (tests/contact_mesh.py does).
At 1 rank every example runs whole. At more ranks those of PARALLEL_STEPS run their first steps
only (-msim_steps after the options file), through their landing and its closest approach to the
obstacle at 1 rank, where a partition's contact handling is exercised: whole, the three took 154 s
at 2 ranks against 45 s at 1 (2 shared cores; MUMPS's and PD's distributed solves of these small
systems wait on every message). The others run whole (cloth_table: the cloth slides off the box's
edge by step 35).
Usage: contact_examples.py path/to/msim [--np N] [--only NAME ...]"""
import glob
import os
import re
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

# the steps run at more than 1 rank, where fewer than the file's. At 1 rank (frame of the first
# distance under 1 mm, of the least distance): bunny_drop (11, 11; it bounces once and is back at
# the plane by step 18), cloth_fold (0, 33: it starts 0.7 mm above its plane and lies on it from
# step 2 on; 1.0e-4 m at step 16 against the least 6.9e-5 m), cloth_sphere (8, 16)
PARALLEL_STEPS = {"bunny_drop": 20, "cloth_fold": 20, "cloth_sphere": 20}


def obstacles(path):
    """[(kind, values)] of an options file's obstacle lines, and its other options as a dict"""
    found, opts = [], {}
    with open(path) as f:
        for line in f:
            w = line.split("#")[0].split()
            if not w:
                continue
            opts[w[0]] = w[1] if len(w) > 1 else ""
            per = {"-msim_contact_plane": 4, "-msim_contact_sphere": 4, "-msim_contact_box": 6}.get(w[0])
            if per:
                v = [float(x) for x in w[1].split(",")]
                found += [(w[0].split("_")[-1], v[k:k + per]) for k in range(0, len(v), per)]
    return found, opts


def distance(kind, v, p):
    if kind == "plane":
        n = np.array(v[:3])
        return (p @ n - v[3]) / np.linalg.norm(n)
    if kind == "sphere":
        return np.linalg.norm(p - np.array(v[:3]), axis=1) - v[3]
    lo, hi = np.array(v[0::2]), np.array(v[1::2])
    q = np.maximum(np.maximum(lo - p, p - hi), 0)
    inside = np.all((p > lo) & (p < hi), axis=1)
    return np.where(inside, -np.minimum(p - lo, hi - p).min(axis=1), np.sqrt((q * q).sum(axis=1)))


def main():
    exe, check = mt.msim_path(), mt.Checks()
    only = sys.argv[sys.argv.index("--only") + 1:] if "--only" in sys.argv else None
    tmp = tempfile.mkdtemp(prefix="msim_contact_examples_")
    examples = []
    for path in sorted(glob.glob(os.path.join(mt.ROOT, "examples", "*.opts"))):
        name = os.path.basename(path)[:-5]
        obs, opts = obstacles(path)
        if obs and (only is None or name in only):
            examples.append((name, path, obs, opts))
    check(len(examples) >= (len(only) if only else 3), f"{len(examples)} contact examples found: {[e[0] for e in examples]}")
    for np_ in mt.ranks():
        for name, path, obs, opts in examples:
            out = os.path.join(tmp, f"{name}_{np_}")
            steps = int(opts.get("-msim_steps", "0"))
            cut = []
            if np_ > 1 and name in PARALLEL_STEPS:
                steps = PARALLEL_STEPS[name]
                cut = ["-msim_steps", steps]
            r = mt.run(exe, ["-options_file", path, "-msim_output", out, "-msim_output_every", "1"] + cut, np_, cwd=mt.ROOT)
            if not check(r.returncode == 0, f"np {np_}: {name}: runs ({r.stderr.strip()[-300:]})"):
                continue
            series = vtu.read_pvd(os.path.join(out, "series.pvd"))
            least, where = np.inf, None
            for t, f in series:
                frame = vtu.read_vtu(f)
                p = frame["points"][frame["fixed"] == 0]
                d = np.array([distance(k, v, p) for k, v in obs])  # (obstacles, vertices)
                if d.min() < least:
                    least, where = float(d.min()), t
            check(len(series) == steps + 1 and least > 0,
                  f"np {np_}: {name}: every free vertex outside every obstacle in all {len(series)} frames (least distance {least:.3g} m at t = {where})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
