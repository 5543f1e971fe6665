/* The implicit forms msim gives PETSc's TS, with analytic sparse Jacobians (never a dense or
   finite-difference one):
   - first order, U = [x; v] (each rank its 3 nown positions, then velocities):
       F(t, U, U') = [x' - v; M v' - f(t, x, v)],
       dF/dU + a dF/dU' = [[a I, -I], [K, a M + C]]   (K = -df/dx, C = -df/dv),
     (F(t, U, 2 U') and shift 2 a in TSALPHA's start-up solves, whose initial U' is otherwise twice
     too large: ts_forms.cpp),
     a MATNEST of four blocks over the index sets of x and v. Its default preconditioner is exact:
     eliminating v' leaves (a^2 M + a C + K) dx = r_v + (a M + C) r_x, one sparse solve on the
     positions with the KSP of prefix ts_schur_ (MUMPS Cholesky, LDL^T, by default);
   - second order (TSALPHA2), x and v apart: F(t, x, v, a) = M a - f(t, x, v) (2 M a - f in PETSc's
     start-up solves, whose initial acceleration is otherwise twice too large: ts_forms.cpp),
       J = shiftA M + shiftV C + K, assembled into the system's matrix.
   K is the springs' exact Hessian; C is spring damping along the current axes plus air drag. The
   damping force's change with the axis direction is left out of K (it vanishes with the relative
   velocity): where damping dominates, Newton converges linearly rather than quadratically. */
#pragma once
#include <msim/integrator.h>

typedef struct _n_MSimTSForms *MSimTSForms;

PetscErrorCode MSimTSFormsCreate(MSimSystem sys, IS is_pos, IS is_mom, MSimTSForms *forms);
PetscErrorCode MSimTSFormsDestroy(MSimTSForms *forms);
/* First-order form: IFunction, IJacobian (nest) and the exact Schur PC as the default of the TS's
   KSP, unless -pc_type chooses another (then a Krylov method on the nest, e.g. -pc_type fieldsplit).
   unit_mass: the velocity rows divided by M (v' - M^-1 f; blocks M^-1 K and a I + M^-1 C), for
   types whose explicit stages need dF/dU' = I (ARKIMEX); the Schur system is the same. */
PetscErrorCode MSimTSFormsSetFirstOrder(MSimTSForms forms, TS ts, PetscBool unit_mass);
/* Second-order form for TSALPHA2: I2Function and I2Jacobian; X and V are TS2SetSolution's. */
PetscErrorCode MSimTSFormsSetSecondOrder(MSimTSForms forms, TS ts);
/* After TSSetFromOptions: the Schur PC's inner KSP reads its options (prefix ts_schur_). */
PetscErrorCode MSimTSFormsSetFromOptions(MSimTSForms forms, TS ts);
/* Residual and Jacobian evaluations so far, and the positions' KSP. */
PetscErrorCode MSimTSFormsView(MSimTSForms forms, PetscViewer viewer);
