/* The implicit problem: every step of an implicit time scheme minimizes the incremental potential

     Phi(x) = 1/2 (x - y)^T M (x - y) + sum_t E_t(x),      g(x) = grad Phi(x),

   where the time scheme (a registered type, src/implicit/schemes/) supplies y, the weight beta of
   the potentials (each E_t is beta h^2 times a potential, or a dissipation potential) and the
   velocity update, and the energy terms (registered types, src/implicit/terms/) supply E_t, its
   gradient, Hessian blocks, projective-dynamics local step and matrix weights, and the largest
   feasible step. Implicit Euler with springs, spring damping and drag gives
     y = x_n + h v_n + h^2 M^-1 (m g + c w),
     Phi(x) = 1/2 |x-y|_M^2 + h^2 E(x) + h c/2 |x - x_n|^2 + h kd/2 sum_s (n . A_s (x - x_n))^2,
   where A_s x = x_i - x_j (fixed ends from b(t)) and the damping axes n are those of x_n.
   Constant external forces (gravity, the wind's drag) are folded into y by the scheme: a force
   constant in x adds a linear term to Phi, which equals a shift of y by beta h^2 M^-1 f up to a
   constant, so it costs nothing per iteration and leaves Phi's values as they were.
   The solvers (src/solvers/) see the problem only through SNES callbacks and MSimPDProblem. */
#pragma once
#include <msim/system.h>
#include <msim/solvers.h>

/* The bodies and the schemes' and terms' ops are private (msim/private/implicitimpl.h). */
typedef struct _n_MSimImplicit       *MSimImplicit;
typedef struct _n_MSimImplicitScheme *MSimImplicitScheme;
typedef struct _n_MSimImplicitTerm   *MSimImplicitTerm;

/* Registries, PETSc style: -msim_integrator lists the schemes (each is an implicit integrator of
   the same name), -msim_implicit_terms the terms. A new scheme or term is one file under
   src/implicit/schemes/ or terms/ and its line in src/implicit/registry.cpp. */
#define MSIMSCHEMEEULER    "implicit_euler"
#define MSIMSCHEMEBDF2     "bdf2"
#define MSIMSCHEMEMIDPOINT "implicit_midpoint"
#define MSIMSCHEMENEWMARK  "newmark"
#define MSIMSCHEMEDISCGRAD "discrete_gradient"
#define MSIMTERMSPRINGS "springs"
#define MSIMTERMDRAG    "drag"
PetscErrorCode MSimImplicitSchemeRegister(const char name[], PetscErrorCode (*create)(MSimImplicitScheme));
PetscErrorCode MSimImplicitTermRegister(const char name[], PetscErrorCode (*create)(MSimImplicitTerm));
PetscErrorCode MSimImplicitRegisterAll(void);
/* the registered schemes' names (the strings are the registry's; PetscFree the array) */
PetscErrorCode MSimImplicitSchemeGetNames(const char ***names, PetscInt *n);
/* whether an integrator type is one of the implicit schemes (so it has a feasible line search) */
PetscErrorCode MSimImplicitSchemeIsRegistered(const char type[], PetscBool *is);

/* Create with a scheme by name (NULL: implicit Euler) and the terms of -msim_implicit_terms
   (default: every registered term; a term whose physics the scene lacks costs nothing). */
PetscErrorCode MSimImplicitCreate(MSimSystem sys, MSimImplicit *imp);
PetscErrorCode MSimImplicitCreateWithScheme(MSimSystem sys, const char scheme[], MSimImplicit *imp);
/* Refuse a -msim_implicit_terms that leaves out a term the scene needs (drag, obstacles, friction,
   self-contact, self-friction, volume): for a run's integrator; the problem alone may leave
   any out, as tests of Phi's parts do. Collective. */
PetscErrorCode MSimImplicitCheckTermsCoverScene(MSimImplicit imp);
PetscErrorCode MSimImplicitDestroy(MSimImplicit *imp);
PetscErrorCode MSimImplicitView(MSimImplicit imp, PetscViewer viewer);
/* Project each Hessian block to PSD in the Jacobian (the default) or not (-msim_psd) */
PetscErrorCode MSimImplicitSetPSD(MSimImplicit imp, PetscBool psd);
/* How many energy terms the problem sums */
PetscErrorCode MSimImplicitGetNumTerms(MSimImplicit imp, PetscInt *n);
/* The current step's x_n and y (the problem's own Vecs; either may be NULL) */
PetscErrorCode MSimImplicitGetStepState(MSimImplicit imp, Vec *Xn, Vec *Y);
/* imp->step from the scheme's beta and gamma at step size imp->h */
PetscErrorCode MSimImplicitStepUpdate(MSimImplicit imp);
/* start a step from (X, V) at t: sets x_n, y (the scheme's begin_step) */
PetscErrorCode MSimImplicitBeginStep(MSimImplicit imp, PetscReal t, PetscReal h, Vec X, Vec V);
/* X := the first iterate (X holds x_n) */
PetscErrorCode MSimImplicitGuess(MSimImplicit imp, Vec V, Vec X);
/* X holds the minimizer: x_{n+1} into X, v_{n+1} into V */
PetscErrorCode MSimImplicitEndStep(MSimImplicit imp, Vec X, Vec V);
/* Y += s (g + c w / m): the constant external acceleration, for the schemes' y */
PetscErrorCode MSimImplicitAddExternalAcceleration(MSimImplicit imp, PetscReal s, Vec Y);
/* Y += s M^-1 f_d(P, U): the dissipative forces (spring damping with P's axes and the handles'
   velocity, drag -c U) at (P, U) and time t, for the second-order schemes' y (F, W: work vectors;
   src/implicit/schemes/dissipation.cpp says why) */
PetscErrorCode MSimImplicitAddDissipativeAcceleration(MSimImplicit imp, PetscReal s, PetscReal t, Vec P, Vec U, Vec F, Vec W, Vec Y);
PetscErrorCode MSimImplicitResidual(MSimImplicit imp, Vec X, Vec G);
/* Phi at X; an error for a scheme with no objective (scheme->no_objective) */
PetscErrorCode MSimImplicitObjective(MSimImplicit imp, Vec X, PetscReal *phi);
PetscErrorCode MSimImplicitJacobian(MSimImplicit imp, Vec X, Mat J);
/* the Jacobian plus delta M (inertia correction) */
PetscErrorCode MSimImplicitJacobianShifted(MSimImplicit imp, Vec X, PetscReal delta, Mat J);
/* the largest alpha in (0, 1] for which X - alpha Y is feasible for every term (1 today) */
PetscErrorCode MSimImplicitMaxStep(MSimImplicit imp, Vec X, Vec Y, PetscReal *alpha);
/* Refuses (one line, collective) a start state X at time t outside a term's feasible set (each
   term's check_start); restart: NULL for the scene's start, else the checkpoint's, in words */
PetscErrorCode MSimImplicitCheckStart(MSimImplicit imp, PetscReal t, Vec X, const char *restart);
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
/* imp->pd filled with the PD steps and composed on dm, where the pd SNES type finds them */
PetscErrorCode MSimImplicitPDCompose(MSimImplicit imp, DM dm);
