#!/usr/bin/env python3
"""PETSc's implicit TS types on msim's analytic Jacobians (-msim_integrator ts).

The scene is tests/order.py's: a chain of 8 vertices held at both ends, released at rest length
under gravity, to T = 0.3 s; the reference is RK4 at h = 1e-5, computed at 1 rank for every rank
count (it stands for the exact solution, whatever the ranks of the run checked against it: at 2
ranks its 30000 steps of 8 vertices took 11.7 s of messages where 1 rank takes 1.4 s, and an error
that 2 ranks shared with RK4 would no longer cancel out of the comparison). Checked at each rank count:
- observed order of convergence p = log2(e(h) / e(h/2)) for h, h/2, h/4 (within 0.15 of the
  method's order): beuler 1; cn, bdf (order 2), alpha2 at its default spectral radius 1 (the
  implicit midpoint rule, alpha_m = alpha_f = 1/2; on linear motion also Newmark's average
  acceleration) and at radius 0.5, the first-order alpha at radius 0.5 (PETSc's start-up
  estimates U'_0 twice too large, as alpha2's a_0: first order, observed 0.73 and 0.88, before msim
  corrected it); rosw and arkimex's defaults at least 2;
- alpha2 at radius 0.5 is exact on free fall (the chain unfixed, springs at rest length:
  x = x_0 + g t^2 / 2) to 1e-12 m: msim corrects the initial acceleration PETSc's start-up estimates
  twice too large (src/integrators/impls/ts_forms.cpp), which left v_1 off by h g / 6 at radius
  0.5 and the method first order;
- no finite-difference Jacobian: -ts_view never says "finite differences", and the TS's Jacobian is
  msim's MATNEST (first order) or its AIJ (alpha2);
- an adaptive TS (-ts_adapt_type basic) lands every -msim_dt interval, takes its own steps inside
  (more than one per interval where the tolerance is tight) and reaches the reference within a
  small multiple of its tolerance; an adaptive cn given all of T as one -msim_dt (its first step
  has no error estimate in PETSc) reaches the reference within 1e-4 at tolerance 1e-6;
- an adaptive arkimex restarted from a checkpoint at interval 10 ends interval 20 bit for bit where
  the uninterrupted run does (the checkpoint carries the step the TS proposed last); alpha2, whose
  start-up acceleration PETSc keeps privately, and an adaptive rosw with -ts_adapt_type dsp, whose
  controller filters the last error estimates privately (8.5e-9 m off after 10 more intervals at
  atol 1e-6), say at a restart that they start afresh; rk 5dp at a fixed step, whose first stage
  reuses the derivative of the step before's last (FSAL, kept privately: 1.1e-16 m off on a damped
  cloth 10 steps after a restart, with no word), warns that the run can differ in the last bits;
- a type msim has no analytic form for (irk: its stages need an AIJ Jacobian) is one error line
  naming it;
- a stage solve that stopped on a short step short of its tolerance is not accepted: -snes_type qn
  (beuler) and anderson (theta) on an 11 x 11 cloth at h = 0.02 stall (CONVERGED_SNORM_RELATIVE at
  |F| 1e-4 to 1e-3, tolerance 1e-8) and were taken as converged, the monitor's residual 0; now the
  run stops at step 1 in one error line naming the solver and "stalled". The monitor's residual is
  the true |F| (newtonls: above 0, within its tolerance); ksponly, a linearised scheme, runs with a
  note saying so and |F| after its one linear solve in the monitor;
- -snes_type ntr (it needs an objective), a factorization -pc_type on the first-order forms' nest
  Jacobian, and an error control that rejects a step -ts_max_reject times are each one msim line
  naming the options (were PETSc's "Must call SNESSetObjective()", "MatSolverType mumps does
  not support matrix type nest", and "the nonlinear solver failed"), and so are TSSolve's options,
  which msim's stepping never reads (-ts_max_time, -ts_max_steps, and -ts_dt where the TS takes
  fixed steps: each ran on without a word); the error control's give-up
  and an adaptive TS that runs out of -msim_ts_max_substeps within one -msim_dt end the run as a
  failed step does, its last finite state kept (the latter was an error from inside the step)."""
