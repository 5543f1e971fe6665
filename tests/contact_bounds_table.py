#!/usr/bin/env python3
"""A solid box as VI bounds (-msim_contact_bounds) under a cloth that drapes over it (issue 34):
an 11 x 11 cloth (1 m, nothing fixed) dropped 0.2 m onto the table box [0.2, 0.8]^2 x [-1, -0.2],
implicit Euler at h = 0.02 s, Newton (vinewtonrsls, CG on the PSD-projected Hessian). Its corners
hang over all four edges and the projected Newton converges linearly there; PETSc's bt line
search on Phi then met Phi's roundoff just above msim's absolute tolerance and stopped the run at
step 36 with DIVERGED_LINE_SEARCH (src/contact/contact_bounds.cpp: l2 now). Checked at each rank
count:
- 50 steps run (past step 36), and the cloth reached the table: in the last frame some vertex
  lies on its top face (z = -0.2 to 1e-9, inside its footprint);
- no vertex inside the box in any frame written (every step): the bounds hold each vertex in the
  half-space of the face it was outside at the step's start, so the least distance outside is 0
  at the bound, never negative (to 1e-12);
- a user's -snes_linesearch_type is honoured with -msim_contact_bounds alone (setting the VI type
  after the options were read used to reset it to bt): -snes_view shows basic when basic is asked.
The same drop with the semismooth solver (-snes_type vinewtonssls), which stopped at step 11 with
DIVERGED_LINEAR_SOLVE (CG on its nonsymmetric Fischer-Burmeister Jacobian, then a line search on Phi
rather than on its merit |phi|^2: src/integrators/impls/implicit.cpp, SetUpSemismooth):
- the same three checks (50 steps, no vertex inside in any frame, some vertex on the top face,
  which the semismooth solve reaches only to its tolerance: 1.4e-10 on |phi|, far inside 1e-9);
- its defaults: l2 (on |phi|^2) and GMRES, not CG (-snes_view); msim's shell search, which
  works on Phi, is refused in one line;
- the two solvers solve the same variational inequality each step but for the face a vertex at one
  of the table's vertical edges keeps to: held past a face's edge at a converged iterate, a vertex
  takes the face it is beyond (src/contact/contact_bounds.cpp), and the corner vertex (0.8, 0.2)
  ends on the face y = 0.2 under rsls and on x = 0.8 under ssls (step 10, both outside the box),
  which moves the corner rows by 1.2 cm by step 20. So at step 20, past the landing (steps 11-15),
  their frames agree within 2 cm, and the vertical contact force (the frames' contact_force) within
  1% (12.33 and 12.35 N; a row held on a face that is not there added 16 N, tests/contact_bounds_edge.py).
  The 1-rank rsls run is the reference at each rank count: two ranks change the summation order,
  which the frictionless cloth, balanced on the table, amplifies slowly.
The barrier (no bounds) with fixed-iteration PD on the same table, taller (top 0.1 m under a 21 x
21 cloth, -snes_pd_fixed with 10 iterations, friction 0.3, h = 0.02 s, 40 steps), and the box 2 cm
under the cloth beside a tilted plane (h = 1/30 s, 30 steps): before the seventh session's fix
(h5) the first diverged at step 12 (the cloth's edge rows, on the box's side planes, grazed past
its top edges to 1e-12 m from the sides and were locked there by their PD weights, falling at
their landing speed; and the steps started from the clamped guess, Phi far above Phi(x_n)), the
second gained 2.2 J and pressed on the table with 289 N. Checked:
- every step run, and KE + potential never above its start by more than 1% of m g h (h the drop
  to the table): a converged implicit Euler step cannot raise KE + potential + the barrier's
  energy, and the barrier holds none at the start (the cloth starts beyond dhat), so KE +
  potential cannot rise above its start; the 1% is PD-10's unconverged steps';
- at rest the contact force carries the weight: over the last 20 steps (t_a to t_b) the mean
  vertical contact force is m g + (P_b - P_a) / (t_b - t_a) by the momentum balance of the steps,
  |P| <= sqrt(2 m KE), so |mean - m g| <= (sqrt(2 m KE_a) + sqrt(2 m KE_b)) / (t_b - t_a) + 5% of
  m g (PD-10's residual); m the cloth's (-msim_scene_view).
At 1 and 2 ranks."""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

