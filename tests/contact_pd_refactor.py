#!/usr/bin/env python3
"""PD's lazy refactorization with contact (-msim_contact_pd_refactor, issue 34). The barrier's
weights on PD's matrix A only speed the iteration up: each global step is X - A^-1 g(X) with the
true gradient g whatever weights A holds, so a factor kept with stale weights (the default: until
some vertex's diagonal is off by more than a factor 4) must reach the same converged step as one
refactored whenever the set of vertices within dhat changes (0, the old rule), and so must a
refactorization that refreshes only the vertices off by more than sqrt(r) (the default,
-msim_contact_pd_refactor_selective) or every vertex (0). Checked, at each rank count:
- a 11 x 11 cloth landing flat on a plane (8 steps) and on the ball (4 steps: the first contact
  step, the last PD converges in at this h), PD with Anderson to |g| <= 1e-9: every step
  converges under both rules, the lazy rule factors fewer times, and the final positions agree
  within TOL: |x - x*| <= |g| / lambda_min(Phi's Hessian) per step and run, lambda_min >= the
  vertex mass m (implicit Euler's M, springs near rest), over the steps of both runs;
- a 21 x 21 cloth draped on the ball with PD-10 (24 steps, friction 0.3), frames every step:
  no vertex inside the ball in any frame under the default rule, and it factors fewer times than
  the old rule; and the same drape run through PD's residual path (no -snes_pd_fixed, tolerances
  0: the same 10 iterations, each global step's Phi check done at once) ends at the same
  positions within roundoff: with -snes_pd_fixed the check is taken from the next local step's Phi
  sum instead (src/implicit/pd_steps.cpp), which must not change the iterates. Some checks must
  reject a step (bound retries or halvings in -log_view), so the comparison covers them too;
- the bound on Phi that sets a rejected step's length from the contact terms alone
  (-msim_contact_pd_bound, the default): fewer Phi evaluations and retries than halving on Phi,
  Phi (evaluated in full under -info) not rising at any step it accepted, and converged steps on
  the ball the same with and without it (bound_checks);
- Newton-CG on PD's factor with the barrier's weights (-msim_contact_pc_pd_weight) on the 11 x 11
  drape: the factor takes them, CG takes fewer iterations, every step converges (pc_weight_checks).
Usage: contact_pd_refactor.py path/to/msim [--np N]"""
import os
import re
import sys
import tempfile

import numpy as np

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

MSIM = mt.msim_path()
H = ["-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.0333333333333333"]
CONVERGED = ["-snes_type", "pd", "-snes_pd_anderson", "5", "-snes_max_it", "2000", "-snes_atol", "1e-9", "-snes_rtol", "0"]
ATOL, N = 1e-9, 11
M = 1.0 / (N * N)  # the vertex mass: the cloth's 1 kg over its vertices
PLANE = ["-msim_contact_plane", "0,0,1,-0.05"]
BALL = ["-msim_contact_sphere", "0.5,0.5,-0.4,0.3"]
CENTRE, RADIUS = np.array([0.5, 0.5, -0.4]), 0.3


def factorizations(path):
    """MSimLLTFactor's count in a -log_view file, summed over its stages"""
    with open(path) as f:
        return sum(int(c) for c in re.findall(r"^MSimLLTFactor\s+(\d+)", f.read(), re.M))


def energies(path):
    """MSimEnergy's count (Phi evaluations) in a -log_view file, summed over its stages"""
    with open(path) as f:
        return sum(int(c) for c in re.findall(r"^MSimEnergy\s+(\d+)", f.read(), re.M))


def halvings(path):
    """global steps whose Phi check rejected the step: bound retries (MSimPDBound) and halvings on
    Phi (MSimPDHalving), from a -log_view file"""
    with open(path) as f:
        t = f.read()
    return sum(int(c) for c in re.findall(r"^MSimPD(?:Bound|Halving)\s+(\d+)", t, re.M))


def run(np_, args, tmp, tag, final=True):
    """(final positions or None, monitor rows, factorizations)"""
    csv, log = os.path.join(tmp, f"{tag}_{np_}.csv"), os.path.join(tmp, f"{tag}_{np_}.log")
    args = args + ["-msim_monitor_csv", csv, "-log_view", f"ascii:{log}"]
    if final:
        x, r = mt.final_positions(MSIM, args, np_, tmp, tag)
    else:
        r = mt.run(MSIM, args, np_)
        x = None
        if r.returncode:
            print(r.stderr[-1500:])
    if r.returncode:
        return None, [], -1
    return x, mt.read_csv(csv), factorizations(log)


