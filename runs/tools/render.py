#!/usr/bin/env python3
"""Render an msim ParaView series (.pvd) to PNG pictures and an animated GIF with matplotlib.
Usage: /usr/bin/python3 runs/tools/render.py out/cloth/series.pvd (or .xdmf) [--png out/cloth/cloth.png]
       [--gif out/cloth/cloth.gif] [--frames 50] [--view elev,azim] [--up y] [--obstacles run.opts]
The PNG shows four moments of the run side by side; the GIF plays the whole series. Springs are
drawn as lines, a surface's triangles and a solid's boundary (the faces of one tet only) shaded;
--obstacles draws the planes, spheres and boxes an options file's -msim_contact_plane, _sphere and
_box give (grey, translucent; static positions)."""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.animation import FuncAnimation, PillowWriter  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection, Poly3DCollection  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vtu import boundary_faces, read_series  # noqa: E402

UP = {"x": [1, 2, 0], "y": [2, 0, 1], "z": [0, 1, 2]}  # axes drawn as matplotlib's x, y, z
BASE = np.array([0.45, 0.62, 0.85])  # the surface colour, lit by LIGHT (in plot coordinates)
LIGHT = np.array([-0.4, -0.6, 0.7]) / np.linalg.norm([-0.4, -0.6, 0.7])


def shade(tri, two_sided):
    """Lambert shading of triangles (t, 3, 3): ambient plus diffuse from LIGHT."""
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.linalg.norm(n, axis=1, keepdims=True) + 1e-300
    d = n @ LIGHT
    d = np.abs(d) if two_sided else np.clip(d, 0, None)
    return np.clip((0.35 + 0.65 * d)[:, None] * BASE, 0, 1)


