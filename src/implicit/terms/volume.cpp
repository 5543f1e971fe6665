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
   and PD's Phi check (pd_check) is asked for only where some tet may come below jhat; with the
   barrier alone the term gives PD's bound on Phi its excess over its lagged model (pd_gap), from
   which PD leaves the check out or sizes a rejected step (pd_steps.cpp, PDBound). */
#include <msim/implicit.h>
#include <msim/volume.h>
#include <msim/volume_kernels.hpp>
#include <vector>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <petsc/private/petscimpl.h> /* PetscObjectStateGet: whether D is the step max_step saw */

/* term->data: what the last max_step saw, for PD's check after it. rec: with the barrier alone,
   each tet of max_step's list (T.active: every tet it could not prove above jhat along the step;
   all of them without a reference) as V0, 1/V0, b(J0), b'(J0), dJ(x0).y / (the tet's 6 V) and its
   4 vertices' x0 and y (max_step's local slots), so that pd_gap evaluates the barrier at
   x0 - a y for any a without a new exchange (a Phi evaluation between max_step and pd_gap
   overwrites the slots) */
typedef struct {
  PetscBool             barrier; /* its motion may meet the barrier (J < jhat) */
  PetscReal             alpha;   /* max_step's step */
  PetscObjectId         yid;     /* the step Y max_step saw, and its state */
  PetscObjectState      ystate;
  std::vector<PetscReal> rec;
} VolumeData;

enum { REC_V0, REC_IV0, REC_B0, REC_DB0, REC_GY, REC_X, REC_Y = REC_X + 12, REC_N = REC_Y + 12 };

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

/* With the barrier alone, max_step's list of tets at x0 and y, the local slots it just filled
   (VolumeData's rec): each tet's V0, b(J0), b'(J0) and dJ(x0).y. Elsewhere J stays above jhat
   along the step, where b, b' are zero. */
static void BarrierRecords(MSimSystem sys, bool all, std::vector<PetscReal> &rec)
{
  const MSimTets         &T = sys->tets;
  const msim::TetMaterial m = {0.0, T.kappa, T.jhat};
  const PetscScalar      *xl, *yl;
  const size_t            n = all ? T.V0.size() : T.active.size();

  rec.resize(REC_N * n);
  PetscCallAbort(PETSC_COMM_SELF, VecGetArrayRead(sys->xloc, &xl));
  PetscCallAbort(PETSC_COMM_SELF, VecGetArrayRead(T.yloc, &yl));
  for (size_t k = 0; k < n; k++) {
    const size_t    c  = all ? k : (size_t)T.active[k];
    const PetscInt *q4 = T.slot.data() + 4 * c;
    const double   *x[4] = {xl + 3 * q4[0], xl + 3 * q4[1], xl + 3 * q4[2], xl + 3 * q4[3]};
    double          g[12], *r = rec.data() + REC_N * k;
    const double    J0 = msim::TetVolumeGradient(x, g) * T.iV0[c];
    double          gy = 0;
    for (int q = 0; q < 4; q++)
      for (int i = 0; i < 3; i++) {
        const double y = yl[3 * q4[q] + i];
        gy += g[3 * q + i] * y;
        r[REC_X + 3 * q + i] = x[q][i];
        r[REC_Y + 3 * q + i] = y;
      }
    r[REC_V0]  = T.V0[c];
    r[REC_IV0] = T.iV0[c];
    r[REC_GY]  = gy;
    msim::TetPsi(m, J0, &r[REC_B0], &r[REC_DB0], NULL);
  }
  PetscCallAbort(PETSC_COMM_SELF, VecRestoreArrayRead(T.yloc, &yl));
  PetscCallAbort(PETSC_COMM_SELF, VecRestoreArrayRead(sys->xloc, &xl));
}

/* term->data (VolumeData): whether the last max_step's motion may meet the barrier, and with the
   barrier alone the tets pd_gap needs */
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
  vd->alpha = *alpha;
  vd->rec.clear();
  vd->yid    = 0; /* no direction recorded: pd_gap answers +inf (no bound) */
  vd->ystate = 0;
  if (vd->barrier && !(term->ops.pd_gap && imp->A)) PetscFunctionReturn(PETSC_SUCCESS); /* the records were not built: an empty list would claim no excess */
  PetscCall(PetscObjectGetId((PetscObject)Y, &vd->yid));
  PetscCall(PetscObjectStateGet((PetscObject)Y, &vd->ystate));
  if (vd->barrier) BarrierRecords(sys, !ref, vd->rec);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD's global step checks Phi along its step only where the barrier may be met: elsewhere the
   term is Teschner's quadratic, lagged in the right-hand side as with -msim_volume_kappa 0, which
   never asks for that check. Saves an evaluation of Phi (every term's pass) per PD iteration. */
static PetscErrorCode PDCheck_Volume(MSimImplicitTerm term, PetscBool *needed)
{
  PetscFunctionBeginUser;
  *needed = ((VolumeData *)term->data)->barrier;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PD's bound on Phi (pd_steps.cpp, PDBound), with the barrier alone (kv = 0): the right-hand side
   holds the barrier's gradient at X0 and A no weight of it, so gap[j] += h^2 sum_t V0 (b(J(x0 -
   a_j y)) - b(J0) + a_j b'(J0) dJ(x0).y), the barrier's excess over its linear model, summed over
   the ranks. Only the tets of max_step's list (the ~160 of the bunny's 9,549 within reach of jhat
   along the step); so D must be the step max_step saw (same Vec, unchanged) and a_j at most its
   alpha, else no bound (+inf). X0 is max_step's X: the records hold its positions. */