MSIM = mt.msim_path()
STEPS = 50
BOX = (0.2, 0.8, 0.2, 0.8, -1.0, -0.2)
BASE = ["-msim_cloth_n", "11", "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.02",
        "-msim_contact_box", ",".join(str(b) for b in BOX), "-msim_contact_bounds"]


def outside(p):
    """each point's distance outside the box along the face it is farthest beyond (< 0: inside)"""
    x0, x1, y0, y1, z0, z1 = BOX
    return np.max(np.stack([x0 - p[:, 0], p[:, 0] - x1, y0 - p[:, 1], p[:, 1] - y1, z0 - p[:, 2], p[:, 2] - z1]), axis=0)


def drop(tmp, name, extra, np_, check):
    """the table drop with extra options at np_ ranks, its three checks; its frames' folder or None"""
    out = os.path.join(tmp, f"{name}_{np_}")
    csv = os.path.join(tmp, f"{name}_{np_}.csv")
    r = mt.run(MSIM, BASE + extra + ["-msim_steps", str(STEPS), "-msim_output", out, "-msim_output_every", "1", "-msim_monitor_csv", csv], np_)
    rows = mt.read_csv(csv) if r.returncode == 0 else []
    check(r.returncode == 0 and len(rows) == STEPS + 1, f"np={np_} {name}: the cloth on the table as VI bounds, {STEPS} steps run" + ("" if r.returncode == 0 else ": " + r.stderr.strip()[-300:]))
    if r.returncode:
        return None
    files = mt.frames(out)
    least = min(float(outside(vtu.read_vtu(os.path.join(out, f))["points"]).min()) for f in files)
    check(len(files) == STEPS + 1 and least >= -1e-12, f"np={np_} {name}: no vertex inside the box in any of {len(files)} frames (least distance outside {least:.3g} m)")
    last = vtu.read_vtu(os.path.join(out, files[-1]))["points"]
    on_top = (np.abs(last[:, 2] - BOX[5]) <= 1e-9) & (last[:, 0] > BOX[0]) & (last[:, 0] < BOX[1]) & (last[:, 1] > BOX[2]) & (last[:, 1] < BOX[3])
    check(on_top.any(), f"np={np_} {name}: {int(on_top.sum())} vertices lie on the table's top face at step {STEPS}")
    return out


PD_TABLE = {
    "box 0.1 m under": ["-msim_cloth_n", "21", "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.02",
                        "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed", "-msim_friction", "0.3",
                        "-msim_contact_box", "0.2,0.8,0.2,0.8,-1,-0.1", "-msim_steps", "40"],
    "box 2 cm under and a plane": ["-msim_cloth_n", "21", "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.0333333333333",
                                   "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed", "-msim_friction", "0.3",
                                   "-msim_contact_box", "0.2,0.8,0.2,0.8,-1,-0.02", "-msim_contact_plane", "0.3,0,1,-0.3", "-msim_steps", "30"],
}
G = 9.81