def bounds(frames, up):
    pts = np.concatenate([load()["points"][:, UP[up]] for _, load in frames[:: max(1, len(frames) // 20)] + [frames[-1]]])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2 * 1.05 + 1e-9
    return c, r


def read_obstacles(path):
    """[(kind, values)] from an options file's -msim_contact_plane / _sphere / _box lines (4, 4 and 6
    values per obstacle, several per option)"""
    found = []
    with open(path) as f:
        for line in f:
            w = line.split("#")[0].split()
            per = {"-msim_contact_plane": 4, "-msim_contact_sphere": 4, "-msim_contact_box": 6}.get(w[0] if w else "")
            if per and len(w) > 1:
                v = [float(x) for x in w[1].split(",")]
                found += [(w[0].split("_")[-1], v[k:k + per]) for k in range(0, len(v), per)]
    return found


def draw_obstacles(ax, obstacles, c, r, up):
    """the obstacles in plot coordinates, clipped to the cube of centre c and half-width r"""
    grey = dict(color="#9a9a9a", alpha=0.35, linewidth=0)
    perm = UP[up]
    for kind, v in obstacles:
        if kind == "sphere":
            u, w = np.meshgrid(np.linspace(0, 2 * np.pi, 40), np.linspace(0, np.pi, 20))
            xyz = np.array([v[0] + v[3] * np.cos(u) * np.sin(w), v[1] + v[3] * np.sin(u) * np.sin(w), v[2] + v[3] * np.cos(w)])[perm]
            ax.plot_surface(*xyz, **grey)
        elif kind == "box":
            lo, hi = np.array(v[0::2]), np.array(v[1::2])
            cmin, cmax = np.array(c) - r, np.array(c) + r  # plot coordinates
            lo, hi = np.maximum(lo[perm], cmin), np.minimum(hi[perm], cmax)
            corner = lambda b: np.where(np.array(b, dtype=bool), hi, lo)  # noqa: E731
            quads = []
            for axis in range(3):
                for side in (0, 1):
                    q = []
                    for a, b in ((0, 0), (1, 0), (1, 1), (0, 1)):
                        bits = [0, 0, 0]
                        bits[axis], bits[(axis + 1) % 3], bits[(axis + 2) % 3] = side, a, b
                        q.append(corner(bits))
                    quads.append(q)
            ax.add_collection3d(Poly3DCollection(quads, facecolors="#9a9a9a", alpha=0.3, edgecolors="#666666", linewidths=0.3))
        elif kind == "plane":
            n = np.array(v[:3])[perm] / np.linalg.norm(v[:3])
            d = v[3] / np.linalg.norm(v[:3])
            p0 = np.array(c) + (d - np.dot(n, c)) * n  # the point of the plane nearest the view's centre
            t1 = np.cross(n, [1, 0, 0] if abs(n[0]) < 0.9 else [0, 1, 0])
            t1 /= np.linalg.norm(t1)
            t2 = np.cross(n, t1)
            quad = [p0 + r * (a * t1 + b * t2) for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            ax.add_collection3d(Poly3DCollection([quad], facecolors="#9a9a9a", alpha=0.3, edgecolors="none"))


def draw(ax, grid, c, r, title, view, up, max_lines=20000, obstacles=()):
    ax.cla()
    draw_obstacles(ax, obstacles, c, r, up)
    pts, conn = grid["points"][:, UP[up]], grid["connectivity"]
    if conn.shape[1] == 2:
        if len(conn) > max_lines:  # thin very dense meshes for legibility
            conn = conn[:: len(conn) // max_lines + 1]
        ax.add_collection3d(Line3DCollection(pts[conn], colors="#1f5fa8", linewidths=0.4, alpha=0.8))
    else:
        faces = conn if conn.shape[1] == 3 else boundary_faces(conn)
        tri = pts[faces]
        # the axis permutations in UP are cyclic: they keep orientation, outward stays outward
        poly = Poly3DCollection(tri, facecolors=shade(tri, conn.shape[1] == 3), edgecolors="none")
        ax.add_collection3d(poly)
    fixed = grid["fixed"].astype(bool)
    if fixed.any():
        ax.scatter(*pts[fixed].T, color="#d62728", s=12, depthshade=False)
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1), zoom=0.85)  # room for the z label, which the full-size box clips
    ax.locator_params(nbins=4)
    ax.tick_params(labelsize=7)
    ax.view_init(elev=view[0], azim=view[1])
    names = "xyz"
    ax.set_xlabel(f"{names[UP[up][0]]} (m)")
    ax.set_ylabel(f"{names[UP[up][1]]} (m)")
    ax.set_zlabel(f"{names[UP[up][2]]} (m)")
    ax.set_title(title, fontsize=10)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("pvd")
    p.add_argument("--png")
    p.add_argument("--gif")
    p.add_argument("--frames", type=int, default=50)
    p.add_argument("--view", default="20,-60", help="elevation,azimuth of the camera in degrees")
    p.add_argument("--up", default="z", choices="xyz", help="the axis drawn upward")
    p.add_argument("--obstacles", help="an options file whose -msim_contact_plane/_sphere/_box lines are drawn")
    a = p.parse_args()
    obstacles = read_obstacles(a.obstacles) if a.obstacles else []
    view = [float(v) for v in a.view.split(",")]
    frames = read_series(a.pvd)
    if not frames:
        sys.exit(f"{a.pvd}: no frames")
    base = os.path.splitext(a.pvd)[0]
    png = a.png or base + ".png"
    gif = a.gif or base + ".gif"
    c, r = bounds(frames, a.up)

    picks = sorted(set(int(round(x)) for x in np.linspace(0, len(frames) - 1, 4)))
    fig = plt.figure(figsize=(4 * len(picks), 4.2))
    for k, i in enumerate(picks):
        ax = fig.add_subplot(1, len(picks), k + 1, projection="3d")
        draw(ax, frames[i][1](), c, r, f"t = {frames[i][0]:.3f} s", view, a.up, obstacles=obstacles)
    fig.tight_layout()
    fig.savefig(png + ".tmp.png", dpi=110)
    os.replace(png + ".tmp.png", png)
    plt.close(fig)

    step = max(1, len(frames) // a.frames)
    chosen = frames[::step]
    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="3d")

    def update(k):
        draw(ax, chosen[k][1](), c, r, f"t = {chosen[k][0]:.3f} s", view, a.up, obstacles=obstacles)

    anim = FuncAnimation(fig, update, frames=len(chosen))
    anim.save(gif + ".tmp.gif", writer=PillowWriter(fps=12), dpi=80)
    os.replace(gif + ".tmp.gif", gif)
    plt.close(fig)
    print(f"wrote {png} and {gif} ({len(chosen)} frames)")


if __name__ == "__main__":
    main()
