#!/usr/bin/env python3
"""Render an msim ParaView series (.pvd) to PNG pictures and an animated GIF with matplotlib.
Usage: /usr/bin/python3 runs/tools/render.py out/cloth/series.pvd [--png out/cloth/cloth.png]
       [--gif out/cloth/cloth.gif] [--frames 50]
The PNG shows four moments of the run side by side; the GIF plays the whole series."""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.animation import FuncAnimation, PillowWriter  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from vtu import read_pvd, read_vtu  # noqa: E402


def bounds(frames):
    pts = np.concatenate([read_vtu(f)["points"] for _, f in frames[:: max(1, len(frames) // 20)] + [frames[-1]]])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    c, r = (lo + hi) / 2, (hi - lo).max() / 2 * 1.05 + 1e-9
    return c, r


def draw(ax, grid, c, r, title, max_lines=20000):
    ax.cla()
    pts, conn = grid["points"], grid["connectivity"]
    if len(conn) > max_lines:  # thin very dense meshes for legibility
        conn = conn[:: len(conn) // max_lines + 1]
    segs = pts[conn]
    ax.add_collection3d(Line3DCollection(segs, colors="#1f5fa8", linewidths=0.4, alpha=0.8))
    fixed = grid["fixed"].astype(bool)
    if fixed.any():
        ax.scatter(*pts[fixed].T, color="#d62728", s=12, depthshade=False)
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=20, azim=-60)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.set_title(title, fontsize=10)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("pvd")
    p.add_argument("--png")
    p.add_argument("--gif")
    p.add_argument("--frames", type=int, default=50)
    a = p.parse_args()
    frames = read_pvd(a.pvd)
    if not frames:
        sys.exit(f"{a.pvd}: no frames")
    base = os.path.splitext(a.pvd)[0]
    png = a.png or base + ".png"
    gif = a.gif or base + ".gif"
    c, r = bounds(frames)

    picks = sorted(set(int(round(x)) for x in np.linspace(0, len(frames) - 1, 4)))
    fig = plt.figure(figsize=(4 * len(picks), 4.2))
    for k, i in enumerate(picks):
        ax = fig.add_subplot(1, len(picks), k + 1, projection="3d")
        draw(ax, read_vtu(frames[i][1]), c, r, f"t = {frames[i][0]:.3f} s")
    fig.tight_layout()
    fig.savefig(png + ".tmp.png", dpi=110)
    os.replace(png + ".tmp.png", png)
    plt.close(fig)

    step = max(1, len(frames) // a.frames)
    chosen = frames[::step]
    fig = plt.figure(figsize=(5, 5))
    ax = fig.add_subplot(projection="3d")

    def update(k):
        draw(ax, read_vtu(chosen[k][1]), c, r, f"t = {chosen[k][0]:.3f} s")

    anim = FuncAnimation(fig, update, frames=len(chosen))
    anim.save(gif + ".tmp.gif", writer=PillowWriter(fps=12), dpi=80)
    os.replace(gif + ".tmp.gif", gif)
    plt.close(fig)
    print(f"wrote {png} and {gif} ({len(chosen)} frames)")


if __name__ == "__main__":
    main()
