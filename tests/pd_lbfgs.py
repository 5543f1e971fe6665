#!/usr/bin/env python3
"""SNES pd with -snes_pd_lbfgs m (L-BFGS on the PD matrix, src/solvers/pd_lbfgs.cpp), at 1 and 2 ranks:
- to convergence (|g| <= 1e-11) it ends where Newton (exact Hessian, MUMPS) and plain PD end, for
  implicit_euler and newmark: the bound is derived from the tolerance, |x - x*| <= |g| / lambda_min
  with lambda_min >= the vertex mass (Phi's Hessian is M + beta h^2 K), times 3 steps and a factor
  100 for K's indefinite part and the steps' propagation;
- Phi never rises from one iteration to the next within a solve (its -info lines), beyond Phi's
  roundoff (MSIM_PHI_ROUNDOFF, 1e-12 of |Phi|, plus what positions of order 1 m resolve); its convergence test reads its own gradient
  A x - rhs(x), so ending at Newton's solution also checks that gradient against the SNES function;
- a cloth dropped on the ball (a barrier's feasible set: the step is cut by max_step) runs, never
  gains energy, and reaches the ball;
- -snes_pd_lbfgs 0 is plain PD bit for bit; -snes_pd_lbfgs with -snes_pd_anderson is refused with
  one line."""
import os
import re
import sys
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
N, MASS, STEPS, ATOL = 11, 1.0, 3, 1e-11
SCENE = ["-msim_cloth_n", str(N), "-msim_mass", str(MASS), "-msim_dt", "0.02", "-msim_steps", str(STEPS), "-msim_spectrum_check", "0"]
TIGHT = ["-snes_rtol", "0", "-snes_stol", "0", "-snes_atol", str(ATOL)]
NEWTON = ["-snes_type", "newtonls", "-msim_psd", "0", "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps",
          "-msim_check_saddle", "0", "-snes_max_it", "100"] + TIGHT
LBFGS = ["-snes_type", "pd", "-snes_pd_lbfgs", "5", "-snes_max_it", "5000"] + TIGHT
PD = ["-snes_type", "pd", "-snes_max_it", "50000"] + TIGHT
BALL = ["-msim_cloth_n", "15", "-msim_fix", "none", "-msim_dt", "0.0333333333333333", "-msim_steps", "30", "-msim_integrator", "implicit_euler",
        "-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_friction", "0.3", "-snes_type", "pd", "-snes_pd_lbfgs", "5", "-snes_pd_fixed", "-snes_max_it", "10"]
INFO = re.compile(r"pd: L-BFGS iteration (\d+) Phi (\S+)")


def phi_never_rises(check, np_, text, label):
    """within each solve (from its iteration 0), Phi(k) <= Phi(k-1) + 1e-12 |Phi(k-1)| + FLOOR:
    FLOOR = total mass x (machine epsilon x 1 m)^2 is what the inertia term 1/2 m |x - y|^2 cannot
    resolve with positions of order 1 m (a free-falling step's Phi is ~1e-26 J: there the
    iterations only move it by roundoff)"""
    floor = MASS * np.finfo(float).eps ** 2
    worst, n, prev = -np.inf, 0, None
    for k, phi in ((int(a), float(b)) for a, b in INFO.findall(text)):
        if k > 0 and prev is not None:
            worst = max(worst, (phi - prev) / (1e-12 * abs(prev) + floor))
            n += 1
        prev = phi
    check(n > 0 and worst <= 1, f"np={np_}: {label}: Phi never rises over {n} iterations (largest rise {worst:.3g} x the allowance 1e-12 |Phi| + {floor:.1e} J)")


def main():
    check = mt.Checks()
    bound = 100 * STEPS * ATOL / (MASS / N**2)
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            for scheme in ("implicit_euler", "newmark"):
                base = SCENE + ["-msim_integrator", scheme]
                x = {}
                for label, opts in (("Newton", NEWTON), ("PD+L-BFGS", LBFGS), ("PD", PD)):
                    x[label], r = mt.final_positions(MSIM, base + opts + (["-info", ":snes"] if label == "PD+L-BFGS" else []), np_, tmp, f"{scheme}_{label}".replace("+", ""))
                    check(x[label] is not None and "stopped at -snes_max_it" not in r.stderr, f"np={np_}: {scheme} {label}: converged to |g| <= {ATOL:g} in every step")
                    if label == "PD+L-BFGS" and x[label] is not None:
                        phi_never_rises(check, np_, r.stdout, f"{scheme} to convergence")
                if any(v is None for v in x.values()):
                    continue
                for other in ("Newton", "PD"):
                    d = float(np.max(np.abs(x["PD+L-BFGS"] - x[other])))
                    check(d <= bound, f"np={np_}: {scheme}: PD+L-BFGS ends {d:.2e} m from {other} (bound {bound:.1e} m)")
            # the ball: the barrier's feasible set
            csv = os.path.join(tmp, f"ball_{np_}.csv")
            r = mt.run(MSIM, BALL + ["-msim_monitor_csv", csv, "-info", ":snes"], np_)
            rows = mt.read_csv(csv) if r.returncode == 0 else []
            check(r.returncode == 0 and len(rows) == 31, f"np={np_}: cloth on the ball, 30 PD+L-BFGS-10 steps" + ("" if r.returncode == 0 else ": " + r.stderr.strip()[-200:]))
            if rows:
                e0, emax = float(rows[0]["total"]), max(float(x["total"]) for x in rows)
                check(emax <= e0 + 1e-9, f"np={np_}: on the ball: total energy at most {emax:.6g} J <= its start {e0:.3g} J")
                check(max(int(x["contact_n"]) for x in rows) > 0, f"np={np_}: the cloth reached the ball")
                phi_never_rises(check, np_, r.stdout, "on the ball")
            # m = 0 is plain PD
            a, _ = mt.final_positions(MSIM, SCENE + ["-msim_integrator", "bdf2", "-snes_type", "pd", "-snes_pd_fixed", "-snes_max_it", "10"], np_, tmp, "m0a")
            b, _ = mt.final_positions(MSIM, SCENE + ["-msim_integrator", "bdf2", "-snes_type", "pd", "-snes_pd_fixed", "-snes_max_it", "10", "-snes_pd_lbfgs", "0"], np_, tmp, "m0b")
            check(a is not None and b is not None and np.array_equal(a, b), f"np={np_}: -snes_pd_lbfgs 0 is plain PD bit for bit")
            mt.refusals(check, MSIM, SCENE + ["-msim_integrator", "implicit_euler", "-snes_type", "pd"],
                        [("L-BFGS and Anderson", ["-snes_pd_lbfgs", "3", "-snes_pd_anderson", "3"], ["-snes_pd_lbfgs", "-snes_pd_anderson"]),
                         ("negative m", ["-snes_pd_lbfgs", "-1"], ["-snes_pd_lbfgs"]),
                         ("scale below 1", ["-snes_pd_lbfgs", "3", "-snes_pd_lbfgs_scale_max", "0.5"], ["-snes_pd_lbfgs_scale_max"])], np_)
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
