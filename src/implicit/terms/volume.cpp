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
   and PD's Phi check (pd_check) is asked for only where some tet may come below jhat and, with
   the barrier alone, where the barrier's excess over its lagged model may outweigh the global
   step's decrease of its quadratic model (PDCheck_Volume). */
#include <msim/implicit.h>
#include <msim/volume.h>
#include <msim/volume_kernels.hpp>
#include <msim/solvers.h> /* MSimMatMultInterleaved3 */
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>

/* term->data: what the last max_step saw, for PD's check after it */
typedef struct {
  PetscBool barrier; /* its motion may meet the barrier (J < jhat) */
  PetscReal gap;     /* this rank's barrier excess over its linear model at X - alpha Y */
  PetscReal alpha;   /* max_step's step */
  Vec       Y, W;    /* the step (the caller's, alive until its check) and a work Vec for A Y */
  PetscInt  checks, skipped; /* bounds tried, checks they left out (-info) */
} VolumeData;

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

/* With the barrier alone, this rank's sum over the tets of the last max_step's list (T.active:
   every tet it could not prove above jhat along the step; all of them without a reference) of
   V0 (b(J1) - b(J0) + a b'(J0) dJ(x0).y), x0 and y the local slots max_step just filled, J1 at
   x0 - a y: the barrier's excess over its linear model at the step's end (a: max_step's).
   Elsewhere J stays above jhat, where b, b' are zero. */
static PetscReal BarrierGapLocal(MSimSystem sys, bool all, PetscReal a)
{
  const MSimTets         &T = sys->tets;
  const msim::TetMaterial m = {0.0, T.kappa, T.jhat};
  const PetscScalar      *xl, *yl;
  PetscReal               gap = 0;
  const size_t            n   = all ? T.V0.size() : T.active.size();

  PetscCallAbort(PETSC_COMM_SELF, VecGetArrayRead(sys->xloc, &xl));
  PetscCallAbort(PETSC_COMM_SELF, VecGetArrayRead(T.yloc, &yl));
  for (size_t k = 0; k < n; k++) {
    const size_t    c  = all ? k : (size_t)T.active[k];
    const PetscInt *q4 = T.slot.data() + 4 * c;
    const double   *x[4] = {xl + 3 * q4[0], xl + 3 * q4[1], xl + 3 * q4[2], xl + 3 * q4[3]};
    double          g[12], x1[12], b0, db0, b1;
    const double    J0 = msim::TetVolumeGradient(x, g) * T.iV0[c];
    double          gy = 0;
    for (int q = 0; q < 4; q++)
      for (int i = 0; i < 3; i++) {
        const double y = yl[3 * q4[q] + i];
        gy += g[3 * q + i] * y;
        x1[3 * q + i] = x[q][i] - a * y;
      }
    const double J1 = msim::TetSignedVolume(x1, x1 + 3, x1 + 6, x1 + 9) * T.iV0[c];
    msim::TetPsi(m, J0, &b0, &db0, NULL);
    msim::TetPsi(m, J1, &b1, NULL, NULL);
    gap += T.V0[c] * (b1 - b0 + a * db0 * gy * T.iV0[c]);
  }
  PetscCallAbort(PETSC_COMM_SELF, VecRestoreArrayRead(T.yloc, &yl));
  PetscCallAbort(PETSC_COMM_SELF, VecRestoreArrayRead(sys->xloc, &xl));
  return gap;
}

/* term->data (VolumeData): whether the last max_step's motion may meet the barrier, and with the
   barrier alone its excess over its model at the full step, for PDCheck_Volume */
static PetscErrorCode MaxStep_Volume(MSimImplicitTerm term, Vec X, Vec Y, PetscReal *alpha)
{
  MSimImplicit    imp = term->imp;
  MSimSystem      sys = imp->sys;
  const MSimTets &T   = sys->tets;
  VolumeData     *vd  = (VolumeData *)term->data;
  /* max_step's list of tets: its reference's (msim/volume.h), or every tet without one */
  const bool      ref = T.gl.size() == 2 * T.V0.size() && T.xref.size() == (size_t)(3 * sys->nloc) && T.r2slot.size() == (size_t)sys->nloc;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemVolumeMaxStep(sys, imp->step.tx, X, Y, alpha, &vd->barrier));
  vd->Y     = Y;
  vd->alpha = *alpha;
  vd->gap   = PETSC_INFINITY; /* no bound: the check, as before */
  if (vd->barrier && T.kv == 0) vd->gap = BarrierGapLocal(sys, !ref, *alpha);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD's global step checks Phi along its step only where the barrier may be met: elsewhere the
   term is Teschner's quadratic, lagged in the right-hand side as with -msim_volume_kappa 0, which
   never asks for that check. Saves an evaluation of Phi (every term's pass) per PD iteration.
   With the barrier alone (kv = 0) and a full step from a factor, the check is also left out where
   Phi provably does not rise. The step X1 = X0 - Y = A^-1 rhs(X0) minimises the global step's
   quadratic model S (the springs' projections at X0, inertia and the diagonal terms, and the
   barrier's linear model at X0), with S(X0) = Phi(X0) and S(X1) = Phi(X0) - Y^T A Y / 2; the
   springs' energy at X1 is at most their projections' energy, so Phi(X1) <= Phi(X0) - Y^T A Y / 2
   + gap, gap = the barrier's excess over its linear model at X1 (BarrierGapLocal, the few tets
   within reach of jhat; h^2 times it in Phi). gap <= Y^T A Y / 2: no check (one product with A
   instead of a pass of every term and the halvings). The other terms with a feasible set ask for
   their own check; the model is the right-hand side's at X0, as PD's loops take it. */
static PetscErrorCode PDCheck_Volume(MSimImplicitTerm term, PetscBool *needed)
{
  MSimImplicit imp = term->imp;
  VolumeData  *vd  = (VolumeData *)term->data;
  PetscReal    gap = vd->gap, yay;
  const double a   = vd->alpha;
  PetscInt     feasible = 0;

  PetscFunctionBeginUser;
  *needed = vd->barrier;
  /* the bound is at max_step's alpha: the step's, where no other term has a feasible set */
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.max_step) feasible++;
  if (!vd->barrier || imp->pd_iterative || !imp->A || feasible > 1) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCallMPI(MPIU_Allreduce(MPI_IN_PLACE, &gap, 1, MPIU_REAL, MPIU_SUM, imp->sys->comm));
  if (!(gap < PETSC_INFINITY)) PetscFunctionReturn(PETSC_SUCCESS);
  if (!vd->W) PetscCall(VecDuplicate(vd->Y, &vd->W));
  PetscCall(MSimMatMultInterleaved3(imp->A, &imp->A3, vd->Y, NULL, vd->W));
  PetscCall(VecDot(vd->Y, vd->W, &yay));
  *needed = (PetscBool)!(imp->step.h2 * gap <= (a - 0.5 * a * a) * PetscRealPart(yay));
  vd->checks++;
  if (!*needed) vd->skipped++;
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Volume(MSimImplicitTerm term)
{
  VolumeData *vd = (VolumeData *)term->data;

  PetscFunctionBeginUser;
  PetscCall(PetscInfo(NULL, "volume: PD's Phi check left out by the barrier's bound in %" PetscInt_FMT " of %" PetscInt_FMT " steps that reached it\n", vd->skipped, vd->checks));
  PetscCall(VecDestroy(&vd->W));
  delete vd;
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
  } else term->data = new VolumeData{PETSC_TRUE, PETSC_INFINITY, 1, NULL, NULL, 0, 0};
  PetscFunctionReturn(PETSC_SUCCESS);
}
