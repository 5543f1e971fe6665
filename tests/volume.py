#!/usr/bin/env python3
"""The tets' volume term (-msim_volume, msim/volume.h), checked on every frame from the frames'
positions (signed tet volumes computed here, runs/self_contact/volume/tetcheck.py; not msim's
volume_ratio field), at the rank count given:
- a tet box squashed against its clamp by 50 g (Newton): with the term no tet is inverted in any
  frame; without it some frames have inverted tets (so the check can fail); the same with the
  barrier alone (-msim_volume_stiffness 0, whose passes skip tets), with Newton and with PD; with
  PD, Phi (evaluated in full under -info) does not rise at any step PD's bound on Phi accepted;
- moving handles: a box pressed down onto a floor, or lifted through its bottom layer in one step,
  with PD, its accelerations and Newton: no frame with an inverted tet, or one line naming the
  handles and -msim_dt (moving_handles);
- the bunny (examples/bunny.opts, PD with Anderson, 12 steps: the springs alone invert tets from
  step 9 on): the same two checks;
- at 2 ranks a box bent by 15 g with the barrier acting (J < 0.9) ends where 1 rank's does, to
  roundoff (not the axial squash: a buckling problem, where the ranks' roundoff picks the side);
- explicit integrators get the term's force and stiffness without the barrier (-msim_volume_kappa
  0; the barrier, clamped in explicit steps, could not keep tets from inverting, and is refused
  there): the Gershgorin limit the stability guard prints is lower with the term; symplectic Euler
  at half that limit runs through the squash and its inverted tets per frame are reported;
- a restart with the barrier from a checkpoint written without the term (the squashed box, 48
  tets inverted at step 3 at 1 rank) is refused in one line naming the checkpoint's state, file
  and step, with nothing written (before, the start check ran at the scene's start only, and the
  restart failed its first step's line search after writing its output);
- bad input: -msim_volume_jhat out of (0, 1) is one error line; implicit_midpoint with the barrier
  is refused (explicit integrators with it: tests/bad_input.py).
Usage: volume.py path/to/msim [--no-tetgen] [--np N]"""
import os
import re
import shutil
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "self_contact", "volume"))
import tetcheck  # noqa: E402

MSIM = mt.msim_path()
check = mt.Checks()
TETGEN = "--no-tetgen" not in sys.argv
BOX = ["-msim_scene", "box", "-msim_box_n", "6,2,2", "-msim_box_size", "0.3,0.1,0.1", "-msim_fix_plane", "x_min",
       "-msim_density", "1000", "-msim_young", "5e4", "-msim_gravity", "-500,0,0", "-msim_dt", "0.01"]
NEWTON = ["-msim_integrator", "implicit_euler", "-msim_steps", "20", "-ksp_type", "preonly", "-pc_type", "cholesky",
          "-pc_factor_mat_solver_type", "mumps"]


def inverted_frames(args, np_, out, every):
    """per frame the number of inverted tets, or None when msim failed"""
    # from the project root: the example options files name their meshes relative to it
    r = mt.run(MSIM, args + ["-msim_output", out, "-msim_output_every", str(every)], np_, cwd=mt.ROOT)
    if r.returncode:
        print(r.stderr[-1500:])
        return None
    return [int((J <= 0).sum()) for _, J in tetcheck.ratios(os.path.join(out, "series.pvd"))]


def solid(name, args, np_, tmp, every, without=True):
    """with the term no inverted tet in any frame; without it (where asked) some"""
    on = inverted_frames(args + ["-msim_volume", "1"], np_, os.path.join(tmp, name + "_on"), every)
    off = inverted_frames(args + ["-msim_volume", "0"], np_, os.path.join(tmp, name + "_off"), every) if without else []
    check(on is not None and off is not None, f"np={np_} {name}: runs with and without the term")
    if on is None or off is None:
        return
    print(f"np={np_} {name}: inverted tets per frame with the term {on}, without {off}")
    check(len(on) > 2 and max(on) == 0, f"np={np_} {name}: with -msim_volume no inverted tet in any of {len(on)} frames")
    if without:
        check(sum(1 for n in off if n > 0) > 0, f"np={np_} {name}: without it {sum(1 for n in off if n > 0)} of {len(off)} frames have inverted tets (> 0: the check can fail)")