def main():
    check = mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            for name, obs, steps in (("plane", PLANE, 8), ("ball", BALL, 4)):
                base = ["-msim_cloth_n", N, "-msim_steps", steps] + H + CONVERGED + obs
                res = {rule: run(np_, base + ["-msim_contact_pd_refactor", rule], tmp, f"{name}_{rule}") for rule in ("0", "4")}
                (x0, mon0, f0), (x4, mon4, f4) = res["0"], res["4"]
                # the lazy rule with every vertex refreshed at each refactorization (the default
                # refreshes only those off by more than sqrt(r)): the same converged steps too
                # and with K = 1, where more than K vertices to refresh makes every vertex take its weight
                for k, what in (("0", "every vertex refreshed"), ("1", "every vertex refreshed past one vertex off")):
                    xa, mona, _ = run(np_, base + ["-msim_contact_pd_refactor", "4", "-msim_contact_pd_refactor_selective", k], tmp, f"{name}_4sel{k}")
                    if check(xa is not None and x4 is not None, f"np={np_} {name}: the lazy rule runs with {what}"):
                        its = [int(r["nonlinear_its"]) for r in mona[1:]]
                        d = float(np.abs(x4 - xa).max())
                        tol = 2 * steps * ATOL / M
                        check(max(its) < 2000 and d <= tol, f"np={np_} {name}: refreshing only the vertices off (the default) and {what} give the same converged steps, max difference {d:.3g} m <= {tol:.3g} (iterations {its})")
                if not check(x0 is not None and x4 is not None, f"np={np_} {name}: both rules run {steps} steps"):
                    continue
                for rule, mon in (("0", mon0), ("4", mon4)):
                    its = [int(r["nonlinear_its"]) for r in mon[1:]]
                    res_ = max(float(r["residual"]) for r in mon[1:])
                    check(max(its) < 2000 and res_ <= ATOL, f"np={np_} {name}, rule {rule}: every step converged (iterations {its}, largest |g| {res_:.2g} <= {ATOL:g})")
                check(max(int(r["contact_n"]) for r in mon4) > 0, f"np={np_} {name}: the cloth is in contact (vertices within dhat at the end: {mon4[-1]['contact_n']})")
                check(f4 < f0, f"np={np_} {name}: the lazy rule factors fewer times ({f4} against {f0})")
                tol = 2 * steps * ATOL / M
                d = float(np.abs(x4 - x0).max())
                check(d <= tol, f"np={np_} {name}: the same converged steps, max |x_lazy - x_always| = {d:.3g} m <= {tol:.3g}")
            drape = ["-msim_cloth_n", 21, "-msim_steps", 24, "-msim_friction", "0.3", "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"] + H + BALL
            out = os.path.join(tmp, f"frames_{np_}")
            _, mon, f4 = run(np_, drape + ["-msim_output", out, "-msim_output_every", 1], tmp, "drape_4", final=False)
            _, _, f0 = run(np_, drape + ["-msim_contact_pd_refactor", "0"], tmp, "drape_0", final=False)
            if not check(mon, f"np={np_} drape: 24 steps run"):
                continue
            check(f4 < f0, f"np={np_} drape: the default rule factors fewer times ({f4} against {f0})")
            least, n = np.inf, 0
            for _, fr in vtu.read_pvd(os.path.join(out, "series.pvd")):
                least = min(least, float((np.linalg.norm(vtu.read_vtu(fr)["points"] - CENTRE, axis=1) - RADIUS).min()))
                n += 1
            check(n == 25 and least > 0, f"np={np_} drape: no vertex inside the ball in any of {n} frames (least distance {least:.3g} m)")
            check(int(mon[-1]["contact_n"]) > 0, f"np={np_} drape: the cloth lies on the ball ({mon[-1]['contact_n']} vertices within dhat)")
            xd, _, _ = run(np_, drape, tmp, "drape_deferred")
            xi, _, _ = run(np_, [a for a in drape if a != "-snes_pd_fixed"] + ["-snes_atol", "0", "-snes_rtol", "0", "-snes_stol", "0"], tmp, "drape_immediate")
            nr = halvings(os.path.join(tmp, f"drape_deferred_{np_}.log"))
            if check(xd is not None and xi is not None, f"np={np_} drape: runs with the Phi check deferred (-snes_pd_fixed) and at once (residual path)"):
                d = float(np.abs(xd - xi).max())
                check(d <= 1e-10, f"np={np_} drape: the deferred Phi check takes the same iterates, max |x_deferred - x_immediate| = {d:.3g} m <= 1e-10")
                check(nr > 0, f"np={np_} drape: some checks rejected the step ({nr} bound retries and halvings with the check deferred)")
            bound_checks(check, np_, drape, tmp)
            pc_weight_checks(check, np_, tmp)
    return check.exit_code()


