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
  one line;
- the gradient from the local step's passes (pd_gradient.cpp, the default) is A x - rhs(x) to
  roundoff (-snes_pd_lbfgs_check: |difference| <= 1000 eps |rhs|, the cancellation A x - rhs
  leaves in each row's sum of about 15 terms of rhs's size) on every term it covers: a damped cloth
  with drag and wind (the damped springs' pass, a diagonal term), a cloth on the ball with the
  barrier, friction and self-contact lagged (-msim_contact_pd_weight 0: their part is -(their
  pd_rhs)), a tet beam with the volume term and its barrier, the ball with the barrier's PD
  weights and friction (the obstacles' pd_gradient: weights in A, which cancel); s^T A s from the
  two-loop's Gram matrix is the product's to 1e-8 (pairs of steps above about 1e-8 m: below, both
  are roundoff); with the PD weights, a solve takes the product only where its first gradient
  changed A (the weights' refactorization: the Gram rows belong to the old A), -info says so
  (each fallback line follows such a line), and the other solves are fused; to convergence, the
  product's path (-snes_pd_lbfgs_fused 0) also ends at Newton's solution."""
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
# Whole lines only, and -info in one file per rank (mt.run_info): two ranks' -info output on one
# pipe cut lines of one rank into the other's (2-rank runs with identical monitors showed 195-202
# of their ~200 check lines per rank), and a spliced line once read as a Gram "error" of 99.
NUM = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
GCHECK = re.compile(r"^\[0\] <sys> CheckGradient\(\): pd: L-BFGS fused gradient check: \|g - \(A x - rhs\)\| " + NUM + r" \|g\| " + NUM + r" \|rhs\| " + NUM + r"$", re.M)
GRAM = re.compile(r"^\[0\] <sys> PushPair\(\): pd: L-BFGS Gram check: s\^T A s " + NUM + r", by the product " + NUM + r" \(relative difference " + NUM + r"\)$", re.M)
FALLBACK = "this problem's gradient takes the product"
REWEIGHT = "PD weights changed A at this gradient"
FUSED_LB = ["-snes_type", "pd", "-snes_pd_lbfgs", "3", "-snes_pd_fixed", "-snes_max_it", "10", "-snes_pd_lbfgs_check", "-msim_spectrum_check", "0"]
FUSED_SCENES = {
    "damped cloth, drag and wind": ["-msim_cloth_n", "11", "-msim_damping", "2", "-msim_drag", "0.05", "-msim_wind", "1,0,0", "-msim_integrator", "newmark",
                                    "-msim_dt", "0.02", "-msim_steps", "10"],
    "cloth on the ball, lagged barrier, friction, self-contact": BALL[:BALL.index("-snes_type")] + ["-msim_steps", "20", "-msim_contact_pd_weight", "0", "-msim_self_contact"],
    "cloth on the ball, barrier's PD weights, friction": BALL[:BALL.index("-snes_type")] + ["-msim_steps", "20"],
    "tet beam, volume term": ["-msim_scene", "box", "-msim_box_n", "4,2,2", "-msim_box_size", "1,0.25,0.25", "-msim_fix_plane", "x_min", "-msim_young", "2e5",
                              "-msim_density", "100", "-msim_integrator", "bdf2", "-msim_dt", "0.02", "-msim_steps", "10"],
}


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


def fused_gradient(check, np_):
    """the fused gradient against the product, and the Gram matrix's s^T A s against A s's"""
    eps = np.finfo(float).eps
    for label, scene in FUSED_SCENES.items():
        r = mt.run_info(MSIM, scene + FUSED_LB, np_)
        rank0 = "\n".join(l for l in r.info.splitlines() if l.startswith("[0]"))  # every rank prints the checks
        g = [tuple(float(v) for v in m) for m in GCHECK.findall(rank0)]
        # and a line whose own relative difference (printed to 4 digits) disagrees with its two
        # numbers is a splice that happened to keep the shape: left out
        gram = [(float(a), float(b)) for a, b, d in GRAM.findall(rank0)
                if float(b) > 0 and abs(abs(float(a) - float(b)) / abs(float(b)) - float(d)) <= 1e-3 * float(d) + 1e-300]
        if r.returncode or not g:
            check(False, f"np={np_}: {label}: the fused gradient ran and was checked" + (": " + r.stderr.strip()[-200:] if r.returncode else " (no check lines)"))
            continue
        worst = max(d / (1000 * eps * rhs) for d, _, rhs in g)
        # a solve takes the product only right after its first gradient changed A (PD weights)
        lines = [l for l in rank0.splitlines() if FALLBACK in l or REWEIGHT in l]
        unexplained = sum(1 for i, l in enumerate(lines) if FALLBACK in l and (i == 0 or REWEIGHT not in lines[i - 1]))
        nprod = sum(1 for l in lines if FALLBACK in l)
        check(worst <= 1 and unexplained == 0, f"np={np_}: {label}: |g - (A x - rhs)| <= 1000 eps |rhs| at {len(g)} fused solves' first iterates (largest {worst:.2g} x the bound); "
              f"{nprod} solves took the product, each where the PD weights had just changed A")
        big = [(a, b) for a, b in gram if b > 1e-16]
        rel = max((abs(a - b) / b for a, b in big), default=np.inf)
        check(len(big) > 0 and rel <= 1e-8, f"np={np_}: {label}: s^T A s from the Gram matrix within {rel:.1e} of the product's over {len(big)} pairs (of {len(gram)}; bound 1e-8)")


def main():
    check = mt.Checks()
    bound = 100 * STEPS * ATOL / (MASS / N**2)
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            for scheme in ("implicit_euler", "newmark"):
                base = SCENE + ["-msim_integrator", scheme]
                x = {}
                for label, opts in (("Newton", NEWTON), ("PD+L-BFGS", LBFGS), ("PD+L-BFGS product", LBFGS + ["-snes_pd_lbfgs_fused", "0"]), ("PD", PD)):
                    x[label], r = mt.final_positions(MSIM, base + opts, np_, tmp, f"{scheme}_{label}".replace("+", "").replace(" ", "_"), info="snes" if label.startswith("PD+L-BFGS") else None)
                    check(x[label] is not None and "stopped at -snes_max_it" not in r.stderr, f"np={np_}: {scheme} {label}: converged to |g| <= {ATOL:g} in every step")
                    if label.startswith("PD+L-BFGS") and x[label] is not None:
                        phi_never_rises(check, np_, r.info, f"{scheme} to convergence")
                if any(v is None for v in x.values()):
                    continue
                for lb, other in (("PD+L-BFGS", "Newton"), ("PD+L-BFGS", "PD"), ("PD+L-BFGS product", "Newton")):
                    d = float(np.max(np.abs(x[lb] - x[other])))
                    check(d <= bound, f"np={np_}: {scheme}: {lb} ends {d:.2e} m from {other} (bound {bound:.1e} m)")
            # the ball: the barrier's feasible set
            csv = os.path.join(tmp, f"ball_{np_}.csv")
            r = mt.run_info(MSIM, BALL + ["-msim_monitor_csv", csv], np_, "snes")
            rows = mt.read_csv(csv) if r.returncode == 0 else []
            check(r.returncode == 0 and len(rows) == 31, f"np={np_}: cloth on the ball, 30 PD+L-BFGS-10 steps" + ("" if r.returncode == 0 else ": " + r.stderr.strip()[-200:]))
            if rows:
                e0, emax = float(rows[0]["total"]), max(float(x["total"]) for x in rows)
                check(emax <= e0 + 1e-9, f"np={np_}: on the ball: total energy at most {emax:.6g} J <= its start {e0:.3g} J")
                check(max(int(x["contact_n"]) for x in rows) > 0, f"np={np_}: the cloth reached the ball")
                phi_never_rises(check, np_, r.info, "on the ball")
            fused_gradient(check, np_)
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