import math
import os
import re
import subprocess
import sys
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
SCENE = ["-msim_scene", "chain", "-msim_chain_n", "8", "-msim_fix", "corners", "-msim_spectrum_check", "0",
         "-snes_rtol", "1e-12", "-snes_atol", "1e-13"]
T = 0.3
HS = (4e-3, 2e-3, 1e-3)
CASES = [("beuler", [], 1), ("cn", [], 2), ("bdf", ["-ts_bdf_order", "2"], 2),
         ("alpha2", [], 2), ("alpha2", ["-ts_alpha_radius", "0.5"], 2), ("alpha", ["-ts_alpha_radius", "0.5"], 2)]
HIGHER = [("rosw", []), ("arkimex", [])]


def final(np_, args, tmp, name):
    x, r = mt.final_positions(MSIM, SCENE + args, np_, tmp, name)
    return x, r


def main():
    check = mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        ref, _ = final(1, ["-msim_integrator", "rk4", "-msim_dt", "1e-5", "-msim_steps", str(round(T / 1e-5))], tmp, "ref")
        for np_ in mt.ranks():
            check(ref is not None, f"np={np_}: the RK4 reference (1 rank) runs")
            if ref is None:
                continue

            def err(ts_type, extra, h):
                x, _ = final(np_, ["-msim_integrator", "ts", "-ts_type", ts_type, "-ts_adapt_type", "none", "-msim_dt", repr(h),
                                   "-msim_steps", str(round(T / h))] + extra, tmp, f"{ts_type}_{h}")
                return float(np.abs(x - ref).max()) if x is not None else float("nan")

            for ts_type, extra, order in CASES:
                e = [err(ts_type, extra, h) for h in HS]
                p = [math.log2(e[i] / e[i + 1]) for i in range(2)]
                check(all(abs(q - order) < 0.15 for q in p),
                      f"np={np_}: -ts_type {' '.join([ts_type] + extra)}: errors {', '.join(f'{v:.3e}' for v in e)}: observed order {p[0]:.3f}, {p[1]:.3f} (expected {order})")
            T_ff, h_ff = 0.1, 0.01
            x0, _ = final(np_, ["-msim_fix", "none", "-msim_integrator", "rk4", "-msim_gravity", "0,0,0", "-msim_dt", "1e-3", "-msim_steps", "1"], tmp, "freefall_x0")
            for radius in ("0.5",):
                x, _ = final(np_, ["-msim_fix", "none", "-msim_integrator", "ts", "-ts_type", "alpha2", "-ts_alpha_radius", radius, "-ts_adapt_type", "none",
                                   "-msim_dt", repr(h_ff), "-msim_steps", str(round(T_ff / h_ff))], tmp, f"freefall_{radius}")
                dev = float(np.abs(x - x0 - np.array([0, 0, -9.81 * T_ff ** 2 / 2])).max()) if x is not None and x0 is not None else float("nan")
                check(dev < 1e-12, f"np={np_}: -ts_type alpha2 -ts_alpha_radius {radius}: free fall exact to {dev:.2e} m after {round(T_ff / h_ff)} steps (PETSc's own start-up: h g T / 6 = {h_ff * 9.81 * T_ff / 6:.2e} m off at radius 0.5)")
            for ts_type, extra in HIGHER:
                e = [err(ts_type, extra, h) for h in HS]
                p = [math.log2(e[i] / e[i + 1]) for i in range(2)]
                check(all(q > 1.85 for q in p), f"np={np_}: -ts_type {ts_type}: errors {', '.join(f'{v:.3e}' for v in e)}: observed order {p[0]:.3f}, {p[1]:.3f} (expected at least 2)")

            for ts_type, mat in (("beuler", "type: nest"), ("cn", "type: nest"), ("bdf", "type: nest"), ("arkimex", "type: nest"), ("alpha2", "aij")):
                r = mt.run(MSIM, SCENE + ["-msim_integrator", "ts", "-ts_type", ts_type, "-msim_dt", "1e-3", "-msim_steps", "3", "-ts_view"], np_)
                view = r.stdout + r.stderr
                check(r.returncode == 0 and "finite difference" not in view and mat in view,
                      f"np={np_}: -ts_type {ts_type}: analytic Jacobian ({mat}, no finite differences) (exit {r.returncode})")

            # adaptive: the error control's own steps inside each 10 ms interval
            tol = 1e-6
            x, r = final(np_, ["-msim_integrator", "ts", "-ts_type", "bdf", "-ts_bdf_order", "2", "-ts_adapt_type", "basic",
                               "-ts_atol", repr(tol), "-ts_rtol", "0", "-msim_dt", "0.01", "-msim_steps", str(round(T / 0.01)),
                               "-msim_view"], tmp, "adaptive")
            ok = x is not None
            sub = 0
            if ok:
                for l in (r.stdout + r.stderr).splitlines():
                    if "internal steps" in l:
                        sub = int(l.split("ts:")[1].split()[0])
            e = float(np.abs(x - ref).max()) if ok else float("nan")
            check(ok and sub > 2 * round(T / 0.01) and e < 1e-3,
                  f"np={np_}: adaptive bdf: {sub} internal steps over {round(T / 0.01)} intervals, error {e:.3e} at T")

            # -ts_monitor: msim steps with TSStep, and PETSc calls the monitors in TSSolve only, so it
            # printed nothing; now a line for the start and one per internal step (once at any rank
            # count), times increasing to the last interval's end, as many steps as -msim_view counts
            r = mt.run(MSIM, SCENE + ["-msim_integrator", "ts", "-ts_type", "bdf", "-ts_adapt_type", "basic", "-ts_atol", "1e-6", "-ts_rtol", "0",
                                      "-msim_dt", "0.01", "-msim_steps", "3", "-msim_view", "-ts_monitor"], np_)
            mon = [m.groups() for m in re.finditer(r"^\s*(\d+) TS dt \S+ time (\S+)\s*$", r.stdout, re.M)]
            sub = [int(l.split("ts:")[1].split()[0]) for l in (r.stdout + r.stderr).splitlines() if "internal steps" in l]
            times = [float(t) for _, t in mon]
            check(r.returncode == 0 and len(sub) == 1 and sub[0] > 3 and [int(k) for k, _ in mon] == list(range(sub[0] + 1)) and times[0] == 0
                  and all(b > a for a, b in zip(times, times[1:])) and abs(times[-1] - 0.03) < 1e-12,
                  f"np={np_}: -ts_monitor prints the start and each internal step: {len(mon)} lines for {sub} internal steps, times {times[:2]}..{times[-1:]} (exit {r.returncode})")

            # irk's stages need an AIJ Jacobian (MatKAIJ), msim's is a nest: refused in one line
            mt.refusals(check, MSIM, SCENE + ["-msim_integrator", "ts", "-msim_dt", "1e-3", "-msim_steps", "1"],
                        (("-ts_type irk", ["-ts_type", "irk"], ["-ts_type irk", "no analytic form"]),), np_)
            # an adaptive cn over the whole of T in one -msim_dt: its first step has no error
            # estimate (PETSc's needs the previous step's state) and was accepted at all of T,
            # 2.8e-2 m off; it starts small and the controller meets the tolerance's scale
            x, r = final(np_, ["-msim_integrator", "ts", "-ts_type", "cn", "-ts_adapt_type", "basic", "-ts_atol", "1e-6", "-ts_rtol", "1e-6",
                               "-msim_dt", repr(T), "-msim_steps", "1"], tmp, "adaptive_cn")
            e = float(np.abs(x - ref).max()) if x is not None else float("nan")
            check(e < 1e-4, f"np={np_}: adaptive cn over T in one -msim_dt: error {e:.3e} at T (tolerance 1e-6)")

            for ts_type, extra in (("arkimex", ["-ts_adapt_type", "basic", "-ts_atol", "1e-6", "-ts_rtol", "0"]), ("alpha2", ["-ts_adapt_type", "none"]),
                                   ("rosw", ["-ts_adapt_type", "dsp", "-ts_atol", "1e-6", "-ts_rtol", "0"]), ("rk", ["-ts_rk_type", "5dp", "-ts_adapt_type", "none"]),
                                   ("rk", ["-ts_rk_type", "5dp", "-ts_adapt_type", "dsp", "-ts_atol", "1e-6", "-ts_rtol", "0"])):
                args = SCENE + ["-msim_integrator", "ts", "-ts_type", ts_type, "-msim_dt", "0.01"] + extra
                full, ck, part = (os.path.join(tmp, f"{ts_type}_{extra[-1]}_{k}") for k in ("full.bin", "ck", "part.bin"))
                mt.run(MSIM, args + ["-msim_steps", "20", "-msim_view_final", f"binary:{full}"], np_)
                mt.run(MSIM, args + ["-msim_steps", "10", "-msim_checkpoint", ck], np_)
                r = mt.run(MSIM, args + ["-msim_steps", "20", "-msim_restart", ck, "-msim_view_final", f"binary:{part}"], np_)
                warned = "starts afresh" in r.stderr
                if ts_type == "arkimex":
                    same = os.path.exists(full) and os.path.exists(part) and open(full, "rb").read() == open(part, "rb").read()
                    check(r.returncode == 0 and same and not warned, f"np={np_}: adaptive arkimex restarted at interval 10 ends interval 20 bit for bit as the uninterrupted run (exit {r.returncode})")
                elif ts_type == "alpha2":
                    check(r.returncode == 0 and warned, f"np={np_}: alpha2 restarted from a checkpoint warns that its TS starts afresh (exit {r.returncode})")
                elif ts_type == "rk":
                    warned = "-ts_rk_type 5dp" in r.stderr and "first same as last" in r.stderr
                    check(r.returncode == 0 and warned, f"np={np_}: rk 5dp, whose first stage is the step before's last (FSAL, its derivative kept privately), warns at a restart that the run can differ in the last bits (exit {r.returncode})")
                    if "dsp" in extra:  # and the controller's lost history, which moves the run by more than the last bits
                        check("-ts_adapt_type dsp" in r.stderr and "starts afresh" in r.stderr, f"np={np_}: rk 5dp with the dsp controller warns at a restart of the controller's history too")
                else:
                    warned = "-ts_adapt_type dsp" in r.stderr and "starts afresh" in r.stderr
                    check(r.returncode == 0 and warned, f"np={np_}: adaptive rosw with the dsp controller, whose history PETSc keeps privately, warns at a restart that it starts afresh (exit {r.returncode})")

            r = mt.run(MSIM, SCENE + ["-msim_integrator", "ts", "-ts_type", "glle", "-msim_steps", "1"], np_)
            err_lines = [l for l in r.stderr.splitlines() if "error" in l]
            check(r.returncode != 0 and len(err_lines) == 1 and "-ts_type glle" in err_lines[0],
                  f"np={np_}: -ts_type glle refused in one line naming it: {err_lines}")

            # unconverged stage solves: refused, not accepted with a residual of 0
            cloth = ["-msim_cloth_n", "11", "-msim_integrator", "ts", "-msim_dt", "0.02"]
            for ts_type, snes_type in (("beuler", "qn"), ("theta", "anderson")):
                mt.refusals(check, MSIM, cloth + ["-msim_steps", "1"],
                            ((f"-ts_type {ts_type} -snes_type {snes_type}", ["-ts_type", ts_type, "-snes_type", snes_type],
                              [f"-snes_type {snes_type} stalled", "at step 1"]),), np_)
            # what stopped inside PETSc in its words ("Must call SNESSetObjective()", "MatSolverType
            # mumps does not support matrix type nest", an error-control give-up as "the nonlinear
            # solver failed"): one msim line naming the options
            mt.refusals(check, MSIM, cloth + ["-msim_steps", "1"], (
                ("alpha2 with ntr", ["-ts_type", "alpha2", "-snes_type", "ntr", "-ksp_type", "stcg"], ["-snes_type ntr", "-msim_integrator ts", "newtonls"]),
                ("MUMPS on the nest", ["-ts_type", "beuler", "-pc_type", "lu", "-pc_factor_mat_solver_type", "mumps"], ["-pc_type lu", "nest", "-ts_schur_pc_factor_mat_solver_type"]),
                ("error control", ["-ts_type", "arkimex", "-ts_adapt_type", "basic", "-ts_atol", "1e-14", "-ts_rtol", "1e-14", "-ts_max_reject", "1"],
                 ["-ts_type arkimex", "error control", "-ts_max_reject", "not a solver failure"]),
                # options of TSSolve's loop, which msim's own stepping never reads (ran on silently)
                ("-ts_max_time", ["-ts_type", "beuler", "-ts_max_time", "0.01"], ["-ts_max_time", "not read", "-msim_steps"]),
                ("-ts_max_steps", ["-ts_type", "rosw", "-ts_max_steps", "1"], ["-ts_max_steps", "not read", "-msim_steps"]),
                ("-ts_dt at a fixed step", ["-ts_type", "cn", "-ts_dt", "0.001"], ["-ts_dt", "fixed-step", "-msim_dt"])), np_)
            # the error control's give-up ends the run as a failed step does: the last finite state kept
            out = os.path.join(tmp, f"gave_up_{np_}")
            r = mt.run(MSIM, cloth + ["-msim_steps", "3", "-ts_type", "arkimex", "-ts_adapt_type", "basic", "-ts_atol", "1e-14", "-ts_rtol", "1e-14",
                                      "-ts_max_reject", "1", "-msim_output", out, "-msim_output_every", "1"], np_)
            check(r.returncode != 0 and "the error control gave up" in r.stderr and os.path.exists(os.path.join(out, "last_finite.vtu")),
                  f"np={np_}: an error-control give-up keeps the last finite state (exit {r.returncode}, {r.stderr.strip()[-160:]})")
            # so does running out of -msim_ts_max_substeps (was an error from inside the step: no
            # last finite state, no frame of it)
            out = os.path.join(tmp, f"substeps_{np_}")
            r = mt.run(MSIM, cloth + ["-msim_steps", "3", "-ts_type", "cn", "-ts_adapt_type", "basic", "-ts_atol", "1e-8", "-ts_rtol", "1e-8",
                                      "-msim_ts_max_substeps", "5", "-msim_output", out, "-msim_output_every", "1"], np_)
            lines = mt.lines(r.stderr)
            check(r.returncode != 0 and len(lines) == 1 and "-msim_ts_max_substeps 5" in lines[0] and "last finite state is step 0" in lines[0]
                  and os.path.exists(os.path.join(out, "last_finite.vtu")),
                  f"np={np_}: 5 internal steps (-msim_ts_max_substeps) short of -msim_dt end the run in one line, the last finite state kept (exit {r.returncode}, {lines[-1:]})")
            for snes_type, lo, hi in (("newtonls", 0, 1e-6), ("ksponly", 1e-3, 1e3)):
                mon = os.path.join(tmp, f"residual_{snes_type}.csv")
                r = mt.run(MSIM, cloth + ["-ts_type", "beuler", "-snes_type", snes_type, "-msim_steps", "3", "-msim_monitor_csv", mon], np_)
                res = [float(row["residual"]) for row in mt.read_csv(mon)][1:] if r.returncode == 0 else []
                noted = "linearised scheme" in r.stderr
                check(len(res) == 3 and all(lo < v < hi for v in res) and noted == (snes_type == "ksponly"),
                      f"np={np_}: -snes_type {snes_type}: the monitor's residual is |F| ({res}, in ({lo}, {hi})), a note for the linearised scheme: {noted} (exit {r.returncode})")
            tolerance_tied(check, np_, tmp)
            stage_failures_capped(check, np_, tmp)
    return check.exit_code()


