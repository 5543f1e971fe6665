#!/usr/bin/env python3
"""Every integrator and implicit solver works on a tet solid unchanged: a 3 x 3 x 3 Kuhn box (E =
1 MPa, 1000 kg/m^3) clamped at x = 0, under gravity, at 1 and 2 ranks (or with `--np N` at N
alone: ctest's tet_methods_np1 and _np2, the 1-rank half beside other tests).
- Implicit Euler, 5 steps of h = 5 ms, solved to |g| <= 1e-10 |g0| by Newton (MUMPS Cholesky; CG +
  ICC or block Jacobi, GAMG, hypre's BoomerAMG), PD, PD + safeguarded Anderson, PETSc's Anderson with PD, L-BFGS with the PD
  Hessian, the trust region, PD with msim's parallel factor and with MUMPS: all reach the same
  x_5 to 1e-8 m (the box moves about 1e-3 m), at 2 ranks with METIS's partition and with
  contiguous blocks alike.
- Explicit: rk4 and the TS rk4 give the same x to 1e-12; symplectic Euler, explicit Euler and
  implicit Euler at h = 1e-5 s stay within 1e-6 m of RK4 over 5 ms (a first-order method under
  gravity is off by about h g t / 2 = 2.5e-7 m there).
- SLEPc's spectrum runs (-msim_spectrum), and the guard warns for symplectic Euler above 2/omega.
Usage: tet_methods.py path/to/msim [--np N]"""
import sys
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
BOX = "-msim_scene box -msim_box_n 3,3,3 -msim_box_size 0.3,0.1,0.1 -msim_fix_plane x_min -msim_density 1000 -msim_young 1e6".split()
TIGHT = "-snes_rtol 1e-10 -snes_atol 1e-16 -snes_max_it 5000".split()
IMPLICIT = {
    "newton mumps": "-snes_type newtonls -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps",
    "newton cg": "-snes_type newtonls -ksp_rtol 1e-12",
    "newton cg gamg": "-snes_type newtonls -ksp_type cg -pc_type gamg -ksp_rtol 1e-12",
    "newton cg hypre": "-snes_type newtonls -ksp_type cg -pc_type hypre -ksp_rtol 1e-12",
    "pd": "-snes_type pd",
    "pd mumps": "-snes_type pd -pd_pc_type cholesky -pd_pc_factor_mat_solver_type mumps",
    "pd anderson": "-snes_type pd -snes_pd_anderson 5",
    "anderson-pd": "-snes_type anderson -npc_snes_type pd -npc_snes_max_it 1",
    "lbfgs": "-snes_type qn -snes_qn_scale_type jacobian",
    "trust region": "-snes_type ntr",
}
check = mt.Checks(quiet=True)


def run(args, np_):
    with tempfile.TemporaryDirectory() as tmp:
        x, r = mt.final_positions(MSIM, BOX + args, np_, tmp)
        return x, r.stderr


def main():
    x0, _ = run(["-msim_steps", "1", "-msim_dt", "1e-12", "-msim_integrator", "implicit_euler"], 1)
    for np_ in mt.ranks():
        ref = None
        for name, opts in IMPLICIT.items():
            x, err = run(["-msim_integrator", "implicit_euler", "-msim_dt", "0.005", "-msim_steps", "5"] + opts.split() + TIGHT, np_)
            check(x is not None and "warning" not in err, f"np={np_} {name}: ran without warning ({err.strip()[-300:]})")
            if x is None:
                continue
            if ref is None:
                ref = x
                moved = np.abs(x - x0).max()
                check(moved > 1e-4, f"np={np_}: the box moves ({moved:.2e} m)")
            d = np.abs(x - ref).max()
            print(f"np={np_} {name:13s}: max |x - x(newton mumps)| = {d:.1e} m")
            check(d < 1e-8, f"np={np_} {name}: differs from Newton by {d:.2e} m")
            if np_ > 1 and name in ("newton mumps", "pd"):
                xn, _ = run(["-msim_integrator", "implicit_euler", "-msim_dt", "0.005", "-msim_steps", "5", "-msim_partition", "natural"] + opts.split() + TIGHT, np_)
                d = np.abs(xn - ref).max() if xn is not None else np.inf
                print(f"np={np_} {name:13s} natural partition: max |x - x(newton mumps)| = {d:.1e} m")
                check(d < 1e-8, f"np={np_} {name} with -msim_partition natural differs by {d:.2e} m")
        xr, _ = run(["-msim_integrator", "rk4", "-msim_dt", "1e-5", "-msim_steps", "500"], np_)
        xt, _ = run(["-msim_integrator", "ts", "-ts_type", "rk", "-ts_rk_type", "4", "-ts_adapt_type", "none", "-msim_dt", "1e-5", "-msim_steps", "500"], np_)
        check(xr is not None and xt is not None and np.abs(xr - xt).max() < 1e-12, f"np={np_}: rk4 and TS rk4 differ")
        xi, _ = run(["-msim_integrator", "implicit_euler", "-msim_dt", "1e-5", "-msim_steps", "500", "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps"] + TIGHT, np_)
        for name in ("symplectic_euler", "explicit_euler"):
            xe, err = run(["-msim_integrator", name, "-msim_dt", "1e-5", "-msim_steps", "500", "-msim_spectrum_check", "0"], np_)
            d = np.abs(xe - xr).max() if xe is not None else np.inf
            print(f"np={np_} {name}: max |x - x(rk4)| = {d:.1e} m after 5 ms at h = 10 us")
            check(d < 1e-6, f"np={np_} {name} differs from rk4 by {d:.2e} m")
        d = np.abs(xi - xr).max()
        print(f"np={np_} implicit_euler: max |x - x(rk4)| = {d:.1e} m after 5 ms at h = 10 us")
        check(d < 1e-6, f"np={np_} implicit Euler differs from rk4 by {d:.2e}")
        r = mt.run(MSIM, BOX + ["-msim_spectrum"], np_)
        w = float(r.stdout.split("omega_max = ")[1].split()[0]) if "omega_max = " in r.stdout else None
        check(w is not None and w > 0, f"np={np_}: -msim_spectrum gives omega_max ({r.stdout[-300:]} {r.stderr[-300:]})")
        if w:
            r = mt.run(MSIM, BOX + ["-msim_integrator", "symplectic_euler", "-msim_dt", str(2.2 / w), "-msim_steps", "1"])
            check("exceeds the stability limit" in r.stderr, f"np={np_}: the guard warns above 2/omega_max ({r.stderr.strip()})")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
