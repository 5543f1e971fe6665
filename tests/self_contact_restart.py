#!/usr/bin/env python3
"""Checkpoint and restart of a self-contact run (-msim_self_contact with -msim_checkpoint and
-msim_restart): a small patch of cloth dropped flat onto a sheet held by its corners, one surface
mesh (an OFF written here), with friction between them; stopped at step 12 (landing on the sheet:
the test checks that a vertex is within dhat of a triangle at the checkpoint) and
restarted to step 36, it ends bit for bit where the uninterrupted run does, at 1 and at 2 ranks,
with the same frames and monitor rows (all but the wall time). The restarted run builds its
candidate lists at the checkpoint's positions, the uninterrupted one somewhere earlier: the term
sums its pairs in the order of their vertices' input ids, and its CCD's answer depends on the step
only, not on where the lists were made (tests/checkpoint.py checks the same for a scene without
self-contact). No floor: the obstacles' restarts are checked by tests/contact_restart.py.
Usage: self_contact_restart.py path/to/msim [--np N]"""
import math
import os
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
DHAT = 0.02
SCENE = ["-msim_scene", "mesh", "-msim_mesh_file", "drop.off", "-msim_fix_list", "0,8,72,80", "-msim_self_contact_distance", str(DHAT),
         "-msim_gravity", "0,0,-9.81", "-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-snes_type", "pd", "-snes_max_it", "20",
         "-snes_pd_fixed", "-msim_self_contact", "-msim_friction", "0.5", "-msim_output_every", "4"]
SPLIT, END = 12, 36
check = mt.Checks()


final = mt.read_binary_vec  # positions written by -msim_view_final binary:PATH


def frames(out):
    return {f: open(os.path.join(out, f), "rb").read() for f in mt.frames(out)}


def monitor(path):
    return [",".join(r.split(",")[:-1]) for r in open(path).read().splitlines()]


def write_scene(path):
    """a 9 x 9 sheet of 1 m in z = 0 and a 5 x 5 patch of 0.3 m turned by 0.3 rad, 5 cm above
    it (cells split along alternating diagonals); returns the triangles"""
    V, F = [], []

    def grid(n, size, origin, turn):
        base, h, c, s = len(V), size / (n - 1), math.cos(turn), math.sin(turn)
        for j in range(n):
            for i in range(n):
                V.append((origin[0] + c * i * h - s * j * h, origin[1] + s * i * h + c * j * h, origin[2]))
        for j in range(n - 1):
            for i in range(n - 1):
                a = base + j * n + i
                b, c_, d = a + 1, a + n + 1, a + n
                F.extend([(a, b, c_), (a, c_, d)] if (i + j) % 2 else [(a, b, d), (b, c_, d)])

    grid(9, 1.0, (0, 0, 0), 0)
    grid(5, 0.3, (0.4, 0.3, 0.05), 0.3)
    with open(path, "w") as f:
        f.write(f"OFF\n{len(V)} {len(F)} 0\n")
        f.writelines(f"{x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in V)
        f.writelines(f"3 {a} {b} {c}\n" for a, b, c in F)
    return np.array(F)


def closest_disjoint(x, t):
    """the least distance from a vertex to a triangle of t it is not a vertex of (numpy, no msim
    code): the face's plane where the projection falls inside, else the nearest of its edges"""
    best = np.inf

    def seg(p, a, b):
        ab = b - a
        s = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.einsum("ij,ij->i", ab, ab), 0, 1)
        return np.linalg.norm(p - (a + s[:, None] * ab), axis=1)

    for v in range(len(x)):
        keep = ~np.any(t == v, axis=1)
        a, b, c = x[t[keep, 0]], x[t[keep, 1]], x[t[keep, 2]]
        p = np.broadcast_to(x[v], a.shape)
        n = np.cross(b - a, c - a)
        n /= np.linalg.norm(n, axis=1)[:, None]
        h = np.einsum("ij,ij->i", p - a, n)
        q = p - h[:, None] * n
        inside = np.ones(len(a), bool)
        for u, w in ((a, b), (b, c), (c, a)):
            inside &= np.einsum("ij,ij->i", np.cross(w - u, q - u), n) >= 0
        d = np.where(inside, np.abs(h), np.minimum(np.minimum(seg(p, a, b), seg(p, b, c)), seg(p, c, a)))
        best = min(best, d.min())
    return best


def main():
    with tempfile.TemporaryDirectory() as tmp:
        tris = write_scene(os.path.join(tmp, "drop.off"))
        for np_ in mt.ranks():
            ref = os.path.join(tmp, f"ref{np_}")
            r = mt.run(MSIM, SCENE + ["-msim_steps", str(END), "-msim_output", ref, "-msim_monitor_csv", ref + ".csv",
                                      "-msim_view_final", f"binary:{ref}.bin"], np_, cwd=tmp)
            if not check(r.returncode == 0, f"np {np_}: the uninterrupted run ({r.stderr.strip()[-300:]})"):
                continue
            out, ck = os.path.join(tmp, f"split{np_}"), os.path.join(tmp, f"split{np_}.ck")
            base = SCENE + ["-msim_output", out, "-msim_monitor_csv", out + ".csv", "-msim_checkpoint", ck, "-msim_checkpoint_every", "6"]
            r1 = mt.run(MSIM, base + ["-msim_steps", str(SPLIT), "-msim_view_final", f"binary:{out}_{SPLIT}.bin"], np_, cwd=tmp)
            r2 = mt.run(MSIM, base + ["-msim_steps", str(END), "-msim_restart", ck, "-msim_view_final", f"binary:{out}.bin"], np_, cwd=tmp)
            if not check(r1.returncode == 0 and r2.returncode == 0, f"np {np_}: both parts run ({r1.stderr.strip()[-300:]} {r2.stderr.strip()[-300:]})"):
                continue
            # contact at the checkpoint: some vertex-disjoint pair within dhat (the friction term's
            # lag and the barrier both act across the restart), by the fold's own monitor column
            x24 = final(f"{out}_{SPLIT}.bin")
            if check(len(x24) == 3 * 106, f"np {np_}: the checkpoint's positions ({len(x24) // 3} vertices)"):
                d = closest_disjoint(np.array(x24).reshape(-1, 3), tris)
                check(d < DHAT, f"np {np_}: at the checkpoint a vertex is {d:.3g} m from a triangle it is not on (dhat {DHAT} m)")
            x, rx = final(out + ".bin"), final(ref + ".bin")
            err = max(abs(a - b) for a, b in zip(x, rx))
            check(x == rx, f"np {np_}: final positions bit for bit equal to the uninterrupted run's (max difference {err:.3g} m)")
            check(frames(out) == frames(ref), f"np {np_}: the same frames, byte for byte")
            check(monitor(out + ".csv") == monitor(ref + ".csv"), f"np {np_}: the same monitor rows")
    return check.exit_code()


if __name__ == "__main__":
    raise SystemExit(main())