def bound_rises(name, args, np_):
    """PD's bound on Phi (src/implicit/pd_steps.cpp, PDBound): the barrier alone gives it its
    excess over its lagged model (pd_gap), from which PD leaves its Phi check out or sizes a
    rejected step. With -info Phi is evaluated in full at both ends of every step the bound
    accepted: it must not rise beyond roundoff (1e-12 |Phi| + 1e-20 J, as in
    tests/contact_pd_refactor.py), and the bound must have accepted some steps"""
    r = mt.run_info(MSIM, args, np_, "vec")
    pairs = [(float(a), float(b)) for a, b in re.findall(r"pd bound: .*\(found\).* Phi (\S+) -> (\S+)", r.info)]
    rise = max((b - a - 1e-12 * abs(a) for a, b in pairs), default=0.0)
    check(r.returncode == 0 and len(pairs) > 0 and rise <= 1e-20, f"np={np_} {name}: Phi did not rise at any of the {len(pairs)} steps PD's bound accepted (largest rise beyond 1e-12 |Phi|: {rise:.3g} J)")
    off = mt.run_info(MSIM, args + ["-msim_volume_pd_bound", "0"], np_, "vec")
    n_off = len(re.findall(r"pd bound: ", off.info))
    check(off.returncode == 0 and n_off == 0, f"np={np_} {name}: -msim_volume_pd_bound 0 leaves the bound out ({n_off} bound lines; rc {off.returncode})")


def moving_handles(np_, tmp):
    """Moving handles (-msim_fix_velocity) and the barrier alone (the bunny's settings): a box's top
    face pressed down at 0.5 m/s onto a floor, with PD, PD + Anderson, PD + L-BFGS and Newton,
    either runs through or stops in one line naming the handles (a step whose start they invert);
    no frame has an inverted tet (plain PD and PD + Anderson wrote the handles' step through the
    tets under them as their result: J down to -1.6). Handles rising at 5 m/s through the bottom
    layer (3.3 cm) in one step: one line naming them and -msim_dt, with Newton (was a bare
    DIVERGED_LINE_SEARCH) and PD (was 5 inverted frames, then "diverged"), the last finite state
    written."""
    base = ["-msim_scene", "box", "-msim_box_n", "3,3,3", "-msim_box_size", "0.1,0.1,0.1", "-msim_density", "1000",
            "-msim_young", "1e4", "-msim_gravity", "0,0,0", "-msim_dt", "0.01", "-msim_integrator", "implicit_euler",
            "-msim_volume", "-msim_volume_stiffness", "0"]
    squash = base + ["-msim_fix_plane", "z_max", "-msim_fix_velocity", "0,0,-0.5", "-msim_contact_plane", "0,0,1,-0.005", "-msim_steps", "19"]
    rise = base + ["-msim_fix_plane", "z_min", "-msim_fix_velocity", "0,0,5", "-msim_steps", "3"]
    pd = ["-snes_type", "pd", "-snes_max_it", "50", "-snes_pd_fixed"]
    for name, args, must_stop in [("squash, PD", squash + ["-snes_type", "pd", "-snes_max_it", "500"], False),
                                  ("squash, PD + Anderson", squash + pd + ["-snes_pd_anderson", "5"], False),
                                  ("squash, PD + L-BFGS", squash + pd + ["-snes_pd_lbfgs", "5"], False),
                                  ("squash, Newton", squash, False),
                                  ("rise, Newton", rise, True), ("rise, PD", rise + pd, True)]:
        out = os.path.join(tmp, "handles")
        r = mt.run(MSIM, args + ["-msim_output", out, "-msim_output_every", "1"], np_)
        err = [l for l in mt.lines(r.stderr) if "error" in l]
        named = len(err) == 1 and "moving handles" in err[0] and "-msim_dt" in err[0]
        inverted = [int((J <= 0).sum()) for _, J in tetcheck.ratios(os.path.join(out, "series.pvd"))]
        ok = (r.returncode == 0 and not err and not must_stop) or (r.returncode != 0 and named and os.path.exists(os.path.join(out, "last_finite.vtu")))
        check(ok and max(inverted) == 0, f"np={np_} moving handles, {name}: rc {r.returncode}, inverted tets per frame {inverted}, error {err}")
        shutil.rmtree(out)


def restart_inverted(np_, tmp):
    """the squashed box's checkpoint at step 3 without the term, restarted with the barrier"""
    ck, out = os.path.join(tmp, "squash.ck"), os.path.join(tmp, "squash_restart")
    solver = NEWTON[:2] + NEWTON[4:]  # without its -msim_steps
    r = mt.run(MSIM, BOX + solver + ["-msim_steps", "3", "-msim_volume", "0", "-msim_checkpoint", ck], np_)
    if not check(r.returncode == 0, f"np={np_}: the squashed box without the term runs 3 steps ({r.stderr[-300:]})"):
        return
    r = mt.run(MSIM, BOX + solver + ["-msim_steps", "5", "-msim_volume", "1", "-msim_restart", ck, "-msim_output", out], np_)
    err = mt.lines(r.stderr)
    named = f"tets are inverted or flat in the checkpoint's state (-msim_restart {ck}: step 3, t = 0.03 s)"
    check(r.returncode != 0 and len(err) == 1 and named in err[0] and not os.path.exists(out), f"np={np_}: a restart with the barrier from its inverted tets is refused in one line naming the checkpoint, nothing written ({err[-2:]})")


