/* The volume term over the system's tets (msim/volume.h; the per-tet physics in
   msim/volume_kernels.hpp). Each tet is computed by one rank from its local slots: owned rows from
   X's array, ghost and fixed slots from xloc (the springs' exchange); forces on ghost slots are
   added to their owners by one reverse scatter (floc's ghost slots). */
#include <msim/volume.h>
#include <msim/volume_kernels.hpp>
#include <msim/log.h>
#include <msim/private/systemimpl.h>

static msim::TetMaterial Material(MSimSystem sys)
{
  return {sys->tets.kv, sys->tets.kappa, sys->tets.jhat};
}

/* f(c, x[4]) for every tet of this rank at X (t: the fixed slots' time); xl filled here */
template <class F>
static PetscErrorCode ForEachTet(MSimSystem sys, PetscReal t, Vec X, F &&f)
{
  const PetscScalar *xo, *xl;
  const MSimTets    &T = sys->tets;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGhostsBegin(sys, X, sys->xloc));
  PetscCall(MSimSystemGhostsEnd(sys, t, X, sys->xloc));
  PetscCall(VecGetArrayRead(X, &xo));
  PetscCall(VecGetArrayRead(sys->xloc, &xl));
  for (size_t c = 0; c < T.V0.size(); c++) {
    const double *x[4];
    for (int q = 0; q < 4; q++) {
      const PetscInt s = T.slot[4 * c + q];
      x[q]             = (s < sys->nown ? xo : xl) + 3 * s;
    }
    f(c, x);
  }
  PetscCall(VecRestoreArrayRead(sys->xloc, &xl));
  PetscCall(VecRestoreArrayRead(X, &xo));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeSetUp(MSimSystem sys, PetscReal modulus)
{
  MSimTets &T = sys->tets;
  PetscInt  bad;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS);
  /* a tenth of the springs' modulus: the springs' own bulk modulus is 2E/3 (Poisson ratio 1/4),
     so the term stiffens uniform compression by 15% and the explicit limit little; the barrier,
     not kv, keeps tets from inverting */
  if (T.kv < 0) T.kv = 0.1 * modulus;
  if (T.kappa < 0) T.kappa = T.kv;
  PetscCheck(T.kv >= 0 && T.kappa >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_volume_stiffness and -msim_volume_kappa must be >= 0 Pa (got %g, %g)", (double)T.kv, (double)T.kappa);
  if (T.kv == 0 && T.kappa == 0) {
    T.ntet = 0; /* nothing to compute */
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecDuplicate(sys->xloc, &T.yloc));
  PetscCall(MSimSystemVolumeCountInverted(sys, 0.0, sys->X0, &bad));
  PetscCheck(!bad || T.kappa == 0, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_volume: %" PetscInt_FMT " tets are inverted or flat at the start (-msim_perturb or -msim_prestretch?): the inversion barrier needs every tet positive (-msim_volume_kappa 0 turns it off)", bad);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeCountInverted(MSimSystem sys, PetscReal t, Vec X, PetscInt *n)
{
  PetscInt        local = 0;

  PetscFunctionBeginUser;
  PetscCall(ForEachTet(sys, t, X, [&](size_t c, const double *const x[4]) {
    if (!(msim::TetSignedVolume(x[0], x[1], x[2], x[3]) > 0)) local++;
  }));
  PetscCallMPI(MPI_Allreduce(&local, n, 1, MPIU_INT, MPI_SUM, sys->comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeGradient(MSimSystem sys, PetscReal t, Vec X, PetscReal w, Vec F, PetscReal *e, PetscBool clamp)
{
  const MSimTets         &T = sys->tets;
  const msim::TetMaterial m = Material(sys);
  PetscScalar            *f = NULL, *fl = NULL;
  PetscReal               local = 0;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Volume, X, F, 0, 0));
  if (F) {
    PetscCall(VecGetArray(F, &f));
    PetscCall(VecGetArray(sys->floc, &fl));
    PetscCall(PetscArrayzero(fl + 3 * sys->nown, 3 * sys->nghost));
  }
  PetscCall(ForEachTet(sys, t, X, [&](size_t c, const double *const x[4]) {
    double       g[12], psi = 0, dpsi = 0;
    const double V0 = T.V0[c]; /* > 0 */
    const double J  = (F ? msim::TetVolumeGradient(x, g) : msim::TetSignedVolume(x[0], x[1], x[2], x[3])) * T.iV0[c];
    /* clamp (the explicit force): J held at jhat/100 or more in the barrier, so that an inverted
       tet is pushed back by a finite force instead of none (psi is +inf there) */
    const double Jc = clamp ? PetscMax(J, 0.01 * m.jhat) : J;
    msim::TetPsi(m, Jc, &psi, &dpsi, NULL);
    dpsi += m.kv * (J - Jc); /* the quadratic part at the true J */
    if (e) local += V0 * psi;
    if (!F) return;
    const double coef = w * dpsi; /* V0 psi'(J) dJ/dV */
    for (int q = 0; q < 4; q++) {
      const PetscInt s = T.slot[4 * c + q];
      if (s < sys->nown)
        for (int k = 0; k < 3; k++) f[3 * s + k] += coef * g[3 * q + k];
      else if (s < sys->nown + sys->nghost)
        for (int k = 0; k < 3; k++) fl[3 * s + k] += coef * g[3 * q + k];
    }
  }));
  if (F) {
    PetscCall(VecRestoreArray(sys->floc, &fl));
    PetscCall(VecRestoreArray(F, &f));
    PetscCall(MSimSystemGhostsAdd(sys, sys->floc, F));
  }
  if (e) *e += local;
  PetscCall(PetscLogFlops(150.0 * T.V0.size()));
  PetscCall(PetscLogEventEnd(MSIM_Volume, X, F, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeHessian(MSimSystem sys, PetscReal t, Vec X, PetscReal w, PetscBool psd, Mat J)
{
  const MSimTets         &T   = sys->tets;
  const msim::TetMaterial m   = Material(sys);
  const PetscInt          nfl = sys->nown + sys->nghost;
  PetscErrorCode          ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Volume, X, J, 0, 0));
  PetscCall(ForEachTet(sys, t, X, [&](size_t c, const double *const x[4]) {
    msim::Mat12 H;
    PetscInt    idx[12];
    PetscScalar blk[144];
    if (ierr) return;
    msim::TetEnergy(m, T.V0[c], x, NULL, &H, psd);
    /* fixed vertices are no unknowns: their rows and columns are left out (negative indices) */
    for (int q = 0; q < 4; q++) {
      const PetscInt s = T.slot[4 * c + q];
      for (int k = 0; k < 3; k++) idx[3 * q + k] = s < nfl ? 3 * sys->local_to_global[s] + k : -1;
    }
    for (int a = 0; a < 12; a++)
      for (int b = 0; b < 12; b++) blk[12 * a + b] = w * H(a, b);
    ierr = MatSetValues(J, 12, idx, 12, idx, blk, ADD_VALUES);
  }));
  PetscCall(ierr);
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  PetscCall(PetscLogEventEnd(MSIM_Volume, X, J, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeMaxStep(MSimSystem sys, PetscReal t, Vec X, Vec Y, PetscReal *alpha)
{
  const MSimTets    &T = sys->tets;
  const PetscScalar *yo, *yl;
  PetscReal          a = *alpha;
  static const double zero[3] = {0, 0, 0};

  PetscFunctionBeginUser;
  if (!T.ntet || T.kappa == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Volume, X, Y, 0, 0));
  /* Y's ghost slots (its fixed slots are not read: fixed vertices do not move along Y) */
  PetscCall(MSimSystemGhostsBegin(sys, Y, T.yloc));
  PetscCall(MSimSystemGhostsEnd(sys, t, Y, T.yloc));
  PetscCall(VecGetArrayRead(Y, &yo));
  PetscCall(VecGetArrayRead(T.yloc, &yl));
  PetscCall(ForEachTet(sys, t, X, [&](size_t c, const double *const x[4]) {
    const double *y[4];
    for (int q = 0; q < 4; q++) {
      const PetscInt s = T.slot[4 * c + q];
      y[q]             = s < sys->nown ? yo + 3 * s : s < sys->nown + sys->nghost ? yl + 3 * s : zero;
    }
    /* the barrier's 0.8 (IPC's CCD filter, as the obstacles): the line search starts short of
       the first flat tet, where the barrier is finite */
    const double z = msim::TetFirstZero(T.V0[c], x, y, a / 0.8);
    if (0.8 * z < a) a = 0.8 * z;
  }));
  PetscCall(VecRestoreArrayRead(T.yloc, &yl));
  PetscCall(VecRestoreArrayRead(Y, &yo));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &a, 1, MPIU_REAL, MPIU_MIN, sys->comm));
  *alpha = a;
  PetscCall(PetscLogEventEnd(MSIM_Volume, X, Y, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeRowSums(MSimSystem sys, PetscScalar *floc)
{
  const MSimTets &T = sys->tets;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS);
  /* at rest psi' = 0 and psi'' = kv (the barrier is zero above jhat): D^2 E_ij = kv/|V0| g_i g_j^T,
     of norm kv/|V0| |g_i| |g_j|; the initial state stands for the rest state */
  PetscCall(ForEachTet(sys, 0.0, sys->X0, [&](size_t c, const double *const x[4]) {
    msim::Vec12 g;
    double      n[4], sum = 0;
    msim::TetVolumeGradient(x, g);
    for (int q = 0; q < 4; q++) sum += n[q] = g.segment<3>(3 * q).norm();
    for (int q = 0; q < 4; q++) floc[3 * T.slot[4 * c + q] + 1] += T.kv * T.iV0[c] * n[q] * sum;
  }));
  PetscFunctionReturn(PETSC_SUCCESS);
}
