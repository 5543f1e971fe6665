#!/usr/bin/env python3
"""A tet box hanging from its top face sags under its own weight by what its spring lattice
predicts, at every refinement.

The column: 1 x 1 x L (L = 6), n x n x 6n cubes each cut into 6 Kuhn tets, springs with
k_e = E V_e / L_e^2 (-msim_young; V_e the volume of the tets around the edge), the face z = L fixed,
gravity -z, density rho. Its static state is one implicit Euler step from rest with a huge h: the
step minimizes |x - x_n|_M^2 / (2 h^2) - (x - x_n) . M g + E(x), whose first term vanishes as
h -> infinity, leaving the total potential energy.

The prediction, derived here: under a uniform strain eps the lattice stores, per unit volume,
w = E/2 sum_d w_d (n_d . eps n_d)^2 over its edge directions d with weights w_d = (sum of k_e L_e^2
over the edges of direction d) / (E volume). In a Kuhn cube every tet (0, e_a, e_a + e_b, e_a +
e_b + e_c), of volume 1/6 of the cube's, has one edge along each axis, the face diagonals e_a + e_b
and e_b + e_c and the body diagonal: over the 6 tets the axes get weight 1 each, the diagonals
(1,1,0), (0,1,1), (1,0,1) 4/6 each, (1,1,1) 1. So C = E sum_d w_d n_d x n_d x n_d x n_d, and under
uniaxial stress along z the strain is sigma S_zzzz: the lattice's modulus along z is E_z = 1 /
S_zzzz (S = C^-1 in Voigt form; E_z = 30/29 E). A hanging bar of modulus E_z stretches by
rho g L^2 / (2 E_z) at its free end.

Checked: the mean displacement of the bottom face at n = 1, 2, 4 is within 1% of that (the
clamped top face, which keeps the column from contracting sideways, and the geometric
nonlinearity at strain 3e-4 account for 0.2-0.3%), at 1 and 2 ranks; and, as a control, with one
spring constant for every spring instead of E the sag depends on n (such a lattice's modulus grows
like k / h as its cells shrink: it stiffens under refinement). Usage: box_sag.py path/to/msim"""
import sys
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
E, RHO, G, L = 1e8, 1000.0, 9.81, 6.0


def lattice_modulus_z():
    dirs = [((1, 0, 0), 1), ((0, 1, 0), 1), ((0, 0, 1), 1), ((1, 1, 0), 2 / 3), ((0, 1, 1), 2 / 3), ((1, 0, 1), 2 / 3), ((1, 1, 1), 1)]
    C = np.zeros((3, 3, 3, 3))
    for d, w in dirs:
        n = np.array(d, float) / np.linalg.norm(d)
        C += w * np.einsum("i,j,k,l->ijkl", n, n, n, n)
    voigt = [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)]
    # stress from strain with engineering shears (gamma = 2 eps): sigma_I = sum_J C_IJ e_J
    Cv = np.array([[C[a, b, c, d] for (c, d) in voigt] for (a, b) in voigt])
    return 1.0 / np.linalg.inv(Cv)[2, 2]  # in units of E


def sag(n, np_, spring):
    with tempfile.TemporaryDirectory() as tmp:
        x, r = mt.final_positions(MSIM, [
            "-msim_scene", "box", "-msim_box_n", f"{n},{n},{6 * n}", "-msim_box_size", f"1,1,{L}", "-msim_fix_plane", "z_max",
            "-msim_density", str(RHO), "-msim_integrator", "implicit_euler", "-msim_dt", "1000", "-msim_steps", "1",
            "-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps", "-snes_rtol", "1e-12", "-snes_atol", "1e-14"] + spring, np_, tmp)
    if x is None:
        sys.exit("msim failed")
    return -x[: (n + 1) ** 2, 2].mean()  # vertices i + (n+1) j of the layer z = 0


def main():
    ez = lattice_modulus_z()
    predicted = RHO * G * L * L / (2 * E * ez)
    print(f"lattice modulus along z: {ez:.6f} E; predicted sag {predicted:.6e} m")
    check = mt.Checks()
    for np_ in (1, 2):
        for n in (1, 2, 4):
            s = sag(n, np_, ["-msim_young", str(E)])
            err = s / predicted - 1
            check(abs(err) <= 1e-2, f"np={np_} n={n}: sag {s:.6e} m within 1% of {predicted:.6e} ({err:+.2e} relative)")
    # control: equal springs (k = E x 1 m, the n = 1 value's order) stiffen under refinement
    s1, s4 = sag(1, 1, ["-msim_stiffness", "1e8"]), sag(4, 1, ["-msim_stiffness", "1e8"])
    check(s1 > 1.5 * s4, f"a lattice of equal springs stiffens under refinement: sag {s1:.6e} at n = 1, {s4:.6e} at n = 4")
    sys.exit(check.exit_code())


if __name__ == "__main__":
    main()
