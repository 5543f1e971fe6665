/* Newton with inertia correction (msim/implicit.h): on a cloth whose springs are compressed the
   exact Hessian H = M + h^2 K is indefinite and plain Newton, which looks for any point where
   g = 0, converges to saddle points of Phi (flat compressed patches that should buckle). Shifting
   to H + delta M until the LDL^T has no negative pivot makes every direction a descent direction
   of Phi, as in interior-point codes (Nocedal and Wright, Numerical Optimization, 2nd ed., sec.
   3.4 and 19.3): the least delta of the sequence 0 or a third of the previous iteration's shift,
   then first_shift, then x8, is kept. The shift scales the mass, so it is dimensionless; where H
   is positive definite (stretched cloth, and near a minimum) delta shrinks 3x per iteration to 0 and Newton
   converges quadratically. */
#include <msim/implicit.h>

/* shifts below this are dropped (H itself is tried); the first nonzero shift, relative to M */
static const PetscReal MSIM_SHIFT_MIN = 1e-8, MSIM_SHIFT_FIRST = 1e-3, MSIM_SHIFT_GROWTH = 8;
/* 1e-3 x 8^30 = 1e24: no mass-spring Hessian needs more; stop there with an error */
static const PetscInt MSIM_SHIFT_TRIES = 30;

PetscErrorCode MSimImplicitFactorInertia(KSP ksp, Mat J, PetscInt *nneg)
{
  PC             pc;
  Mat            F;
  PCFailedReason failed;

  PetscFunctionBeginUser;
  PetscCall(KSPSetOperators(ksp, J, J));
  PetscCall(KSPSetUp(ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCGetFailedReason(pc, &failed));
  if (failed != PC_NOERROR) {
    *nneg = -1;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(PCFactorGetMatrix(pc, &F));
  PetscCall(MatGetInertia(F, nneg, NULL, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimImplicitJacobianInertiaCorrected(MSimImplicit imp, KSP ksp, Vec X, Mat J, MSimInertiaCorrection *ic)
{
  PetscReal delta = ic->delta_last / 3;
  PetscInt  nneg;

  PetscFunctionBeginUser;
  if (delta < MSIM_SHIFT_MIN) delta = 0;
  for (PetscInt try_ = 0;; try_++) {
    PetscCall(MSimImplicitJacobianShifted(imp, X, delta, J));
    PetscCall(MSimImplicitFactorInertia(ksp, J, &nneg));
    if (nneg == 0) break;
    PetscCheck(try_ < MSIM_SHIFT_TRIES, PetscObjectComm((PetscObject)J), PETSC_ERR_NOT_CONVERGED, "-msim_inertia_correction: H + %g M still %s", (double)delta, nneg < 0 ? "cannot be factored" : "has negative eigenvalues");
    PetscCall(PetscInfo(ksp, "inertia correction: H + %g M has %" PetscInt_FMT " negative eigenvalues%s\n", (double)delta, nneg, nneg < 0 ? " (factorization failed)" : ""));
    delta = delta == 0 ? MSIM_SHIFT_FIRST : MSIM_SHIFT_GROWTH * delta;
    ic->extra++;
  }
  if (delta > 0) ic->shifted++;
  ic->delta_last = delta;
  ic->delta_max  = PetscMax(ic->delta_max, delta);
  PetscFunctionReturn(PETSC_SUCCESS);
}
