#!/usr/bin/env python3
"""Self-contact (-msim_self_contact) on a triangle surface mesh and on a tet solid's boundary faces,
checked by the independent numpy test of every frame (runs/tools/intersections.py: the surface of
the frame's cells, a tet mesh's faces of exactly one tet, and segment-triangle tests over every
pair of its triangles that share no vertex; signed tet volumes from the frame's positions,
runs/self_contact/volume/tetcheck.py; no msim code), at the rank count given:
- a sheet read as a surface mesh (an OFF written here: an n x n grid of 1 m split along
  alternating diagonals, not the cloth generator's split, so the mesh path is what is tested)
  standing on its edge on the floor (1 cm below it), perturbed out of its plane, crumples onto itself
  under gravity (as tests/self_contact.py's cloth): without the feature some frame has
  intersecting pairs (so the check can fail), with it none;
- a tet slab (-msim_scene box, one layer of cells) standing on its edge, soft, folds onto itself
  the same way: its boundary faces intersect without the feature, never with it; with the volume
  term (-msim_volume) no tet is inverted in any frame;
- at ranks > 1, the slab with -msim_self_contact_halo 0 (other ranks' elements left out) has
  intersecting pairs where the fold crosses the partition (the halo matters; the test can fail):
  there this run stands for the slab's run without the feature, which runs at 1 rank only;
- a 7 x 7 sheet (0.5 m) of handles 4 cm above a free 11 x 11 sheet (1 m), moved down at 5 m/s
  (5 cm a step: past the free sheet's plane within the first), with PD + Anderson: no
  intersecting pair in any frame and the free sheet under the handles ends below them, pushed
  along (a frame check alone could miss a sheet passing through between frames). Anderson's
  mixed iterates, unchecked by CCD, let the handles pass through (72 pairs from step 2);
- a scene with no surface (a chain) is refused in one line naming -msim_self_contact.
Usage: self_contact_mesh.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
sys.path.insert(0, os.path.join(mt.ROOT, "runs", "self_contact", "volume"))
import intersections  # noqa: E402
import tetcheck  # noqa: E402
import vtu  # noqa: E402

# Newton capped at 15 iterations a step (the test's time): every iterate the line search accepts is
# feasible, converged or not, so the guarantee checked here holds at any cap
COMMON = ["-msim_fix", "none", "-msim_perturb", "0.01", "-msim_integrator", "implicit_euler", "-msim_friction", "0.5",
          "-snes_max_it", "15", "-msim_dt", "0.02", "-msim_steps", "35"]
UP_Y = ["-msim_gravity", "0,-9.81,0", "-msim_contact_plane", "0,1,0,-0.01"]
# a slab of 8 x 1 x 8 cells (6 tets each) in the x-z plane, 3 cm thick along y, soft enough (1 kPa)
# to fold under its weight along -z: its input ids run x, then y, then z, so the directory blocks
# of 2 ranks are its lower and upper halves, and the fold brings the two together (the halo test)
SLAB = COMMON + ["-msim_gravity", "0,0,-9.81", "-msim_contact_plane", "0,0,1,-0.01", "-msim_scene", "box", "-msim_box_n", "8,1,8",
                 "-msim_box_size", "1,0.03,1", "-msim_density", "30", "-msim_young", "1e3", "-msim_volume"]


def write_sheet(path, n):
    """an n x n grid of 1 m in the x-y plane as an OFF surface, cells split along alternating
    diagonals"""
    x = [(i / (n - 1), j / (n - 1), 0.0) for j in range(n) for i in range(n)]
    tris = []
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i
            tris += [(a, b, c), (a, c, d)] if (i + j) % 2 == 0 else [(a, b, d), (b, c, d)]
    with open(path, "w") as f:
        f.write(f"OFF\n{len(x)} {len(tris)} 0\n")
        f.writelines(f"{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n" for p in x)
        f.writelines(f"3 {t[0]} {t[1]} {t[2]}\n" for t in tris)


def write_sheets(path):
    """a free 11 x 11 sheet of 1 m at z = 0 (vertices 0-120) and a 7 x 7 sheet of 0.5 m at z = 0.04
    above its middle (121-169), both centred on the z axis; returns the upper sheet's ids"""
    x, tris = [], []
    for n, size, z in ((11, 1.0, 0.0), (7, 0.5, 0.04)):
        off = len(x)
        x += [(size * (i / (n - 1) - 0.5), size * (j / (n - 1) - 0.5), z) for j in range(n) for i in range(n)]
        for j in range(n - 1):
            for i in range(n - 1):
                a = off + j * n + i
                tris += [(a, a + 1, a + n + 1), (a, a + n + 1, a + n)]
    with open(path, "w") as f:
        f.write(f"OFF\n{len(x)} {len(tris)} 0\n")
        f.writelines(f"{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n" for p in x)
        f.writelines(f"3 {t[0]} {t[1]} {t[2]}\n" for t in tris)
    return list(range(121, len(x)))


