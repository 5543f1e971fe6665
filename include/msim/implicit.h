/* Implicit Euler in position form, shared by the integrator, the pd SNES type and the tests:
   y = x_n + h v_n + h^2 M^-1 (m g + c w),
   g(x) = M (x - y) - h^2 f_spring(x) + h c (x - x_n) + h kd sum_s A_s^T n n^T A_s (x - x_n),
   the gradient of
   Phi(x) = 1/2 (x-y)^T M (x-y) + h^2 E(x) + h c/2 |x - x_n|^2 + h kd/2 sum_s (n . A_s (x - x_n))^2,
   where A_s x = x_i - x_j (fixed ends from b(t)) and the damping axes n are those of x_n. */
#pragma once
#include <msim/system.h>
#include <msim/solvers.h>

typedef struct _n_MSimImplicit *MSimImplicit;
struct _n_MSimImplicit {
  MSimSystem sys;
  PetscReal  h, t;            /* step and start time of the current step */
  Vec        Xn, Y;           /* x_n and y */
  PetscBool  psd;             /* project spring Hessian blocks to PSD in the Jacobian */
  /* projective dynamics: scalar matrix A = M + h c I + sum_s (h^2 k_s + h kd) L_s over free
     vertices, factored once (KSP prefix pd_), three columns solved together */
  Mat        A;
  Mat        A3;              /* A kron I3 on block-size-3 Vecs (MAIJ), made on first use */
  KSP        pdksp;
  Mat        B, Xd;           /* dense nown x 3: right-hand sides and solutions */
  PetscBool  pd_direct;       /* preonly + msimllt: solve the interleaved Vec arrays directly */
  PetscBool  pd_iterative;    /* a Krylov -pd_ksp_type: x, y, z one at a time from a guess */
  Vec        pdb, pdx;        /* one column of the right-hand side and of the solution */
  PetscInt   pd_lits;         /* Krylov iterations of the PD solves in the current step */
  PetscInt   nfactor;         /* numeric factorizations done by the PD solves */
  Vec        rhs;
  MSimPDProblem pd;
};

PetscErrorCode MSimImplicitCreate(MSimSystem sys, MSimImplicit *imp);
PetscErrorCode MSimImplicitDestroy(MSimImplicit *imp);
/* start a step from (X, V) at t: sets x_n, y. */
PetscErrorCode MSimImplicitBeginStep(MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V);
PetscErrorCode MSimImplicitResidual(MSimImplicit imp, Vec X, Vec G);
PetscErrorCode MSimImplicitObjective(MSimImplicit imp, Vec X, PetscReal *phi);
PetscErrorCode MSimImplicitJacobian(MSimImplicit imp, Vec X, Mat J);
/* the Jacobian plus delta M (inertia correction) */
PetscErrorCode MSimImplicitJacobianShifted(MSimImplicit imp, Vec X, PetscReal delta, Mat J);
/* Newton with inertia correction (-msim_inertia_correction): the exact Hessian H, or H + delta M
   with the least delta of a geometric sequence for which the LDL^T in the KSP's Cholesky PC
   (MUMPS) has no negative pivot, so every Newton direction descends and Newton converges to
   minima of Phi, not to saddles. Assembles into J and leaves it factored in ksp. */
typedef struct {
  PetscReal delta_last; /* the previous iteration's shift: the next one starts from a third of it */
  PetscReal delta_max;  /* largest shift used */
  PetscInt  shifted;    /* Newton iterations that needed a shift */
  PetscInt  extra;      /* factorizations beyond one per iteration */
} MSimInertiaCorrection;
/* Factors J in ksp (a Cholesky PC whose factor knows its inertia: MUMPS) and returns its number
   of negative eigenvalues, or -1 if the factorization failed (a zero pivot: J singular). */
PetscErrorCode MSimImplicitFactorInertia(KSP ksp, Mat J, PetscInt *nneg);
PetscErrorCode MSimImplicitJacobianInertiaCorrected(MSimImplicit imp, KSP ksp, Vec X, Mat J, MSimInertiaCorrection *ic);
/* PD pieces */
PetscErrorCode MSimImplicitPDSetUp(MSimImplicit imp);
PetscErrorCode MSimImplicitPDRHS(MSimImplicit imp, Vec X, Vec rhs, PetscReal *phi);
/* A X = rhs (A kron I3); an iterative -pd_ksp_type starts from guess (NULL: zero; may be X) */
PetscErrorCode MSimImplicitPDSolve(MSimImplicit imp, Vec rhs, Vec guess, Vec X);
/* A kron I3 as a shell Mat whose only use is as a KSP operator for the PD-factor PC */
PetscErrorCode MSimImplicitPDCreateShell(MSimImplicit imp, Mat *J);
PetscErrorCode MSimImplicitPDSetPC(MSimImplicit imp, KSP ksp);
