/* The tets' volume term in Phi (msim/volume.h): beta h^2 sum_t |V0| psi(J_t), a Teschner volume
   energy plus IPC's log barrier on J = V/V0 (msim/volume_kernels.hpp), with its exact gradient,
   12 x 12 Hessian blocks (eigen-projected to PSD on request) and max_step: the largest step along
   which no tet's signed volume reaches zero (the cubic in alpha per tet), times 0.8. A feasible
   start (x_n, every tet positive) and a line search that starts at max_step keep every iterate,
   and so x_{n+1}, free of inverted tets. PD: the term's force at the current iterate in the
   right-hand side (lagged, as the obstacles' barrier), the PD matrix unchanged, and the global step
   shortened by max_step and halved until Phi does not rise (src/implicit/pd_steps.cpp) - not
   Bouaziz's volume projection with a weight in the matrix. Schemes whose unknown is not x_{n+1}
   (midpoint, Newmark) are refused while the barrier is on, as the obstacles' are. With kv = 0
   (the barrier alone) every pass skips the tets the safe radii prove above jhat (msim/volume.h),
   and PD's Phi check (pd_check) is asked for only where some tet may come below jhat. */
#include <msim/implicit.h>
#include <msim/volume.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

static PetscErrorCode Energy_Volume(MSimImplicitTerm term, Vec X, PetscReal *e)
{
  MSimImplicit imp   = term->imp;
  PetscReal    local = 0;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemVolumeGradient(imp->sys, imp->step.tx, X, 0.0, NULL, &local, PETSC_FALSE));
  PetscCallMPI(MPIU_Allreduce(MPI_IN_PLACE, &local, 1, MPIU_REAL, MPIU_SUM, imp->sys->comm));
  *e += imp->step.h2 * local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Gradient_Volume(MSimImplicitTerm term, Vec X, Vec G)
{
  MSimImplicit imp = term->imp;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemVolumeGradient(imp->sys, imp->step.tx, X, imp->step.h2, G, NULL, PETSC_FALSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Hessian_Volume(MSimImplicitTerm term, Vec X, PetscBool psd, Mat J)
{
  MSimImplicit imp = term->imp;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemVolumeHessian(imp->sys, imp->step.tx, X, imp->step.h2, psd, J));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD: rhs -= the term's gradient at X; *e += this rank's part of its Phi */
static PetscErrorCode PDRHS_Volume(MSimImplicitTerm term, Vec X, Vec rhs, PetscReal *e)
{
  MSimImplicit imp   = term->imp;
  PetscReal    local = 0;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemVolumeGradient(imp->sys, imp->step.tx, X, -imp->step.h2, rhs, e ? &local : NULL, PETSC_FALSE));
  if (e) *e += imp->step.h2 * local;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* term->data: whether the last max_step's motion may meet the barrier (J < jhat) */
static PetscErrorCode MaxStep_Volume(MSimImplicitTerm term, Vec X, Vec Y, PetscReal *alpha)
{
  MSimImplicit imp = term->imp;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemVolumeMaxStep(imp->sys, imp->step.tx, X, Y, alpha, (PetscBool *)term->data));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD's global step checks Phi along its step only where the barrier may be met: elsewhere the
   term is Teschner's quadratic, lagged in the right-hand side as with -msim_volume_kappa 0, which
   never asks for that check. Saves an evaluation of Phi (every term's pass) per PD iteration. */
static PetscErrorCode PDCheck_Volume(MSimImplicitTerm term, PetscBool *needed)
{
  PetscFunctionBeginUser;
  *needed = *(PetscBool *)term->data;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Volume(MSimImplicitTerm term)
{
  PetscFunctionBeginUser;
  delete (PetscBool *)term->data;
  term->data = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode View_Volume(MSimImplicitTerm term, PetscViewer viewer)
{
  const MSimTets &T = term->imp->sys->tets;

  PetscFunctionBeginUser;
  PetscCall(PetscViewerASCIIPrintf(viewer, "volume: %" PetscInt_FMT " tets, kv %g Pa, inversion barrier kappa %g Pa below J = %g\n", T.ntet, (double)T.kv, (double)T.kappa, (double)T.jhat));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static const MSimImplicitTermOps VolumeOps = {.energy = Energy_Volume, .gradient = Gradient_Volume, .hessian = Hessian_Volume, .pd_rhs = PDRHS_Volume, .max_step = MaxStep_Volume, .pd_check = PDCheck_Volume, .view = View_Volume, .destroy = Destroy_Volume};

PetscErrorCode MSimImplicitTermCreate_Volume(MSimImplicitTerm term)
{
  const MSimTets &T = term->imp->sys->tets;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS); /* no tets, or -msim_volume 0: no op */
  PetscCheck(T.kappa == 0 || !term->imp->scheme->no_barrier, term->imp->sys->comm, PETSC_ERR_SUP, "-msim_integrator %s with the tets' inversion barrier is not supported (%s): use implicit_euler or bdf2, or -msim_volume_kappa 0 (or -msim_volume 0)", term->imp->scheme->type, term->imp->scheme->no_barrier);
  term->ops          = VolumeOps;
  term->in_potential = PETSC_TRUE; /* MSimSystemComputeEnergy counts the tets' energy */
  if (T.kappa == 0) { /* no barrier: every step is feasible */
    term->ops.max_step = NULL;
    term->ops.pd_check = NULL;
    term->ops.destroy  = NULL;
  } else term->data = new PetscBool(PETSC_TRUE);
  PetscFunctionReturn(PETSC_SUCCESS);
}