def frames(out):
    """per frame: intersecting pairs of the surface, and the inverted tets (None for a surface)"""
    pairs, inverted, V0 = [], [], None
    for _, path in vtu.read_pvd(os.path.join(out, "series.pvd")):
        d = vtu.read_vtu(path)
        x, cells = d["points"], d["connectivity"]
        pairs.append(intersections.intersecting_pairs(x, intersections.surface_triangles(cells)))
        if cells.shape[1] == 4:  # signed volumes against frame 0's (the start: no tet near inversion)
            V = tetcheck.signed_volumes(x, cells)
            V0 = V if V0 is None else V0
            inverted.append(int((V / V0 <= 0).sum()))
    return pairs, inverted


def run(exe, check, args, np_, out, what):
    r = mt.run(exe, args + ["-msim_output", out, "-msim_output_every", "5"], np_)
    if not check(r.returncode == 0, f"np {np_}: {what} runs ({r.stderr.strip()[-400:]})"):
        return None, None
    return frames(out)


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_self_contact_mesh_")
    sheet = os.path.join(tmp, "sheet.off")
    write_sheet(sheet, 11)
    SHEET = COMMON + UP_Y + ["-msim_scene", "mesh", "-msim_mesh_file", sheet]
    sheets = os.path.join(tmp, "sheets.off")
    handles = write_sheets(sheets)
    PUSH = ["-msim_scene", "mesh", "-msim_mesh_file", sheets, "-msim_fix", "list", "-msim_fix_list", ",".join(map(str, handles)),
            "-msim_fix_velocity", "0,0,-5", "-msim_gravity", "0,0,0", "-msim_self_contact", "-msim_dt", "0.01", "-msim_steps", "3",
            "-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_pd_anderson", "5", "-snes_max_it", "20", "-snes_pd_fixed"]
    for np_ in mt.ranks():
        for name, args in (("sheet", SHEET), ("slab", SLAB)):
            off = None
            if name == "sheet" or np_ == 1:
                off, _ = run(exe, check, args, np_, os.path.join(tmp, f"{name}_off_{np_}"), f"the {name} without self-contact")
                if off is not None:
                    check(max(off) > 0, f"np {np_}: without self-contact the {name} passes through itself (intersecting pairs per frame {off})")
            on, inv = run(exe, check, args + ["-msim_self_contact"], np_, os.path.join(tmp, f"{name}_on_{np_}"), f"the {name} with self-contact")
            if on is None:
                continue
            print(f"np {np_}: {name}: intersecting pairs per frame without {off}, with {on}; inverted tets with {inv}")
            check(len(on) == 8 and max(on) == 0, f"np {np_}: {name} with self-contact: no intersecting pair in any of {len(on)} frames ({on})")
            if name == "slab":
                check(max(inv) == 0, f"np {np_}: slab with self-contact and -msim_volume: no inverted tet in any frame ({inv})")
        if np_ > 1:
            nohalo, _ = run(exe, check, SLAB + ["-msim_self_contact", "-msim_self_contact_halo", "0"], np_, os.path.join(tmp, f"nohalo_{np_}"), "the slab without the halo")
            if nohalo is not None:
                check(max(nohalo) > 0, f"np {np_}: without the halo the slab's fold across ranks is missed (pairs per frame {nohalo}): the halo test can fail")
        out = os.path.join(tmp, f"push_{np_}")
        r = mt.run(exe, PUSH + ["-msim_output", out, "-msim_output_every", "1"], np_)
        if check(r.returncode == 0, f"np {np_}: handles pushing a sheet with PD + Anderson run ({r.stderr.strip()[-400:]})"):
            push, _ = frames(out)
            x = vtu.read_vtu(vtu.read_pvd(os.path.join(out, "series.pvd"))[-1][1])["points"]
            under = [v for v in range(handles[0]) if abs(x[v, 0]) <= 0.25 and abs(x[v, 1]) <= 0.25]
            top, low = float(x[under, 2].max()), float(x[handles, 2].min())
            check(len(push) == 4 and max(push) == 0 and top < low,
                  f"np {np_}: handles pushing a sheet with PD + Anderson: no intersecting pair in any of {len(push)} frames ({push}), the free sheet under them ends below them (highest z {top:.4f} < the handles' {low:.4f})")
        r = mt.run(exe, ["-msim_scene", "chain", "-msim_integrator", "implicit_euler", "-msim_steps", "1", "-msim_self_contact"], np_)
        lines = [l for l in mt.lines(r.stderr) if "-msim_self_contact" in l]
        check(r.returncode != 0 and len(lines) == 1, f"np {np_}: a chain (no surface) refuses -msim_self_contact in one line ({lines})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