def guard_limit(extra, np_):
    r = mt.run(MSIM, BOX + ["-msim_integrator", "symplectic_euler", "-msim_steps", "1", "-msim_dt", "0.01"] + extra, np_)
    m = re.search(r"stability limit h <= (\S+)", r.stderr)
    return float(m.group(1)) if m else None


for np_ in mt.ranks():
    with tempfile.TemporaryDirectory() as tmp:
        moving_handles(np_, tmp)
        restart_inverted(np_, tmp)
        solid("squashed box", BOX + NEWTON, np_, tmp, 2)
        # the barrier alone (kv 0: its passes skip the tets the safe radii prove above jhat), with
        # Newton and with PD (the bunny's solver); the squash without the term inverts (above)
        solid("squashed box, barrier alone", BOX + NEWTON + ["-msim_volume_stiffness", "0"], np_, tmp, 2, without=False)
        solid("squashed box, barrier alone, PD", BOX + ["-msim_integrator", "implicit_euler", "-msim_steps", "20", "-snes_type", "pd", "-snes_max_it", "100", "-msim_volume_stiffness", "0"], np_, tmp, 2, without=False)
        bound_rises("squashed box, barrier alone, PD", BOX + ["-msim_integrator", "implicit_euler", "-msim_steps", "20", "-snes_type", "pd", "-snes_max_it", "100", "-msim_volume", "1", "-msim_volume_stiffness", "0"], np_)
        if TETGEN:
            solid("bunny", ["-options_file", os.path.join(mt.ROOT, "examples", "bunny.opts"), "-msim_steps", "12"], np_, tmp, 1)
        if np_ > 1:
            # the box bent by 15 g across its axis, the barrier acting below J = 0.9, Newton to
            # convergence (the axial squash is a buckling problem: the ranks' roundoff picks the side)
            bent = [a if a != "-500,0,0" else "0,0,-150" for a in BOX] + NEWTON + ["-msim_steps", "10", "-snes_max_it", "300", "-msim_volume", "1", "-msim_volume_jhat", "0.9", "-msim_volume_stiffness", "5e3"]
            x1, _ = mt.final_positions(MSIM, bent, 1, tmp, "box")
            xn, _ = mt.final_positions(MSIM, bent, np_, tmp, "box")
            ok = x1 is not None and xn is not None
            d = float(np.abs(x1 - xn).max()) if ok else float("nan")
            check(ok and d <= 1e-9, f"np={np_}: the bent box's final positions with the term equal 1 rank's (max difference {d:.1e} m)")
        h_on, h_off = guard_limit(["-msim_volume", "1", "-msim_volume_kappa", "0"], np_), guard_limit(["-msim_volume", "0"], np_)
        check(h_on is not None and h_off is not None and h_on < h_off, f"np={np_}: the explicit guard's Gershgorin limit counts the term: h <= {h_on} with it, {h_off} without")
        if h_on:
            ex = inverted_frames(BOX + ["-msim_integrator", "symplectic_euler", "-msim_dt", f"{0.5 * h_on:.6g}", "-msim_steps", f"{int(0.2 / (0.5 * h_on))}", "-msim_volume", "1", "-msim_volume_kappa", "0"], np_, os.path.join(tmp, "explicit"), 10)
            check(ex is not None, f"np={np_}: symplectic Euler with the term runs through the squash at half its limit")
            print(f"np={np_}: symplectic Euler on the squash with the term (no guarantee): inverted tets per frame {ex}")
        r = mt.run(MSIM, BOX + NEWTON + ["-msim_volume_jhat", "1.5"], np_)
        lines = [l for l in mt.lines(r.stderr) if "error" in l]
        check(r.returncode != 0 and len(lines) == 1 and "-msim_volume_jhat" in lines[0], f"np={np_}: -msim_volume_jhat 1.5 is one error line naming it: {lines}")
        r = mt.run(MSIM, BOX + NEWTON + ["-msim_integrator", "implicit_midpoint", "-msim_volume", "1"], np_)
        lines = [l for l in mt.lines(r.stderr) if "error" in l]
        check(r.returncode != 0 and len(lines) == 1 and "barrier" in lines[0], f"np={np_}: implicit_midpoint with the barrier is refused in one line: {lines}")
sys.exit(check.exit_code())
