#!/usr/bin/env python3
"""Friction between surfaces in self-contact (-msim_self_contact with -msim_friction mu; the term
src/implicit/terms/self_friction.cpp), against the incline's physics, at the rank count given.
A small square sheet (0.2 m, 4 vertices, 2 triangles) rests on a large fixed sheet (2 x 1 m, 2
triangles), both read as one surface mesh (an OFF written here); gravity is tilted by theta about
y, so the fixed sheet is an incline. The small sheet lies inside one triangle of the large one, more
than dhat from its edges, and slides along +x, away from them: each of its vertices has exactly one
pair within dhat (point-triangle, its normal along z), so the barrier holds m_v g cos(theta) and
friction, with that normal force lagged at each step's start, is mu m_v g cos(theta) against the
slip. Each vertex starts at the gap where the barrier's force holds its weight's normal part
(computed here from the term's rule for its weight C, as tests/contact.py does for the obstacles),
so the lagged normal force is right from the first step (a start resting in contact, within dhat:
-msim_self_contact_start_gap 0 lets it pass the start check, which refuses only crossing or
touching elements then):
- mu > tan(theta): the sheet stays; the smoothed friction acts as static below the speed eps_v, so it
  may creep, never by more than eps_v T;
- mu < tan(theta): it slides with a = g (sin theta - mu cos theta): implicit Euler under a constant
  force moves a T^2/2 (1 + 1/N) in N steps, checked within 5%;
- mu = 0 (no friction term): a = g sin theta, the same way (the check can tell friction from none);
- mu > tan(theta) with the large sheet moving up the incline at v (-msim_fix_velocity: a conveyor
  belt; the slip is relative to it): the small sheet is carried up with it, v T within eps_v T plus
  one step's v h (friction catches it up within the first step: g (sin + mu cos) h > v);
- no frame has the small sheet's vertices below the large sheet (gap > 0);
- the large sheet moving up at 1.5 m/s (15 mm a step, more than the small sheet's resting gap,
  about dhat): the small sheet is lifted, above the large sheet in every frame and resting on it
  (gap below dhat) at the end; the handles' jump at each step's start used to pass it unseen,
  leaving it under the large sheet (src/implicit/terms/self_contact.cpp, FeasibleStart_Self);
- mu > tan(theta) with an obstacle far below taken as variable bounds (-msim_contact_bounds): the
  sheet stays as without it, and one warning line says the obstacles have no friction (it needs
  the barrier's normal force); the bounds once refused every -msim_friction, this one too.
Usage: self_friction.py path/to/msim [--np N]"""
import math
import os
import sys
import tempfile

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

G = 9.81
THETA = math.radians(30)
H, STEPS, DHAT = 0.01, 40, 0.01
BIG = [(0, 0), (2, 0), (2, 1), (0, 1)]          # fixed, z = 0; split along (0,0)-(2,1)
SMALL = [(0.6, 0.05), (0.8, 0.05), (0.8, 0.25), (0.6, 0.25)]  # free; split along its 0-2 diagonal
TRIS = [(0, 1, 2), (0, 2, 3), (4, 5, 6), (4, 6, 7)]


def area(a, b, c):
    return 0.5 * abs((b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1]))


def barrier(s, dh2):
    """b(s) = -(s - dh2)^2 log(s / dh2) on squared distances, and b', b''"""
    r, l = s - dh2, math.log(s / dh2)
    return -r * r * l, -2 * r * l - r * r / s, -2 * l - 4 * r / s + r * r / (s * s)


def equilibrium_gaps():
    """each small-sheet vertex's gap d with 2 C |b'(d^2)| d = h^2 m_v g cos(theta): the scene's mass
    (1 kg) split by area, a third of each triangle's to each of its vertices; C =
    mbar / (4 s0 b''(s0) + 2 b'(s0)), s0 = dhat^2 / 4, mbar the mean vertex mass (the term's rule)"""
    xy = BIG + SMALL
    areas = [area(*(xy[v] for v in t)) for t in TRIS]
    mass = [0.0] * 8
    for t, a in zip(TRIS, areas):
        for v in t:
            mass[v] += a / sum(areas) / 3
    dh2 = DHAT * DHAT
    _, db, d2b = barrier(dh2 / 4, dh2)
    C = (1.0 / 8) / (4 * dh2 / 4 * d2b + 2 * db)
    gaps = []
    for v in range(4, 8):
        want = H * H * mass[v] * G * math.cos(THETA)
        lo, hi = 1e-9 * DHAT, DHAT
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if 2 * C * abs(barrier(mid * mid, dh2)[1]) * mid > want else (lo, mid)
        gaps.append(0.5 * (lo + hi))
    return gaps


