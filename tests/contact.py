#!/usr/bin/env python3
"""Contact with obstacles (msim/contact.h), at each rank count, against physics derived here:
- no penetration: a cloth dropped on a plane, a sphere and a box, with implicit Euler and Newton, PD
  and L-BFGS, has every vertex outside the obstacle in every frame (its distance, computed here
  from the frames, is > 0);
- at rest on a plane (with drag), the total contact force (-msim_monitor_csv) is the weight m g
  within 1e-3 and points along the plane's normal (also for a plane given with an unnormalised
  normal, and one facing +x under gravity along -x);
- friction on an incline (gravity tilted by theta, the plane z >= d): with mu > tan(theta) the
  cloth stays (moves less than eps_v T: the smoothed friction's static regime is a speed below
  eps_v), with mu < tan(theta) it slides with
  a = g (sin theta - mu cos theta): implicit Euler under a constant force moves a T^2/2 (1 + 1/N)
  in N steps, checked within 5%;
- explicit symplectic Euler with the penalty kc: at rest each vertex of a flat cloth carries its own
  weight, so it sinks m_v g / kc below the plane (within 1%); both stability guards count kc
  (Gershgorin: 2 / sqrt((2 sum k + kc) / m), 2 / sqrt((2 sum k + 2 kc) / m) with two obstacles a
  vertex can press into at once; SLEPc: 2 / sqrt(kc / m) for a flat cloth, whose springs are not
  stiff across its plane);
- PETSc's implicit TS (beuler, bdf, theta 0.99, alpha2 at radius 0) takes the same penalty with its
  stiffness in the Jacobian: at rest the cloth carries m g (1e-3) and sinks m_v g / kc (1%); alpha2 at
  radius 0 lands a cloth on a frictionless plane without drag and its total energy never rises above
  its start (1e-6 m g h); alpha and alpha2 with alpha_f < 1 (radius > 0), which gained 3.99 J from
  0.49 J there, are refused with an obstacle, and so are theta below 0.99 and cn;
- bad input: a sphere given with 3 values, a cloth starting inside a sphere, implicit_midpoint
  with an obstacle (refused: the barrier keeps its unknown, the midpoint, feasible, not x_{n+1})
  and ksponly with an obstacle (refused: one linear step, no feasible line search), and friction
  with a penalty (explicit or TS: it has none) or with obstacles as VI bounds and no self-contact
  (nothing for it to act on), a named -snes_type
  that is not a VI with bounds (not overridden silently), a start within 1e-6 dhat of an obstacle
  and a restart whose state is inside a (new) obstacle are one error line; with obstacles as VI
  bounds too, where a restart at rest on them (d = 0) is bit for bit. The 1e-6 dhat margin is the
  barrier's: a penalty or VI bounds start on an obstacle (d = 0, or a roundoff from it). Fixed
  vertices are not checked: a cloth pinned by an edge inside a box runs, its free vertices outside,
  without a word; handles moved into a box are named in one warning line.
Usage: contact.py path/to/msim [--np N]"""
import math
import os
import sys
import tempfile

import msimtest as mt

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "runs", "tools"))
import vtu  # noqa: E402

G = 9.81


def plane_distance(p, n, d):
    s = math.sqrt(sum(c * c for c in n))
    return (p[:, 0] * n[0] + p[:, 1] * n[1] + p[:, 2] * n[2]) / s - d / s


def sphere_distance(p, c, r):
    import numpy as np
    return np.sqrt(((p - np.array(c)) ** 2).sum(axis=1)) - r


def box_distance(p, b):
    """signed distance to the solid box b = (x0, x1, y0, y1, z0, z1): outside, to its nearest
    point; inside, minus the distance to its nearest face"""
    import numpy as np
    lo, hi = np.array(b[0::2]), np.array(b[1::2])
    q = np.maximum(np.maximum(lo - p, p - hi), 0)
    inside = np.all((p > lo) & (p < hi), axis=1)
    return np.where(inside, -np.minimum(p - lo, hi - p).min(axis=1), np.sqrt((q * q).sum(axis=1)))


def barrier_derivatives(d, dhat):
    """b'(d), b''(d) of b(d) = -(d - dhat)^2 log(d / dhat)"""
    r, l = d - dhat, math.log(d / dhat)
    return -2 * r * l - r * r / d, -2 * l - 4 * r / d + r * r / (d * d)


