#!/usr/bin/env python3
"""Saddle points of the implicit step: Newton on the exact Hessian (MUMPS LDL^T) counts the
negative eigenvalues at the point it converged to, and msim reports them. Checked against a count
derived here, independently of msim, on a chain held at both ends and pulled along its axis by
gravity. Everything stays on the axis, where the step is a linear tridiagonal system; the Hessian's
two transverse blocks are the tridiagonal m I + h^2 K_T with spring stiffness k a_i, a_i = 1 - L/l_i,
negative where a spring is compressed, and their inertia is that of the pivots of their LDL^T
(Sylvester). The axial block m I + h^2 k (Laplacian) is positive definite.
A compressed chain must be reported as a saddle with exactly that many negative eigenvalues, at 1
and 2 ranks: prestretch 0.95, where the Hessian turns indefinite only at the solution (Newton's one
factorization, at x0, has none), and 0.8; a stretched one (prestretch 1.05) is a minimum and gets no
warning.
Usage: saddle.py path/to/msim"""
import re
import sys

import msimtest as mt

MSIM = mt.msim_path()
N, LENGTH, MASS, K, H, GX = 40, 1.0, 1.0, 1000.0, 0.01, -50.0


def expected_negative(prestretch):
    m, L, h2k = MASS / N, LENGTH / (N - 1), H * H * K
    xn = [prestretch * i * L for i in range(N)]
    # free vertices 1..N-2: (m + 2 h^2 k) x_i - h^2 k (x_{i-1} + x_{i+1}) = m xn_i + h^2 m gx
    # (the rest lengths cancel on the axis); Thomas algorithm, ends fixed at xn
    n = N - 2
    diag, off = [m + 2 * h2k] * n, -h2k
    rhs = [m * xn[i + 1] + H * H * m * GX for i in range(n)]
    rhs[0] -= off * xn[0]
    rhs[-1] -= off * xn[-1]
    c, d = [0.0] * n, [0.0] * n
    c[0], d[0] = off / diag[0], rhs[0] / diag[0]
    for i in range(1, n):
        den = diag[i] - off * c[i - 1]
        c[i], d[i] = off / den, (rhs[i] - off * d[i - 1]) / den
    x = [0.0] * n
    x[-1] = d[-1]
    for i in range(n - 2, -1, -1):
        x[i] = d[i] - c[i] * x[i + 1]
    pos = [xn[0]] + x + [xn[-1]]
    a = [1 - L / (pos[i + 1] - pos[i]) for i in range(N - 1)]
    # transverse block on the free vertices: diagonal m + h^2 k (a_{i-1} + a_i), off-diagonal -h^2 k a_i
    neg, piv = 0, None
    for i in range(1, N - 1):
        t = m + h2k * (a[i - 1] + a[i])
        if piv is not None:
            t -= (h2k * a[i - 1]) ** 2 / piv
        neg += t < 0
        piv = t
    return 2 * neg  # two transverse directions


def run(prestretch, np):
    r = mt.run(MSIM, [
        "-msim_scene", "chain", "-msim_chain_n", str(N), "-msim_chain_length", str(LENGTH), "-msim_mass", str(MASS),
        "-msim_stiffness", str(K), "-msim_fix", "corners", "-msim_prestretch", str(prestretch), "-msim_gravity", f"{GX},0,0",
        "-msim_integrator", "implicit_euler", "-msim_dt", str(H), "-msim_steps", "1", "-snes_type", "newtonls", "-msim_psd", "0",
        "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps", "-msim_view"], np)
    m = re.search(r"steps converged to a saddle point of Phi \(negative pivots in the exact Hessian's LDL\^T\): (\d+), at most (\d+) negative", r.stdout)
    warned = "converged to a saddle point" in r.stderr
    return r.returncode, (int(m.group(1)), int(m.group(2))) if m else None, warned


def main():
    check = mt.Checks()
    for prestretch in (0.95, 0.8, 1.05):
        want = expected_negative(prestretch)
        for np in (1, 2):
            rc, got, warned = run(prestretch, np)
            check(rc == 0 and got == ((1, want) if want else (0, 0)) and warned == (want > 0),
                  f"prestretch {prestretch} np={np}: derived {want} negative eigenvalues; msim reports (steps, negative) {got}, warning {warned}")
    # the derivation must exercise a saddle at all
    check(expected_negative(0.95) > 0 and expected_negative(0.8) > 0, "the compressed chain has negative eigenvalues (else the case tests nothing)")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