def write_off(path):
    gaps = equilibrium_gaps()
    pts = [(x, y, 0.0) for x, y in BIG] + [(x, y, z) for (x, y), z in zip(SMALL, gaps)]
    with open(path, "w") as f:
        f.write(f"OFF\n{len(pts)} {len(TRIS)} 0\n")
        f.writelines(f"{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n" for p in pts)
        f.writelines(f"3 {t[0]} {t[1]} {t[2]}\n" for t in TRIS)
    return gaps


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_self_friction_")
    off = os.path.join(tmp, "sheets.off")
    gaps = write_off(off)
    grav = f"{G * math.sin(THETA)},0,{-G * math.cos(THETA)}"
    base = ["-msim_scene", "mesh", "-msim_mesh_file", off, "-msim_mass", "1", "-msim_fix_box", "-1,3,-1,2,-1e-6,1e-6",
            "-msim_self_contact", "-msim_self_contact_distance", str(DHAT), "-msim_self_contact_start_gap", "0", "-msim_gravity", grav,
            "-msim_integrator", "implicit_euler", "-msim_dt", str(H), "-msim_steps", str(STEPS), "-msim_output_every", "1"]
    T = STEPS * H
    eps_v = 1e-3 * math.hypot(2, 1)  # -msim_friction_eps's default: 1e-3 of the scene's diameter per second
    belt = -0.05  # m/s along x: up the incline
    bounds = ["-msim_contact_plane", "0,0,1,-0.5", "-msim_contact_bounds"]
    for np_, mu, v, extra in ((n, m, b, e) for n in mt.ranks() for m, b, e in ((0.8, 0.0, []), (0.2, 0.0, []), (0.0, 0.0, []), (0.8, belt, []), (0.8, 0.0, bounds))):
        out = os.path.join(tmp, f"mu{mu}_{v}_{len(extra)}_{np_}")
        r = mt.run(exe, base + extra + ["-msim_friction", str(mu), "-msim_fix_velocity", f"{v},0,0", "-msim_output", out], np_)
        if not check(r.returncode == 0, f"np {np_}: mu {mu}{', belt' if v else ''}{', a plane as bounds' if extra else ''}: runs ({r.stderr.strip()[-300:]})"):
            continue
        if extra:
            said = [l for l in mt.lines(r.stderr) if "warning" in l]
            check(len(said) == 1 and "-msim_friction acts between surfaces in self-contact only" in said[0],
                  f"np {np_}: mu {mu}, a plane as bounds: one warning line that the obstacles have no friction ({said})")
        series = vtu.read_pvd(os.path.join(out, "series.pvd"))
        first, least = None, float("inf")
        for _, path in series:
            d = vtu.read_vtu(path)
            free = d["points"][d["fixed"] == 0]
            least = min(least, float(free[:, 2].min()))
            first = free if first is None else first
        moved = float(free[:, 0].mean() - first[:, 0].mean())
        check(len(series) == STEPS + 1 and len(free) == 4 and least > 0,
              f"np {np_}: mu {mu}: the small sheet stays above the large one in all {len(series)} frames (least gap {least:.3g} m > 0; start {min(gaps):.3g}..{max(gaps):.3g})")
        if v:
            check(abs(moved - v * T) < eps_v * T + abs(v) * H, f"np {np_}: mu {mu} > tan(theta), the large sheet moving up at {v} m/s: carried {moved:.4g} m, v T = {v * T:.4g} m (within eps_v T + v h = {eps_v * T + abs(v) * H:.3g} m)")
        elif mu > math.tan(THETA):
            check(abs(moved) < eps_v * T, f"np {np_}: mu {mu} > tan(theta) = {math.tan(THETA):.3f}: the sheet stays (moved {moved:.3g} m < eps_v T = {eps_v * T:.3g} m)")
        else:
            a = G * (math.sin(THETA) - mu * math.cos(THETA))
            want = 0.5 * a * T * T * (1 + 1 / STEPS)
            check(abs(moved - want) <= 0.05 * want, f"np {np_}: mu {mu} < tan(theta): slides {moved:.5g} m, g (sin - mu cos) T^2/2 (1 + 1/N) = {want:.5g} m (error {abs(moved - want) / want:.2%})")
    # the large sheet lifting the small one: each step moves the handles 15 mm up at once, more than
    # the small sheet's resting gap, which they passed unseen (the sheet was left under the large
    # one, falling); now it is carried up, above the large sheet in every frame and resting on it
    # (within dhat) at the end
    # (Newton, and plain PD, which restarted such a step from x_n, left infeasible by the handles)
    lift = 1.5  # m/s along z
    for np_, solver in ((n, s_) for n in mt.ranks() for s_ in ([], ["-snes_type", "pd"])):
        out = os.path.join(tmp, f"lift_{np_}_{len(solver)}")
        r = mt.run(exe, base + solver + ["-msim_friction", "0.8", "-msim_fix_velocity", f"0,0,{lift}", "-msim_output", out], np_)
        if not check(r.returncode == 0, f"np {np_}: the large sheet lifting the small one{', PD' if solver else ''}: runs ({r.stderr.strip()[-300:]})"):
            continue
        least = float("inf")
        for t, path in vtu.read_pvd(os.path.join(out, "series.pvd")):
            d = vtu.read_vtu(path)
            gap = d["points"][d["fixed"] == 0][:, 2] - lift * t
            least = min(least, float(gap.min()))
        check(least > 0 and float(gap.max()) < DHAT, f"np {np_}{', PD' if solver else ''}: the large sheet moving up {lift * H * 1e3:.3g} mm a step under a gap of {min(gaps) * 1e3:.3g}..{max(gaps) * 1e3:.3g} mm: the small sheet above it in every frame (least gap {least:.3g} m > 0) and resting on it at the end (largest gap {float(gap.max()):.3g} m < dhat)")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
