"""Signed tet volumes of every frame of an msim series, computed here from the frames' positions (not
from msim's volume_ratio field): V = (x1 - x0) . ((x2 - x0) x (x3 - x0)) / 6 per tet, against the
rest volumes V0 of the first frame of a rest series (or of the series itself when it starts at rest).
Used by tests/volume.py and study.py."""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tools"))
import vtu  # noqa: E402


def signed_volumes(points, tets):
    a = points[tets[:, 0]]
    return np.einsum("ij,ij->i", points[tets[:, 1]] - a, np.cross(points[tets[:, 2]] - a, points[tets[:, 3]] - a)) / 6.0


def tet_frames(pvd):
    """(time, points, tets) of each frame's tet piece, in order"""
    out = []
    for t, path in vtu.read_pvd(pvd):
        d = vtu.read_vtu(path)
        if d["connectivity"].shape[1] == 4:
            out.append((t, d["points"], d["connectivity"]))
    return out


def ratios(pvd, rest_pvd=None):
    """[(time, J per tet)] with J = V / V0; V0 from the first frame of rest_pvd (default: pvd)"""
    frames = tet_frames(pvd)
    _, p0, c0 = tet_frames(rest_pvd)[0] if rest_pvd else frames[0]
    V0 = signed_volumes(p0, c0)
    return [(t, signed_volumes(p, c) / V0) for t, p, c in frames]


if __name__ == "__main__":
    for t, J in ratios(sys.argv[1]):
        print(f"t {t:.4f}: inverted {int((J <= 0).sum())}, J min {J.min():.4f} max {J.max():.4f}")