static PetscErrorCode PDGap_Volume(MSimImplicitTerm term, Vec X0, Vec D, PetscInt n, const PetscReal alpha[], PetscReal gap[])
{
  MSimImplicit            imp = term->imp;
  const MSimTets         &T   = imp->sys->tets;
  const msim::TetMaterial m   = {0.0, T.kappa, T.jhat};
  VolumeData             *vd  = (VolumeData *)term->data;
  PetscObjectId           id;
  PetscObjectState        state;
  std::vector<PetscReal>  g(n, 0.0);
  const size_t            nt = vd->rec.size() / REC_N;

  PetscFunctionBeginUser;
  (void)X0;
  PetscCall(PetscObjectGetId((PetscObject)D, &id));
  PetscCall(PetscObjectStateGet((PetscObject)D, &state));
  for (PetscInt j = 0; j < n; j++) {
    if (id != vd->yid || state != vd->ystate || !(alpha[j] <= vd->alpha)) {
      g[j] = PETSC_INFINITY;
      continue;
    }
    const double a = alpha[j];
    for (size_t k = 0; k < nt; k++) {
      const double *r = vd->rec.data() + REC_N * k;
      double        x1[12], b1;
      for (int i = 0; i < 12; i++) x1[i] = r[REC_X + i] - a * r[REC_Y + i];
      const double J1 = msim::TetSignedVolume(x1, x1 + 3, x1 + 6, x1 + 9) * r[REC_IV0];
      msim::TetPsi(m, J1, &b1, NULL, NULL);
      g[j] += r[REC_V0] * (b1 - r[REC_B0] + a * r[REC_DB0] * r[REC_GY] * r[REC_IV0]);
    }
  }
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, g.data(), (PetscMPIInt)n, MPIU_REAL, MPIU_SUM, imp->sys->comm));
  for (PetscInt j = 0; j < n; j++) gap[j] += imp->step.h2 * g[j];
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Moving handles (-msim_fix_velocity): x_n, feasible at t_n, need not be at tx, where the
   handles have moved by w h while the free vertices have not; a tet between them that is thinner
   than that move along w is inverted there, the barrier infinite, and no solver can start: plain
   PD's max_step was 0 from there and each step wrote that start, inverted, as its result (a 3 x 3
   x 3 box whose top face pressed down at 0.5 m/s left the tets under it 0.3 mm thin after 9 steps,
   then inverted them by 5 mm a step). Carrying the free vertices with the handles, as
   self-contact's start does (FeasibleStart_Self), cannot help in general: what the handles push
   is what the tets hold up (the box's floor). So the step is refused (imp->refused) with the
   worst tet, the handles' move and the step that tet allows. A holds the other terms' start. */
static PetscErrorCode FeasibleStart_Volume(MSimImplicitTerm term, Vec A)
{
  MSimImplicit    imp = term->imp;
  MSimSystem      sys = imp->sys;
  const PetscReal h = imp->step.tx - imp->step.t, *w = sys->fix_velocity, move = h * PetscSqrtReal(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
  PetscInt        n;
  PetscReal       a, c[3];

  PetscFunctionBeginUser;
  imp->refused[0] = 0;
  PetscCall(MSimSystemVolumeHandleStart(sys, imp->step.t, imp->step.tx, A, &n, &a, c));
  if (!n) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscSNPrintf(imp->refused, sizeof(imp->refused), "the moving handles (-msim_fix_velocity) invert %" PetscInt_FMT " tet(s): they move %g m in one step, and the worst tet, near (%g, %g, %g) m, flattens after %g m of it (the inversion barrier of -msim_volume is infinite at the step's start, where no solver can begin; reduce -msim_dt below %g s)", n, (double)move, (double)c[0], (double)c[1], (double)c[2], (double)(a * move), (double)(a * h)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the start's check is the system's (MSimSystemVolumeCheckStart), which the spectrum shares */
static PetscErrorCode CheckStart_Volume(MSimImplicitTerm term, PetscReal t, Vec X, const char *restart)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemVolumeCheckStart(term->imp->sys, t, X, restart));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Destroy_Volume(MSimImplicitTerm term)
{
  VolumeData *vd = (VolumeData *)term->data;

  PetscFunctionBeginUser;
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

static const MSimImplicitTermOps VolumeOps = {.energy = Energy_Volume, .gradient = Gradient_Volume, .hessian = Hessian_Volume, .pd_rhs = PDRHS_Volume, .max_step = MaxStep_Volume, .pd_check = PDCheck_Volume, .pd_gap = PDGap_Volume, .check_start = CheckStart_Volume, .view = View_Volume, .destroy = Destroy_Volume};

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
    term->ops.pd_gap      = NULL;
    term->ops.check_start = NULL;
    term->ops.destroy     = NULL;
  } else {
    const PetscReal *w = term->imp->sys->fix_velocity;
    term->data         = new VolumeData{PETSC_TRUE, 1, 0, 0, {}};
    if (term->imp->sys->nfix_global && (w[0] != 0 || w[1] != 0 || w[2] != 0)) term->ops.feasible_start = FeasibleStart_Volume;
  }
  /* Teschner's quadratic (kv > 0) is lagged too, over every tet: no pd_gap (PD halves on Phi) */
  if (T.kv != 0 || !T.pd_bound) term->ops.pd_gap = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