def pc_weight_checks(check, np_, tmp):
    """-msim_contact_pc_pd_weight: Newton-CG preconditioned by PD's factor (-msim_pc_pd) takes the
    barrier's weights into the factor, refactored by -msim_contact_pd_refactor's rule (default 4)
    and where the set of vertices within dhat changed. On a cloth the springs' h^2 sum k dwarfs the
    weights in A's diagonal, so the diagonals' test alone never refactored and the option changed
    nothing, bit for bit (11 x 11 drape on the ball, 30 steps: 14,459 CG iterations either way, 2
    factorizations, the second at the first Jacobian, before contact). Checked on that drape:
    with the option the factor is redone (more factorizations than without), CG takes fewer
    iterations (13,757 when measured) and every Newton step converges."""
    drape = ["-msim_cloth_n", N, "-msim_fix", "none", "-msim_contact_sphere", "0.5,0.5,-0.35,0.3", "-msim_integrator", "implicit_euler",
             "-msim_dt", "0.01", "-msim_steps", 30, "-msim_pc_pd", "-ksp_type", "cg"]
    res = {}
    for opt in ("0", "1"):
        tag = f"pcw{opt}"
        csv, log = os.path.join(tmp, f"{tag}_{np_}.csv"), os.path.join(tmp, f"{tag}_{np_}.log")
        r = mt.run(MSIM, drape + ["-msim_contact_pc_pd_weight", opt, "-msim_monitor_csv", csv, "-log_view", f"ascii:{log}"], np_)
        if not check(r.returncode == 0, f"np={np_} Newton-CG on the PD factor, -msim_contact_pc_pd_weight {opt}: 30 steps run"):
            print(r.stderr[-1500:])
            return
        mon = mt.read_csv(csv)
        res[opt] = (sum(int(m["linear_its"]) for m in mon), factorizations(log), "-snes_max_it" in r.stderr, max(int(m["contact_n"]) for m in mon))
    (cg0, f0, _, _), (cg1, f1, stalled, nc) = res["0"], res["1"]
    check(nc > 0, f"np={np_} Newton-CG drape: the cloth reaches the ball ({nc} vertices within dhat)")
    # besides the factorization at the first Jacobian (before contact: no weight yet), which the old rule made too
    check(f1 > f0 + 1, f"np={np_} Newton-CG drape: the option refactors with the barrier's weights ({f1} factorizations against {f0} + 1)")
    check(cg1 < cg0, f"np={np_} Newton-CG drape: the weights take CG fewer iterations ({cg1} against {cg0})")
    check(not stalled, f"np={np_} Newton-CG drape with the option: every step converges (no step at -snes_max_it)")


def bound_checks(check, np_, drape, tmp):
    """-msim_contact_pd_bound (default on): where Phi rose along a global step, its length comes
    from a bound that needs only the contact terms' change (src/implicit/pd_steps.cpp), not from
    halvings that each evaluate Phi in full. Checked: the 21 x 21 drape takes fewer Phi evaluations
    and halvings than halving on Phi; with -info, Phi evaluated in full at both ends of every step
    the bound accepted did not rise (beyond roundoff); converged steps (Anderson to |g| <= 1e-9,
    whose safeguard checks at once) agree with those halving on Phi within the bound of the
    refactorization checks above."""
    logs = {}
    for b in ("0", "1"):
        tag = f"bound{b}"
        _, mon, _ = run(np_, drape + ["-msim_contact_pd_bound", b], tmp, tag, final=False)
        if not check(mon, f"np={np_} drape, -msim_contact_pd_bound {b}: 24 steps run"):
            return
        log = os.path.join(tmp, f"{tag}_{np_}.log")
        logs[b] = (energies(log), halvings(log))
    (e0, h0), (e1, h1) = logs["0"], logs["1"]
    check(e1 + h1 < e0 + h0, f"np={np_} drape: the bound takes fewer Phi evaluations + rejected-step retries ({e1} + {h1}) than halving on Phi ({e0} + {h0})")
    r = mt.run_info(MSIM, drape, np_, "vec")
    pairs = [(float(a), float(b)) for a, b in re.findall(r"pd bound: .*\(found\).* Phi (\S+) -> (\S+)", r.info)]
    rise = max((b - a - 1e-12 * abs(a) for a, b in pairs), default=0.0)
    check(r.returncode == 0 and pairs and rise <= 1e-20, f"np={np_} drape: Phi did not rise at any of the {len(pairs)} steps the bound accepted (largest rise beyond 1e-12 |Phi|: {rise:.3g} J)")
    base = ["-msim_cloth_n", N, "-msim_steps", 4] + H + CONVERGED + BALL + ["-msim_friction", "0.3"]
    x1, mon1, _ = run(np_, base, tmp, "conv_bound1")
    x0, mon0, _ = run(np_, base + ["-msim_contact_pd_bound", "0"], tmp, "conv_bound0")
    if check(x1 is not None and x0 is not None, f"np={np_} ball, converged, with and without the bound: both run"):
        res_ = max(float(m["residual"]) for m in mon0[1:] + mon1[1:])
        tol = 2 * 4 * ATOL / M
        d = float(np.abs(x1 - x0).max())
        check(res_ <= ATOL and d <= tol, f"np={np_} ball, converged: the same steps with and without the bound, max |x_bound - x_halving| = {d:.3g} m <= {tol:.3g} (largest |g| {res_:.2g})")


if __name__ == "__main__":
    sys.exit(main())