def tolerance_tied(check, np_, tmp):
    """An adaptive TS's stage solves meet -ts_atol/-ts_rtol where -snes_* tolerances are unset: on a
    damped, dragged chain with a moving handle the error against RK4 (h = 1e-5) falls as the TS's
    tolerance tightens (alpha2 at 1e-6 and 1e-7 was 1.4e-7, then 2.9e-6 m: the stages' default
    -snes_rtol 1e-8 set the error); a -snes_rtol looser than the tolerance needs is one warning.
    The reference at 1 rank, as main()'s."""
    chain = ["-msim_scene", "chain", "-msim_chain_n", "3", "-msim_fix", "edge", "-msim_mass", "3", "-msim_stiffness", "50",
             "-msim_prestretch", "1.05", "-msim_damping", "0.3", "-msim_drag", "0.2", "-msim_wind", "0.5,0,0",
             "-msim_fix_velocity", "0,0.4,0.2", "-msim_spectrum_check", "0"]
    t_end, dt = 0.2, 0.04
    ref, _ = mt.final_positions(MSIM, chain + ["-msim_integrator", "rk4", "-msim_dt", "1e-5", "-msim_steps", str(round(t_end / 1e-5))], 1, tmp, "tied_ref")
    for ts_type in ("alpha2", "cn"):
        e = []
        for tol in ("1e-6", "1e-7"):
            x, _ = mt.final_positions(MSIM, chain + ["-msim_integrator", "ts", "-ts_type", ts_type, "-ts_adapt_type", "basic", "-ts_atol", tol, "-ts_rtol", tol,
                                                     "-msim_dt", repr(dt), "-msim_steps", str(round(t_end / dt))], np_, tmp, f"tied_{ts_type}_{tol}")
            e.append(float(np.abs(x - ref).max()) if x is not None and ref is not None else float("nan"))
        check(e[1] < 0.3 * e[0], f"np={np_}: adaptive {ts_type}: error {e[0]:.2e} at -ts_atol/-ts_rtol 1e-6, {e[1]:.2e} at 1e-7 (falls with the tolerance)")
    r = mt.run(MSIM, chain + ["-msim_integrator", "ts", "-ts_type", "alpha2", "-ts_adapt_type", "basic", "-ts_atol", "1e-7", "-ts_rtol", "1e-7",
                              "-snes_rtol", "1e-8", "-msim_dt", repr(dt), "-msim_steps", "1"], np_)
    warned = [l for l in mt.lines(r.stderr) if "-snes_rtol" in l and "warning" in l]
    check(r.returncode == 0 and len(warned) == 1, f"np={np_}: -snes_rtol 1e-8 with -ts_atol/-ts_rtol 1e-7: one warning line (exit {r.returncode}, {warned})")


