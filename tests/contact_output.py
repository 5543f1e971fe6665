#!/usr/bin/env python3
"""The obstacles' force in the frames (point array contact_force, .vtu and HDF5/XDMF series) and in
-msim_monitor_csv (contact_fx, fy, fz, contact_n), both computed at the end-of-step state
(msim/contact_force.h), checked against physics derived here at each rank count:
- a flat cloth of mass m at rest on the plane z >= -0.05 (with drag, so it settles): in the last
  frame every vertex's contact force is its own weight m_v g along +z (flat, its springs pull only
  in the plane), so the frame's forces sum to m g (within 1e-3), for implicit Euler's barrier
  (Newton and PD) in both series formats and for symplectic Euler's penalty;
- the same cloth under gravity tilted by theta = 0.3 (an incline) with friction mu = 0.6 > tan theta:
  it sticks, so the obstacle carries the whole weight, normal force m g cos theta plus friction
  m g sin theta up the slope: each vertex's force is -m_v g_vec and the frame's sum -m g_vec
  (within 1e-3), which the normal force alone misses by 4.5% in z and m g cos sin theta in x;
- in every frame written, the frame's forces sum to the monitor's columns of the same step (to
  roundoff: the same function on the same state), and contact_n counts the vertices whose force
  is non-zero;
- frame 0 (the cloth above the plane, beyond the contact distance) holds zero forces;
- a cloth that starts within the contact distance dhat of the plane, at d: frame 0 and the monitor's
  step-0 row hold the barrier's force of that state, kappa m |b'(d)| along +z summed to
  kappa MASS |b'(d)| with kappa = 1/(beta h^2 b''(dhat/2)) (implicit Euler beta 1, Newton and PD;
  BDF2 beta 4/9), where they showed 0 until the first step set kappa; the penalty of symplectic
  Euler and ts pushes only below the plane, where no start may be (refused), so 0 there; a run
  restarted from a checkpoint writes the uninterrupted run's rows from its first step on;
- the plane as VI bounds (-msim_contact_bounds): the same force (the bound's reaction) with every
  vertex exactly on the plane; a sphere or a tilted plane as bounds is refused in one line;
- without obstacles the frames have no contact_force array.
Usage: contact_output.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

G, MASS, N = 9.81, 2.0, 5


def read_frames(out, fmt):
    """[(step, contact_force (nv, 3) or None)] of every frame of the series in out"""
    frames = []
    if fmt == "vtu":
        for _, path in vtu.read_pvd(os.path.join(out, "series.pvd")):
            step = int(os.path.basename(path)[6:12])
            frames.append((step, vtu.read_vtu(path).get("contact_force")))
    else:
        import h5py
        for name in sorted(f for f in os.listdir(out) if f.startswith("frame_") and f.endswith(".h5")):
            with h5py.File(os.path.join(out, name), "r") as f:
                frames.append((int(name[6:12]), f["contact_force"][:].reshape(-1, 3) if "contact_force" in f else None))
    return frames


def barrier_db(d, dhat):
    """b'(d) and b''(d) of IPC's barrier b(d) = -(d - dhat)^2 log(d / dhat)"""
    lg = np.log(d / dhat)
    return -2 * (d - dhat) * lg - (d - dhat) ** 2 / d, -2 * lg - 4 * (d - dhat) / d + (d - dhat) ** 2 / d ** 2


def start_in_contact(exe, check, tmp, np_):
    """frame 0 and the step-0 row of a cloth starting at d = 0.005 from the plane, inside dhat =
    0.02, against the barrier's force derived here; then a restart's rows against the run's"""
    h, d, dhat = 0.01, 0.005, 0.02
    rest = ["-msim_cloth_n", str(N), "-msim_fix", "none", "-msim_mass", str(MASS), "-msim_contact_plane", f"0,0,1,{-d}",
            "-msim_contact_distance", str(dhat), "-msim_dt", str(h), "-msim_steps", "1"]
    db, _ = barrier_db(d, dhat)
    _, d2b_half = barrier_db(dhat / 2, dhat)
    cases = (("implicit Euler, Newton, vtu", ["-msim_integrator", "implicit_euler"], "vtu", 1.0),
             ("implicit Euler, PD, HDF5", ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-msim_output_format", "hdf5"], "hdf5", 1.0),
             ("BDF2, Newton, vtu", ["-msim_integrator", "bdf2"], "vtu", 4.0 / 9.0),
             ("symplectic Euler, penalty, vtu", ["-msim_integrator", "symplectic_euler", "-msim_dt", "0.0005"], "vtu", None),
             ("ts, penalty, vtu", ["-msim_integrator", "ts", "-msim_dt", "0.0005"], "vtu", None))
    for label, args, fmt, beta in cases:
        out, csv = os.path.join(tmp, f"start_{np_}_{len(os.listdir(tmp))}"), os.path.join(tmp, f"start_{np_}_{len(os.listdir(tmp))}.csv")
        r = mt.run(exe, rest + args + ["-msim_output", out, "-msim_monitor_csv", csv], np_)
        if not check(r.returncode == 0, f"np {np_}: starting within dhat, {label}: runs ({r.stderr.strip()[-300:]})"):
            continue
        f0 = read_frames(out, fmt)[0][1]
        row = mt.read_csv(csv)[0]
        mon = np.array([float(row[k]) for k in ("contact_fx", "contact_fy", "contact_fz")])
        want = np.array([0.0, 0.0, -MASS * db / (beta * h * h * d2b_half)]) if beta else np.zeros(3)
        count = N * N if beta else 0
        check(np.abs(f0.sum(axis=0) - want).max() <= 1e-9 * max(want[2], 1) and np.abs(mon - want).max() <= 1e-9 * max(want[2], 1)
              and int(row["contact_n"]) == count and int((np.abs(f0).sum(axis=1) > 0).sum()) == count,
              f"np {np_}: starting within dhat, {label}: frame 0 and the step-0 row hold the start's force {want} N on {count} vertices "
              f"(frame {f0.sum(axis=0)}, row {mon}, {row['contact_n']} vertices)")
    # restarted at step 2 (friction: its x_n is the checkpoint's), the rows of steps 3 and 4 are the run's
    ck, full, part = os.path.join(tmp, f"start_{np_}.ck"), os.path.join(tmp, f"full_{np_}.csv"), os.path.join(tmp, f"part_{np_}.csv")
    base = rest[:-2] + ["-msim_integrator", "implicit_euler", "-msim_friction", "0.3"]
    r1 = mt.run(exe, base + ["-msim_steps", "4", "-msim_monitor_csv", full], np_)
    r2 = mt.run(exe, base + ["-msim_steps", "2", "-msim_checkpoint", ck], np_)
    r3 = mt.run(exe, base + ["-msim_steps", "4", "-msim_restart", ck, "-msim_monitor_csv", part], np_)
    if check(r1.returncode == 0 and r2.returncode == 0 and r3.returncode == 0, f"np {np_}: starting within dhat, restarted at step 2: runs"):
        strip = lambda rows: [{k: v for k, v in row.items() if k != "wall_s"} for row in rows]  # noqa: E731
        a, b = strip(mt.read_csv(full)), strip(mt.read_csv(part))
        check(b == a[3:], f"np {np_}: starting within dhat, restarted at step 2: its rows are the run's rows of steps 3 and 4 ({b} vs {a[3:]})")


def main():
    exe, check = mt.msim_path(), mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_contact_output_")
    rest = ["-msim_cloth_n", str(N), "-msim_fix", "none", "-msim_drag", "0.5", "-msim_mass", str(MASS),
            "-msim_contact_plane", "0,0,1,-0.05", "-msim_output_every", "50"]
    cases = (("implicit Euler, Newton, vtu", ["-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "150"], "vtu"),
             ("implicit Euler, Newton, HDF5", ["-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "150", "-msim_output_format", "hdf5"], "hdf5"),
             ("implicit Euler, PD, vtu", ["-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "150", "-snes_type", "pd", "-snes_max_it", "500"], "vtu"),
             ("implicit Euler, Newton, the plane as VI bounds (-msim_contact_bounds)", ["-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "150", "-msim_contact_bounds"], "vtu"),
             ("symplectic Euler, penalty, HDF5", ["-msim_integrator", "symplectic_euler", "-msim_dt", "0.0005", "-msim_steps", "10000", "-msim_contact_stiffness", "2000",
                                                  "-msim_output_every", "2500", "-msim_output_format", "hdf5"], "hdf5"))
    tilt = 0.3
    incline = ("implicit Euler, Newton, at rest by friction on an incline (mu 0.6 > tan 0.3), vtu",
               ["-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "150", "-msim_friction", "0.6", "-msim_gravity", f"{G * np.sin(tilt)},0,{-G * np.cos(tilt)}"], "vtu")
    for np_ in mt.ranks():
        for label, args, fmt in cases + (incline,):
            gvec = np.array([G * np.sin(tilt), 0, -G * np.cos(tilt)]) if "-msim_gravity" in args else np.array([0, 0, -G])
            out, csv = os.path.join(tmp, f"{len(os.listdir(tmp))}"), os.path.join(tmp, f"mon_{len(os.listdir(tmp))}.csv")
            r = mt.run(exe, rest + args + ["-msim_output", out, "-msim_monitor_csv", csv], np_)
            if not check(r.returncode == 0, f"np {np_}: {label}: runs ({r.stderr.strip()[-300:]})"):
                continue
            rows = {int(row["step"]): row for row in mt.read_csv(csv)}
            frames = read_frames(out, fmt)
            if not check(len(frames) >= 4 and all(f is not None for _, f in frames), f"np {np_}: {label}: {len(frames)} frames, each with contact_force"):
                continue
            worst, counts = 0.0, True
            for step, f in frames:
                row = rows[step]
                mon = np.array([float(row[k]) for k in ("contact_fx", "contact_fy", "contact_fz")])
                worst = max(worst, float(np.abs(f.sum(axis=0) - mon).max()))
                counts &= int(row["contact_n"]) == int((np.abs(f).sum(axis=1) > 0).sum())
            check(worst <= 1e-9 * MASS * G and counts, f"np {np_}: {label}: every frame's forces sum to the monitor's columns of its step (worst {worst:.2g} N) and contact_n counts the vertices pushed")
            check(not frames[0][1].any(), f"np {np_}: {label}: frame 0 (above the plane) has no contact force")
            f = frames[-1][1]
            total, mv, want = f.sum(axis=0), MASS / (N * N) * G, -MASS * gvec
            check(np.abs(total - want).max() <= 1e-3 * MASS * G and (gvec[0] != 0 or np.abs(total[:2]).max() <= 1e-6 * MASS * G),
                  f"np {np_}: {label}: at rest the frame's forces sum to -m g_vec = {want} N (got {total}, rel. error {np.abs(total - want).max() / (MASS * G):.2g})")
            worst_v = np.abs(f + MASS / (N * N) * gvec).max()
            check(worst_v <= 1e-3 * mv, f"np {np_}: {label}: each vertex carries its own weight -m_v g_vec, |m_v g| = {mv:.5f} N (worst {worst_v:.2g} N off)")
            if "-msim_contact_bounds" in args:  # the bound's reaction at zero gap
                z = vtu.read_vtu(vtu.read_pvd(os.path.join(out, "series.pvd"))[-1][1])["points"][:, 2]
                check(np.abs(z + 0.05).max() == 0, f"np {np_}: {label}: every vertex rests exactly on the bound z = -0.05 (gap {np.abs(z + 0.05).max():.2g})")
        # VI bounds refuse what is not an axis-aligned plane or box, in one line
        for label, args in (("a sphere", ["-msim_contact_sphere", "0.5,0.5,-1,0.3", "-msim_contact_bounds"]),
                            ("a tilted plane under -snes_type vinewtonrsls", ["-msim_contact_plane", "1,0,1,-1", "-snes_type", "vinewtonrsls"])):
            r = mt.run(exe, ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_steps", "1"] + args, np_)
            err = mt.lines(r.stderr)
            check(r.returncode != 0 and len(err) == 1 and "axis-aligned planes and boxes only" in err[0], f"np {np_}: VI bounds with {label}: refused in one line ({err})")
        start_in_contact(exe, check, tmp, np_)
        out = os.path.join(tmp, f"none_{np_}")
        r = mt.run(exe, ["-msim_integrator", "implicit_euler", "-msim_cloth_n", "5", "-msim_steps", "2", "-msim_output", out], np_)
        if check(r.returncode == 0, f"np {np_}: without obstacles: runs"):
            check(all(f is None for _, f in read_frames(out, "vtu")), f"np {np_}: without obstacles the frames have no contact_force")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
