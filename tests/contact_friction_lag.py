#!/usr/bin/env python3
"""Friction with obstacles under IPC's lag iterations (-msim_friction_lag_iterations, friction.cpp):
each step solved again with the normal forces and tangent bases taken at the previous solve's
result until they stop changing, so that the friction of a step is that of where it ends. At the
rank count given:
- a 5 x 5 cloth 1 mm above a plane under gravity tilted by 0.3 rad (mu 0.3 < tan 0.3: it slides,
  and bounces off the plane at the start, its barrier's stored energy springing it up): no monitor
  row has friction (contact_fx, fy) where no vertex is within the contact distance (contact_n 0),
  and in every frame each vertex's force keeps within Coulomb's cone, |f_t| <= mu f_n, to the
  lag's tolerance (-msim_friction_lag_rtol r of the frame's largest normal force: the forces that
  acted were taken at the last lag point, within r of the result's), and friction somewhere is
  on the cone (sliding), so the cone is tested where it binds. Lagged at the step's start alone,
  2.04 N of friction acted at a step that ended with no contact (step 4), and one vertex carried
  33 times mu f_n;
- the same cloth dropped 4 mm onto the plane with mu 0.4 > tan 0.3 sticks where it lands: its mean
  x after 0.4 s at a step of 0.02 s is within 0.5 mm of that at 0.001 s (1.27 mm down the slope
  there; 0.86 mm at 0.02 s). Lagged at the step's start alone the landing step has no friction,
  and the cloth slid 1.33 mm at 0.001 s, 4.12 mm at 0.02 s and 17.9 mm at 0.05 s;
- BDF2 with PD-10 and lag iterations on the dropped cloth with mu 0.3 (it bounces down the slope),
  checkpointed at step 30 in contact and restarted,
  ends bit for bit as the uninterrupted run (a step's lag starts afresh from its x_n, so nothing
  of it needs carrying).
Usage: contact_friction_lag.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

THETA, G, RTOL = 0.3, 9.81, 1e-2
BASE = ["-msim_cloth_n", "5", "-msim_cloth_size", "0.2", "-msim_fix", "none", "-msim_integrator", "implicit_euler",
        "-msim_gravity", f"{G * np.sin(THETA)},0,{-G * np.cos(THETA)}",
        "-msim_friction_lag_iterations", "10", "-msim_friction_lag_rtol", str(RTOL)]


def sliding(exe, check, np_, tmp):
    """the bouncing, sliding cloth: the monitor's rows and each frame's per-vertex forces"""
    mu, out, csv = 0.3, os.path.join(tmp, "slide"), os.path.join(tmp, "slide.csv")
    args = BASE + ["-msim_contact_plane", "0,0,1,-0.001", "-msim_friction", str(mu), "-msim_dt", "0.001", "-msim_steps", "250",
                   "-msim_monitor_csv", csv, "-msim_output", out, "-msim_output_every", "1"]
    r = mt.run(exe, args, np_)
    if not check(r.returncode == 0, f"np {np_}: the sliding cloth runs with lag iterations"):
        print(r.stderr[-1500:])
        return
    rows = mt.read_csv(csv)
    free = [int(w["step"]) for w in rows if int(w["contact_n"]) == 0]
    stray = [int(w["step"]) for w in rows if int(w["contact_n"]) == 0 and (float(w["contact_fx"]) != 0 or float(w["contact_fy"]) != 0)]
    check(free and not stray, f"np {np_}: no friction in the monitor's {len(free)} rows without contact (rows with some: {stray[:5]})")
    worst, on_cone, frames = 0.0, 0, 0
    for _, path in vtu.read_pvd(os.path.join(out, "series.pvd")):
        f = vtu.read_vtu(path)["contact_force"]
        fn, ft = f[:, 2], np.hypot(f[:, 0], f[:, 1])
        frames += 1
        worst = max(worst, (ft - mu * (fn + RTOL * max(fn.max(), 0))).max())
        on_cone += int(((fn > 0) & (ft >= 0.99 * mu * fn)).sum())
    check(frames == 251 and worst <= 1e-9, f"np {np_}: in all {frames} frames each vertex's |f_t| <= mu (f_n + r max f_n) (largest excess {worst:.3g} N)")
    check(on_cone > 0, f"np {np_}: the cone binds: {on_cone} vertex-frames slide at |f_t| >= 0.99 mu f_n")


def landing(exe, check, np_, tmp):
    """the dropped cloth that sticks: its mean x at two step sizes"""
    x = {}
    for dt in (0.001, 0.02):
        args = BASE + ["-msim_contact_plane", "0,0,1,-0.004", "-msim_friction", "0.4", "-msim_dt", str(dt), "-msim_steps", str(int(round(0.4 / dt)))]
        p, _ = mt.final_positions(exe, args, np_, tmp, name=f"land{dt}")
        if not check(p is not None, f"np {np_}: the landing cloth runs at dt {dt}"):
            return
        start = 0.1  # the cloth's mean x at the start: cloth_size 0.2 from the origin
        x[dt] = p[:, 0].mean() - start
    check(abs(x[0.02] - x[0.001]) < 5e-4, f"np {np_}: the cloth stuck where it landed: {1e3 * x[0.02]:.2f} mm down the slope at dt 0.02, {1e3 * x[0.001]:.2f} mm at 0.001 (within 0.5 mm)")


def restart(exe, check, np_, tmp):
    """BDF2 with PD-10 (its history and the PD weights in the checkpoint) on the cloth dropped 4 mm
    with mu 0.3, which bounces along the slope: checkpointed at step 30 in contact and restarted to
    45, bit for bit the uninterrupted run"""
    scene = BASE + ["-msim_contact_plane", "0,0,1,-0.004", "-msim_friction", "0.3", "-msim_dt", "0.002", "-msim_integrator", "bdf2",
                    "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"]
    ref, rs, ck, csv = (os.path.join(tmp, n) for n in ("ref.bin", "rs.bin", "run.ck", "ck.csv"))
    runs = [mt.run(exe, scene + ["-msim_steps", "45", "-msim_view_final", f"binary:{ref}"], np_, cwd=tmp),
            mt.run(exe, scene + ["-msim_steps", "30", "-msim_checkpoint", ck, "-msim_checkpoint_every", "30", "-msim_monitor_csv", csv], np_, cwd=tmp),
            mt.run(exe, scene + ["-msim_steps", "45", "-msim_restart", ck, "-msim_view_final", f"binary:{rs}"], np_, cwd=tmp)]
    if not check(all(r.returncode == 0 for r in runs), f"np {np_}: bdf2 with lag iterations, checkpointed and restarted, runs"):
        print("".join(r.stderr for r in runs)[-1500:])
        return
    check(int(mt.read_csv(csv)[-1]["contact_n"]) > 0, f"np {np_}: in contact at the checkpoint")
    check(mt.read_binary_vec(rs) == mt.read_binary_vec(ref), f"np {np_}: bdf2 with lag iterations restarted at step 30 ends bit for bit as the uninterrupted run")


def main():
    exe, check = mt.msim_path(), mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            sliding(exe, check, np_, tmp)
            landing(exe, check, np_, tmp)
            restart(exe, check, np_, tmp)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