def equilibrium_distance(gn, h, dhat):
    """d where kappa |b'(d)| = gn with msim's default kappa = 1 / (h^2 b''(dhat/2)), by bisection
    (|b'| falls from infinity at 0 to 0 at dhat)"""
    kappa = 1 / (h * h * barrier_derivatives(dhat / 2, dhat)[1])
    lo, hi = 1e-12 * dhat, dhat
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if kappa * abs(barrier_derivatives(mid, dhat)[0]) > gn else (lo, mid)
    return 0.5 * (lo + hi)


def frames_min_distance(out, dist):
    """the least obstacle distance over every vertex of every frame, and the number of frames"""
    series = vtu.read_pvd(os.path.join(out, "series.pvd"))
    least = float("inf")
    for _, path in series:
        least = min(least, float(dist(vtu.read_vtu(path)["points"]).min()))
    return least, len(series)


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_contact_")
    cloth = ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "7", "-msim_fix", "none", "-msim_dt", "0.02", "-msim_steps", "40"]
    solvers = {"newton": [], "pd": ["-snes_type", "pd", "-snes_max_it", "200"], "lbfgs": ["-snes_type", "qn"]}
    plane = ([0, 0, 1], -0.3)
    sphere = ([0.5, 0.5, -0.6], 0.4)
    box = [0.2, 0.8, 0.2, 0.8, -1, -0.2]  # a table the cloth drapes over
    for np_ in mt.ranks():
        # (a) no vertex inside the obstacle in any frame
        for oname, opt, dist in (("plane", "-msim_contact_plane", lambda p: plane_distance(p, *plane)),
                                 ("sphere", "-msim_contact_sphere", lambda p: sphere_distance(p, *sphere)),
                                 ("box", "-msim_contact_box", lambda p: box_distance(p, box))):
            value = ",".join(str(v) for v in {"plane": plane[0] + [plane[1]], "sphere": sphere[0] + [sphere[1]], "box": box}[oname])
            for sname, sargs in solvers.items():
                out = os.path.join(tmp, f"{oname}_{sname}_{np_}")
                r = mt.run(exe, cloth + sargs + [opt, value, "-msim_output", out, "-msim_output_every", "1"], np_)
                if not check(r.returncode == 0, f"np {np_}: cloth dropped on a {oname}, {sname}: runs ({r.stderr.strip()[-300:]})"):
                    continue
                least, nframes = frames_min_distance(out, dist)
                check(nframes == 41 and least > 0, f"np {np_}: {oname}, {sname}: every vertex outside in all {nframes} frames (least distance {least:.3g} > 0)")
        # (b) at rest: the contact force is the weight, along the normal
        rest = ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_fix", "none", "-msim_dt", "0.01", "-msim_steps", "150", "-msim_drag", "0.5", "-msim_mass", "2"]
        # the cloth lies in the xy plane: flat on the first plane (25 vertices touch), on its edge
        # x = 0 on the second (5)
        for label, extra, normal, touching in (("z >= -0.05", ["-msim_contact_plane", "0,0,2,-0.1"], (0, 0, 1), 25),
                                               ("x >= -0.05 under gravity -x", ["-msim_contact_plane", "1,0,0,-0.05", "-msim_gravity", f"{-G},0,0"], (1, 0, 0), 5)):
            csv = os.path.join(tmp, f"rest_{np_}.csv")
            r = mt.run(exe, rest + extra + ["-msim_monitor_csv", csv], np_)
            if not check(r.returncode == 0, f"np {np_}: at rest on the plane {label}: runs ({r.stderr.strip()[-300:]})"):
                continue
            last = mt.read_csv(csv)[-1]
            f = [float(last[k]) for k in ("contact_fx", "contact_fy", "contact_fz")]
            mg = 2 * G
            along = sum(a * b for a, b in zip(f, normal))
            across = math.sqrt(max(sum(a * a for a in f) - along * along, 0))
            check(abs(along - mg) <= 1e-3 * mg and across <= 1e-6 * mg and int(last["contact_n"]) == touching,
                  f"np {np_}: at rest on the plane {label}: contact force {f} is m g = {mg} along {normal} (rel. error {abs(along - mg) / mg:.2g}, across {across:.2g}), {last['contact_n']} vertices in contact (want {touching})")
        # (c) friction on an incline: gravity tilted by theta about y, the plane z >= -d0 with d0
        # where the barrier's force holds the normal weight (the lagged normal force is right from
        # the first step): kappa m |b'(d0)| = m g cos(theta), kappa = 1 / (h^2 b''(dhat/2))
        theta, n, L, h, steps, dhat = 0.3, 5, 0.2, 0.01, 50, 0.002
        grav = f"{G * math.sin(theta)},0,{-G * math.cos(theta)}"
        d0 = equilibrium_distance(G * math.cos(theta), h, dhat)
        incline = ["-msim_integrator", "implicit_euler", "-msim_cloth_n", str(n), "-msim_cloth_size", str(L), "-msim_fix", "none", "-msim_gravity", grav,
                   "-msim_contact_plane", f"0,0,1,{-d0}", "-msim_contact_distance", str(dhat), "-msim_dt", str(h), "-msim_steps", str(steps)]
        x0 = L / 2  # the grid's mean x at the start
        for mu in (0.5, 0.1):
            p, r = mt.final_positions(exe, incline + ["-msim_friction", str(mu)], np_, tmp, name=f"incline_{mu}")
            if not check(p is not None, f"np {np_}: incline, mu {mu}: runs"):
                continue
            moved = float(p[:, 0].mean()) - x0
            if mu > math.tan(theta):
                # the smoothed friction holds a vertex as static below the speed eps_v (default
                # 1e-3 of the scene's diameter per second): it may creep, never faster
                eps_v = 1e-3 * L * math.sqrt(2)
                check(abs(moved) < eps_v * steps * h, f"np {np_}: mu {mu} > tan(theta) = {math.tan(theta):.3f}: the cloth stays (moved {moved:.3g} m < eps_v T = {eps_v * steps * h:.3g} m)")
            else:
                a = G * (math.sin(theta) - mu * math.cos(theta))
                T = steps * h
                want = 0.5 * a * T * T * (1 + 1 / steps)
                check(abs(moved - want) <= 0.05 * want, f"np {np_}: mu {mu} < tan(theta): slides {moved:.4g} m, g (sin - mu cos) T^2/2 (1 + 1/N) = {want:.4g} m")
        # (d) explicit symplectic Euler with the penalty: each vertex sinks m_v g / kc
        kc, mass = 2000.0, 1.0
        p, r = mt.final_positions(exe, ["-msim_integrator", "symplectic_euler", "-msim_cloth_n", "5", "-msim_fix", "none", "-msim_mass", str(mass), "-msim_drag", "0.5",
                                        "-msim_contact_plane", "0,0,1,-0.05", "-msim_contact_stiffness", str(kc), "-msim_dt", "0.0005", "-msim_steps", "6000"], np_, tmp, name="penalty")
        if check(p is not None and "warning" not in r.stderr, f"np {np_}: symplectic Euler with the penalty: runs below the guard's limit ({r.stderr.strip()[-300:]})"):
            sink = mass / 25 * G / kc
            z = p[:, 2]
            err = max(abs(z.max() - (-0.05 - sink)), abs(z.min() - (-0.05 - sink)))
            check(err <= 0.01 * sink, f"np {np_}: penalty: rest height {z.min():.8f}..{z.max():.8f} is -0.05 - m_v g / kc = {-0.05 - sink:.8f} (within 1% of the sink {sink:.3g})")
        # a penalty run checkpointed while it rests in contact (its vertices sink into the plane by
        # design) restarts and ends bit for bit where the uninterrupted run does, explicit and TS
        for label, integ, h, n in (("symplectic Euler", ["-msim_integrator", "symplectic_euler"], "0.0005", 3000), ("ts beuler", ["-msim_integrator", "ts", "-ts_type", "beuler"], "0.01", 100)):
            scene = integ + ["-msim_cloth_n", "5", "-msim_fix", "none", "-msim_mass", str(mass), "-msim_drag", "0.5", "-msim_contact_plane", "0,0,1,-0.05",
                             "-msim_contact_stiffness", str(kc), "-msim_dt", h]
            ck, whole, resumed = (os.path.join(tmp, f"penalty_{integ[1]}_{np_}{k}") for k in (".ck", "_whole.bin", "_resumed.bin"))
            r1 = mt.run(exe, scene + ["-msim_steps", str(n + n // 30), "-msim_view_final", f"binary:{whole}"], np_)
            r2 = mt.run(exe, scene + ["-msim_steps", str(n), "-msim_checkpoint", ck], np_)
            r3 = mt.run(exe, scene + ["-msim_steps", str(n + n // 30), "-msim_restart", ck, "-msim_view_final", f"binary:{resumed}"], np_)
            same = r1.returncode == r2.returncode == r3.returncode == 0 and open(whole, "rb").read() == open(resumed, "rb").read()
            check(same, f"np {np_}: {label} with the penalty, restarted at rest on the plane: bit for bit ({r3.stderr.strip()[-200:]})")
        # PETSc's implicit TS types take the penalty too, with its stiffness in their Jacobian: at rest
        # the same cloth carries its weight m g and sinks m_v g / kc (a Newton step on the force alone,
        # without the penalty's stiffness, stops short: 9.51 N of 9.81 with beuler). 100 steps: every
        # type is at rest by step 60 (at step 30 both figures are within 1e-6 of their values)
        for ts in (["beuler"], ["bdf", "-ts_adapt_type", "none"], ["theta", "-ts_theta_theta", "0.99"], ["alpha2", "-ts_alpha_radius", "0"]):
            mon = os.path.join(tmp, f"ts_penalty_{ts[0]}_{np_}.csv")
            p, r = mt.final_positions(exe, ["-msim_integrator", "ts", "-ts_type"] + ts + ["-msim_cloth_n", "5", "-msim_fix", "none", "-msim_mass", str(mass), "-msim_drag", "0.5",
                                            "-msim_contact_plane", "0,0,1,-0.05", "-msim_contact_stiffness", str(kc), "-msim_dt", "0.01", "-msim_steps", "100",
                                            "-msim_monitor_csv", mon], np_, tmp, name=f"ts_penalty_{ts[0]}")
            if check(p is not None, f"np {np_}: ts {ts[0]} with the penalty runs"):
                sink = mass / 25 * G / kc
                z = p[:, 2]
                err = max(abs(z.max() - (-0.05 - sink)), abs(z.min() - (-0.05 - sink)))
                fz = float(mt.read_csv(mon)[-1]["contact_fz"])
                check(err <= 0.01 * sink and abs(fz - mass * G) <= 1e-3 * mass * G,
                      f"np {np_}: ts {ts[0]} with the penalty: rest height {z.min():.8f}..{z.max():.8f} is -0.05 - m_v g / kc = {-0.05 - sink:.8f} (within 1% of the sink), contact force {fz:.6g} N = m g = {mass * G:.6g} N (1e-3)")
        # a flat landing on a frictionless plane, no drag, the default kc (12000 N/m on 0.01 kg:
        # omega h = 11): the total energy never rises above its start. alpha2 at radius 0 (forces
        # at x_{n+1}) keeps it (1e-6 of the 0.49 J the 5 cm drop releases); at radius 0.5 or 0.9
        # (alpha_f < 1, the penalty at x_n + alpha_f (x_{n+1} - x_n)) the same 200 steps reached
        # 3.99 and 12.1 J, and alpha at 0.9 11.6 J: alpha and alpha2 with alpha_f < 1 and an
        # obstacle are refused in one line
        land = ["-msim_integrator", "ts", "-msim_cloth_n", "10", "-msim_fix", "none", "-msim_contact_plane", "0,0,1,-0.05", "-msim_dt", "0.01", "-msim_steps", "200"]
        mon = os.path.join(tmp, f"ts_landing_{np_}.csv")
        r = mt.run(exe, land + ["-ts_type", "alpha2", "-ts_alpha_radius", "0", "-msim_monitor_csv", mon], np_)
        if check(r.returncode == 0, f"np {np_}: ts alpha2 at radius 0 lands a cloth on a plane ({r.stderr.strip()[-300:]})"):
            rows = mt.read_csv(mon)
            e = [float(row["total"]) for row in rows]
            hit = any(int(row["contact_n"]) > 0 for row in rows)
            check(hit and len(e) == 201 and max(e) <= e[0] + 1e-6 * 0.05 * G,
                  f"np {np_}: ts alpha2 at radius 0, a landing on a frictionless plane: total energy at most its start {e[0]:.3g} + 1e-6 m g h over {len(e) - 1} steps (max {max(e):.6g} J at step {e.index(max(e))}, contact seen: {hit})")
        mt.refusals(check, exe, land, tuple((f"ts {t} at radius {rad} with an obstacle", ["-ts_type", t, "-ts_alpha_radius", rad], [f"-ts_type {t}", "alpha_f", "obstacle", "not supported", "-ts_alpha_radius 0"])
                                            for t, rad in (("alpha2", "0.5"), ("alpha2", "0.9"), ("alpha", "0.5"))), np_)
        # the stability guard counts the penalty: Gershgorin omega_max^2 <= max_i (2 sum_j k_ij + kc) / m_i;
        # an interior vertex of the 5 x 5 grid has 12 springs of 1000 N/m, m_i = 1/25 kg, and
        # symplectic Euler's limit is 2 / omega_max
        kc = 1e6
        r = mt.run(exe, ["-msim_integrator", "symplectic_euler", "-msim_cloth_n", "5", "-msim_fix", "none", "-msim_contact_plane", "0,0,1,-0.05",
                         "-msim_contact_stiffness", str(kc), "-msim_dt", "0.001", "-msim_steps", "1"], np_)
        hcrit = 2 / math.sqrt((2 * 12 * 1000 + kc) * 25)
        said = [l for l in mt.lines(r.stderr) if "exceeds the stability limit" in l]
        got = float(said[0].split("h <= ")[1].split()[0]) if said else float("nan")
        check(abs(got - hcrit) <= 1e-4 * hcrit, f"np {np_}: the guard's limit with kc = {kc:g}: {got:.6g} s = 2 / sqrt((2 * 12000 + kc) / m_v) = {hcrit:.6g} s")
        # a vertex pressed into two obstacles at once (a plane and a box's top face at the same
        # height) feels 2 kc: the guard counts kc per obstacle (with one kc it let this drop run at
        # 0.001 s, above the limit, where the cloth bounced off with 24 J from a 2 cm drop)
        r = mt.run(exe, ["-msim_integrator", "symplectic_euler", "-msim_cloth_n", "5", "-msim_fix", "none", "-msim_contact_plane", "0,0,1,-0.05",
                         "-msim_contact_box", "-1,2,-1,2,-1,-0.05", "-msim_contact_stiffness", str(kc), "-msim_dt", "0.001", "-msim_steps", "1"], np_)
        hcrit = 2 / math.sqrt((2 * 12 * 1000 + 2 * kc) * 25)
        said = [l for l in mt.lines(r.stderr) if "exceeds the stability limit" in l]
        got = float(said[0].split("h <= ")[1].split()[0]) if said else float("nan")
        check(abs(got - hcrit) <= 1e-4 * hcrit, f"np {np_}: the guard's limit with two obstacles, kc = {kc:g}: {got:.6g} s = 2 / sqrt((2 * 12000 + 2 kc) / m_v) = {hcrit:.6g} s")
        # the SLEPc guard counts it too: (K + kc n n^T per vertex, M); the flat cloth's springs have
        # no stiffness across the plane (at rest length), so over a plane (n = z everywhere)
        # omega_max^2 = max(kc / m_v, the in-plane spring modes <= 24000 / m_v) = kc / m_v exactly;
        # over a sphere the normals tilt into the plane, where the springs add to kc: the limit
        # lies between Gershgorin's 2 / sqrt((24000 + kc) / m_v) and 2 / sqrt(kc / m_v)
        for label, obstacle in (("plane", ["-msim_contact_plane", "0,0,1,-0.05"]), ("sphere", ["-msim_contact_sphere", "0.5,0.5,-1,0.9"])):
            r = mt.run(exe, ["-msim_integrator", "symplectic_euler", "-msim_cloth_n", "5", "-msim_fix", "none"] + obstacle + ["-msim_spectrum_guard", "slepc",
                             "-msim_contact_stiffness", str(kc), "-msim_dt", "0.001", "-msim_steps", "1"], np_)
            hslepc = 2 / math.sqrt(kc * 25)
            said = [l for l in mt.lines(r.stderr) if "exceeds the stability limit" in l and "SLEPc" in l]
            got = float(said[0].split("h <= ")[1].split()[0]) if said else float("nan")
            if label == "plane":
                check(abs(got - hslepc) <= 1e-5 * hslepc, f"np {np_}: the SLEPc guard's limit with kc = {kc:g} over a plane: {got:.6g} s = 2 / sqrt(kc / m_v) = {hslepc:.6g} s")
            else:
                check(hcrit * (1 - 1e-6) <= got <= hslepc * (1 + 1e-6) and got < hslepc * (1 - 1e-6), f"np {np_}: the SLEPc guard's limit with kc = {kc:g} over a sphere: {got:.6g} s in [{hcrit:.6g}, {hslepc:.6g}) s")
        # (e) bad input: one error line each
        mt.refusals(check, exe, ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_steps", "1"],
                    (("a sphere of 3 values", ["-msim_contact_sphere", "0,0,0"], ["-msim_contact_sphere", "4 values"]),
                     ("a cloth starting inside a sphere", ["-msim_contact_sphere", "0.5,0.5,0,0.2"], ["vertex 12 starts inside obstacle 0", "-msim_contact_sphere"]),
                     ("implicit_midpoint with an obstacle", ["-msim_contact_plane", "0,0,1,-1", "-msim_integrator", "implicit_midpoint"], ["implicit_midpoint", "not supported"]),
                     ("Baraff-Witkin (ksponly) with an obstacle", ["-msim_contact_plane", "0,0,1,-1", "-snes_type", "ksponly"], ["-snes_type ksponly", "not supported"]),
                     ("ncg with an obstacle", ["-msim_contact_plane", "0,0,1,-1", "-snes_type", "ncg"], ["-snes_type ncg", "not supported"]),
                     ("PETSc's trust region (newtontr) with an obstacle", ["-msim_contact_plane", "0,0,1,-1", "-snes_type", "newtontr"], ["-snes_type newtontr", "not supported", "ntr"]),
                     # a nonlinear preconditioner's steps get no feasible search: only pd's stay feasible
                     ("newtonls with qn as its nonlinear preconditioner, with an obstacle", ["-msim_contact_plane", "0,0,1,-1", "-npc_snes_type", "qn"], ["-npc_snes_type qn", "obstacles", "not supported"]),
                     ("anderson with self-contact", ["-msim_self_contact", "-snes_type", "anderson"], ["-snes_type anderson", "self-contact", "not supported"]),
                     ("friction with the explicit penalty", ["-msim_contact_plane", "0,0,1,-1", "-msim_friction", "0.3", "-msim_integrator", "symplectic_euler"], ["-msim_friction", "symplectic_euler", "not supported"]),
                     ("friction with TS's penalty", ["-msim_contact_plane", "0,0,1,-1", "-msim_friction", "0.3", "-msim_integrator", "ts"], ["-msim_friction", "-msim_integrator ts", "not supported"]),
                     ("a named -snes_type that is not a VI with obstacles as bounds", ["-msim_contact_plane", "0,0,1,-1", "-msim_contact_bounds", "-snes_type", "pd"], ["-msim_contact_bounds", "not -snes_type pd"]),
                     ("friction with obstacles as variable bounds and no self-contact", ["-msim_contact_plane", "0,0,1,-1", "-msim_friction", "0.3", "-msim_contact_bounds"], ["-msim_friction", "variable bounds", "not supported", "-msim_self_contact"]),
                     ("a cloth starting a roundoff (2.2e-16 m) from a box", ["-msim_contact_box", "1.0000000000000002,2,0,1,-1,1"], ["starts at distance 2.22045e-16 from obstacle 0", "-msim_contact_box", "below 1e-6 of the contact distance"])), np_)
        # the start's margin of 1e-6 dhat is the barrier's (its force nearer is beyond any step's
        # scale); a penalty (explicit, ts) and VI bounds have no dhat and start on an obstacle well:
        # a roundoff from a box, or exactly on a plane (where the bounds rest). Inside is refused
        # for them too. All were refused before, as for the barrier
        on = ["-msim_cloth_n", "5", "-msim_fix", "none", "-msim_steps", "3"]
        for label, args in (("symplectic Euler, a roundoff from a box", ["-msim_integrator", "symplectic_euler", "-msim_contact_box", "1.0000000000000002,2,0,1,-1,1"]),
                            ("ts, exactly on a plane", ["-msim_integrator", "ts", "-msim_contact_plane", "0,0,1,0"]),
                            ("VI bounds, exactly on a plane", ["-msim_integrator", "implicit_euler", "-msim_contact_bounds", "-msim_contact_plane", "0,0,1,0"])):
            r = mt.run(exe, on + args, np_)
            check(r.returncode == 0 and not r.stderr.strip(), f"np {np_}: {label}: starts and runs ({r.stderr.strip()[-300:]})")
        mt.refusals(check, exe, on, (("VI bounds, a cloth starting 1e-300 inside a plane", ["-msim_integrator", "implicit_euler", "-msim_contact_bounds", "-msim_contact_plane", "0,0,1,1e-300"],
                                      ["vertex 0 starts inside obstacle 0", "-msim_contact_plane"]),), np_)
        # fixed vertices are no unknowns: neither the start check nor the barrier sees them, so a
        # cloth pinned by an edge inside a table (a box) is a legitimate scene; its free vertices
        # stay outside (the penalty's may sink in by design: it only runs)
        table = (-0.5, 0.1, -0.5, 1.5, -0.5, 0.5)
        pinned = ["-msim_cloth_n", "5", "-msim_fix_box", "-1,0.05,-1,2,-1,1", "-msim_contact_box", ",".join(str(b) for b in table), "-msim_steps", "20"]
        for label, args, outside in (("the barrier", ["-msim_integrator", "implicit_euler", "-msim_dt", "0.02"], 0.0),
                                     ("VI bounds", ["-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-msim_contact_bounds"], 0.0),
                                     ("ts beuler's penalty", ["-msim_integrator", "ts", "-ts_type", "beuler", "-msim_dt", "0.02"], None)):
            p, r = mt.final_positions(exe, pinned + args, np_, tmp, name="pinned")
            if check(p is not None, f"np {np_}: a cloth pinned by an edge inside a box, {label}: runs"):
                d, fixed = box_distance(p, table), p[:, 0] == 0
                check(fixed.sum() == 5 and (d[fixed] < 0).all() and (outside is None or d[~fixed].min() >= outside) and not r.stderr.strip(),
                      f"np {np_}: pinned inside a box, {label}: the 5 fixed vertices inside (distance {d[fixed].max():.3g}), the free ones outside (least {d[~fixed].min():.3g}), nothing said ({r.stderr.strip()[-300:]!r})")
        # handles moving into an obstacle (at x = -0.1, step 5, past the box's face at -0.09) go on
        # inside it, as no obstacle acts on a prescribed vertex: one warning line says so, naming
        # the first vertex, the obstacle and the step (the run went on without a word)
        r = mt.run(exe, ["-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-msim_steps", "8", "-msim_cloth_n", "5", "-msim_fix_box", "-1,0.05,-1,2,-1,1",
                         "-msim_contact_box", "-0.5,-0.09,-0.5,1.5,-0.5,0.5", "-msim_fix_velocity", "-1,0,0"], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode == 0 and len(lines) == 1 and lines[0].startswith("msim: warning: fixed vertex 0 enters obstacle 0 (-msim_contact_box) at step 5: obstacles do not act on prescribed vertices"),
              f"np {np_}: handles driven into a box: one warning line ({lines!r})")
        # the run that fails for it says so too (only runs that ended did): corners driven 0.3 m
        # into a floor stretch the cloth held above it until the run diverges at step 20
        r = mt.run(exe, ["-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-msim_steps", "20", "-msim_cloth_n", "11", "-msim_fix", "corners",
                         "-msim_fix_velocity", "0,0,-1", "-msim_contact_plane", "0,0,1,-0.1"], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode != 0 and len(lines) == 2 and lines[0].startswith("msim: warning: fixed vertex 110 enters obstacle 0 (-msim_contact_plane) at step 6:")
              and lines[1].startswith("msim: error: diverged at step 20"),
              f"np {np_}: handles driven into a floor until the run diverges: the warning and the error ({lines!r})")
        # pd as newtonls's nonlinear preconditioner is the one composition allowed with a barrier
        # (its steps stay feasible): the cloth lands on a plane and stays out of it
        p, r = mt.final_positions(exe, ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_fix", "none", "-msim_dt", "0.02", "-msim_steps", "20",
                                        "-msim_contact_plane", "0,0,1,-0.1", "-npc_snes_type", "pd", "-npc_snes_max_it", "2", "-npc_snes_pd_fixed"], np_, tmp, name="npc_pd")
        if check(p is not None, f"np {np_}: newtonls with pd as its nonlinear preconditioner, on a plane: runs"):
            check(-0.1 < p[:, 2].min() < -0.09, f"np {np_}: newtonls with pd as its preconditioner: the cloth rests on the plane z = -0.1, outside it (least z {p[:, 2].min():.6g})")
        # a restart checks its state against the obstacles as a start does (they are options, not
        # part of the checkpoint): a plane added across the checkpoint's cloth is refused in one
        # line, before any output
        ck, out = os.path.join(tmp, f"ck_{np_}"), os.path.join(tmp, f"restart_out_{np_}")
        fall = ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_fix", "none", "-msim_dt", "0.02"]
        r = mt.run(exe, fall + ["-msim_steps", "5", "-msim_checkpoint", ck], np_)
        if check(r.returncode == 0, f"np {np_}: the checkpoint run ({r.stderr.strip()[-300:]})"):
            r = mt.run(exe, fall + ["-msim_steps", "10", "-msim_restart", ck, "-msim_contact_plane", "0,0,1,-0.03", "-msim_output", out], np_)
            err = mt.lines(r.stderr)
            check(r.returncode != 0 and len(err) == 1 and "at the restart (t = 0.1 s) inside obstacle 0" in err[0] and not os.path.exists(out),
                  f"np {np_}: a restart whose cloth is inside a new plane: one error line naming it, no output ({err})")
        # with obstacles as VI bounds (which take them out of the barrier's list, where that check
        # looked) the restart is checked against the bounds: a cloth resting on a plane as a bound,
        # at d = 0 exactly, restarts bit for bit; the plane moved up across the checkpoint's cloth
        # is refused in one line, before any output (it ran on, projected out of the plane)
        bound = ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_fix", "none", "-msim_dt", "0.02", "-msim_contact_bounds"]
        onplane = bound + ["-msim_contact_plane", "0,0,1,-0.05"]
        ck, whole, resting, resumed, mon, out = (os.path.join(tmp, f"bounds_{k}_{np_}") for k in ("ck", "whole.bin", "resting.bin", "resumed.bin", "m.csv", "out"))
        r1 = mt.run(exe, onplane + ["-msim_steps", "30", "-msim_view_final", f"binary:{whole}"], np_)
        r2 = mt.run(exe, onplane + ["-msim_steps", "20", "-msim_checkpoint", ck, "-msim_view_final", f"binary:{resting}", "-msim_monitor_csv", mon], np_)
        r3 = mt.run(exe, onplane + ["-msim_steps", "30", "-msim_restart", ck, "-msim_view_final", f"binary:{resumed}"], np_)
        if check(r1.returncode == r2.returncode == r3.returncode == 0, f"np {np_}: a cloth resting on a plane as bounds, checkpointed and restarted ({(r1.stderr + r2.stderr + r3.stderr).strip()[-300:]})"):
            z = mt.read_binary_vec(resting)[2::3]
            check(min(z) == max(z) == -0.05 and int(mt.read_csv(mon)[-1]["contact_n"]) == 25, f"np {np_}: bounds: the checkpoint's cloth rests on the plane at d = 0 exactly (z {min(z)!r}..{max(z)!r})")
            check(mt.read_binary_vec(whole) == mt.read_binary_vec(resumed), f"np {np_}: bounds: the restarted run ends bit for bit where the uninterrupted one does")
            r = mt.run(exe, bound + ["-msim_contact_plane", "0,0,1,-0.02", "-msim_steps", "30", "-msim_restart", ck, "-msim_output", out], np_)
            err = mt.lines(r.stderr)
            check(r.returncode != 0 and len(err) == 1 and "at the restart (t = 0.4 s) inside obstacle 0 (-msim_contact_plane, distance -0.03)" in err[0] and not os.path.exists(out),
                  f"np {np_}: bounds: a restart whose cloth is inside the plane moved up: one error line naming it, no output ({err})")
        # a moving obstacle gives the scene its kinetic energy, which the divergence check counts: a
        # ball rising at 1 m/s through a cloth in zero gravity pushes it along (it diverged at step
        # 10 when the energy scale, 0 here, did not count the ball's speed), no vertex inside it
        mon = os.path.join(tmp, f"push_{np_}.csv")
        p, r = mt.final_positions(exe, ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "11", "-msim_fix", "none", "-msim_dt", "0.01", "-msim_steps", "30",
                                        "-msim_gravity", "0,0,0", "-msim_contact_sphere", "0.5,0.5,-0.3,0.2", "-msim_contact_velocity", "0,0,1", "-msim_monitor_csv", mon], np_, tmp, name="push")
        if check(p is not None, f"np {np_}: a ball rising through the cloth in zero gravity runs 30 steps"):
            least = sphere_distance(p, (0.5, 0.5, -0.3 + 30 * 0.01), 0.2).min()
            check(least > 0 and float(mt.read_csv(mon)[-1]["contact_fz"]) > 0, f"np {np_}: the pushed cloth stays outside the ball (least distance {least:.3g} m) and is pushed up")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