def stage_failures_capped(check, np_, tmp):
    """A fixed-step TS whose stage solves keep failing retried each at a quarter of the step (a box
    landing hard with -msim_volume under beuler, a scene now refused: down to 1e-11 s, for 11+
    minutes inside one -msim_dt, up to -msim_ts_max_substeps 100000): its default cap of 20 ends the
    run in one line. Here the stage solves fail by Newton's 2-iteration limit on a cloth falling
    5 cm a step, and pass only at a fraction of the step (the old binary runs on to its end); the
    line names -snes_max_it as what failed them."""
    box = ["-msim_cloth_n", "8", "-msim_fix", "corners", "-msim_integrator", "ts", "-ts_type", "beuler", "-snes_max_it", "2",
           "-msim_dt", "0.05", "-msim_steps", "4"]
    try:  # a guard against the old endless retries, not a timing check
        r = mt.run(MSIM, box, np_, timeout=600)
    except subprocess.TimeoutExpired:
        check(False, f"np={np_}: beuler's failing stages end the run (still running after 600 s)")
        return
    lines = mt.lines(r.stderr)
    check(r.returncode != 0 and len(lines) == 1 and "-msim_ts_max_substeps 20" in lines[0] and "stopped at -snes_max_it 2" in lines[0] and "raise -snes_max_it" in lines[0]
          and "last finite state is step" in lines[0],
          f"np={np_}: beuler's failing stages end the run in one line at 20 internal steps (exit {r.returncode}, {lines[-1:]})")


if __name__ == "__main__":
    sys.exit(main())