def pd_table(tmp, name, args, np_, check):
    """PD-10 with the barrier on the table: runs, no energy gained, the contact force carries m g"""
    csv = os.path.join(tmp, f"pd_{len(name)}_{np_}.csv")
    r = mt.run(MSIM, args + ["-msim_monitor_csv", csv, "-msim_scene_view"], np_)
    steps = int(args[args.index("-msim_steps") + 1])
    rows = mt.read_csv(csv) if r.returncode == 0 else []
    check(r.returncode == 0 and len(rows) == steps + 1, f"np={np_} PD-10 on the table ({name}): {steps} steps run" + ("" if r.returncode == 0 else ": " + r.stderr.strip()[-200:]))
    if len(rows) != steps + 1:
        return
    h = float(args[args.index("-msim_dt") + 1])
    top = -float(args[args.index("-msim_contact_box") + 1].split(",")[5])
    m = float(next(l for l in r.stdout.splitlines() if l.strip().startswith("mass ")).split()[1])
    tot = [float(x["kinetic"]) + float(x["potential"]) for x in rows]
    rise = max(tot) - tot[0]
    check(rise <= 0.01 * m * G * top, f"np={np_} PD-10 on the table ({name}): KE + potential at most {rise:.3g} J above its start (<= 1% of m g h = {0.01 * m * G * top:.3g} J; m = {m:.4g} kg)")
    a, b = steps - 20, steps
    mean = sum(float(x["contact_fz"]) for x in rows[a + 1:b + 1]) / 20
    bound = (np.sqrt(2 * m * float(rows[a]["kinetic"])) + np.sqrt(2 * m * float(rows[b]["kinetic"]))) / ((b - a) * h) + 0.05 * m * G
    check(abs(mean - m * G) <= bound, f"np={np_} PD-10 on the table ({name}): mean contact force {mean:.4g} N over steps {a + 1}-{b}, m g = {m * G:.4g} N (|difference| <= {bound:.3g} N)")


def main():
    check = mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        reference = None
        for np_ in mt.ranks():
            for name, args in PD_TABLE.items():
                pd_table(tmp, name, args, np_, check)
            rsls = drop(tmp, "vinewtonrsls", [], np_, check)
            if np_ == 1:
                reference = rsls
            elif reference is None:  # run alone at --np 2: the 1-rank reference here too
                reference = drop(tmp, "vinewtonrsls", [], 1, check)
            ssls = drop(tmp, "vinewtonssls", ["-snes_type", "vinewtonssls"], np_, check)
            if reference and ssls:
                frame = mt.frames(ssls)[20]
                a = vtu.read_vtu(os.path.join(reference, frame))
                b = vtu.read_vtu(os.path.join(ssls, frame))
                diff = float(np.abs(a["points"] - b["points"]).max())
                fa, fb = float(a["contact_force"][:, 2].sum()), float(b["contact_force"][:, 2].sum())
                check(diff <= 2e-2 and abs(fa - fb) <= 0.01 * abs(fa), f"np={np_}: vinewtonssls and vinewtonrsls (1 rank) agree at step 20 to {diff:.3g} m (<= 2e-2) and in the vertical contact force, {fb:.5g} and {fa:.5g} N (1%)")
            r = mt.run(MSIM, BASE + ["-msim_steps", "1", "-snes_linesearch_type", "basic", "-snes_view"], np_)
            types = [l.split(":", 1)[1].strip() for l in r.stdout.splitlines() if l.strip().startswith("type:")]
            check(r.returncode == 0 and "vinewtonrsls" in types and "basic" in types and "bt" not in types,
                  f"np={np_}: -msim_contact_bounds -snes_linesearch_type basic: the SNES and line search types {types[:2]}")
            r = mt.run(MSIM, BASE + ["-msim_steps", "1", "-snes_type", "vinewtonssls", "-snes_view"], np_)
            types = [l.split(":", 1)[1].strip() for l in r.stdout.splitlines() if l.strip().startswith("type:")]
            check(r.returncode == 0 and types[:3] == ["vinewtonssls", "l2", "gmres"] and "cg" not in types,
                  f"np={np_}: vinewtonssls's defaults: l2 search, GMRES ({types[:4]})")
            out = os.path.join(tmp, f"shell_{np_}")
            r = mt.run(MSIM, BASE + ["-msim_steps", "1", "-snes_type", "vinewtonssls", "-snes_linesearch_type", "shell", "-msim_output", out], np_)
            err = mt.lines(r.stderr)
            check(r.returncode != 0 and len(err) == 1 and "not -snes_linesearch_type shell" in err[0] and not os.path.exists(out),
                  f"np={np_}: vinewtonssls with msim's shell search (on Phi) is refused in one line, nothing written ({err})")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
