/* The volume term over the system's tets (msim/volume.h; the per-tet physics in
   msim/volume_kernels.hpp). Each tet is computed by one rank from its local slots: owned rows from
   X's array, ghost and fixed slots from xloc (the springs' exchange); forces on ghost slots are
   added to their owners by one reverse scatter (floc's ghost slots; PETSc's star forest adds what
   each rank sent in rank order, after every message arrived: the same sums in every run). The
   Hessian's blocks in other ranks' rows are their halo tets' instead. */
#include <msim/volume.h>
#include <msim/volume_kernels.hpp>
#include <msim/log.h>
#include <msim/private/systemimpl.h>

static msim::TetMaterial Material(MSimSystem sys)
{
  return {sys->tets.kv, sys->tets.kappa, sys->tets.jhat};
}

/* Whether max_step and the passes have a reference: X's local slots at an earlier gradient pass
   (xref), each tet's g and L there (gl) and each slot's least safe radius^2 (r2slot) */
static bool HasReference(MSimSystem sys)
{
  const MSimTets &T = sys->tets;
  return T.gl.size() == 2 * T.V0.size() && T.xref.size() == (size_t)(3 * sys->nloc) && T.r2slot.size() == (size_t)sys->nloc;
}

/* Whether a pass may skip tets: the barrier alone (kv = 0), where psi, psi' and psi'' are zero for
   J >= jhat, and a reference. */
static bool CanSkip(MSimSystem sys)
{
  const MSimTets &T = sys->tets;
  return T.kv == 0 && T.kappa > 0 && !T.noskip && HasReference(sys);
}

/* The tets that the reference does not prove safe, in increasing order (T.active), given m2, each
   local slot's squared motion bound from the reference. A tet is safe (J > jhat all along) when
   its 4 slots' largest m2 is within its safe radius (msim::TetWithinSafeRadius); the tets at or
   below jhat at the reference (T.inside) never are. A slot with m2 below r2slot, the least
   radius^2 of its other tets (taken a little short of the test's bound), passes that test for all
   of them, so only the tets of the other slots are met (a bit per tet, read in order: no sort)
   and tested: one pass over the slots and a few tets, instead of a pass over every tet. Returns
   how many of the tets kept were above jhat at the reference (drift: the reference is getting
   old). */
static size_t ActiveTets(MSimSystem sys)
{
  MSimTets       &T  = sys->tets;
  const double   *m2 = T.m2.data(), *gl = T.gl.data(), *r2 = T.r2slot.data();
  const PetscInt *sl = T.slot.data();
  uint64_t       *bit = T.mark.data();
  size_t          drifted = 0;

  for (PetscInt c : T.inside) bit[c >> 6] |= (uint64_t)1 << (c & 63);
  for (PetscInt s = 0; s < sys->nloc; s++) {
    if (m2[s] < r2[s]) continue;
    for (PetscInt k = T.s2t_ptr[s]; k < T.s2t_ptr[s + 1]; k++) bit[T.s2t[k] >> 6] |= (uint64_t)1 << (T.s2t[k] & 63);
  }
  T.active.clear();
  for (size_t w = 0; w < T.mark.size(); w++) {
    for (uint64_t b = bit[w]; b; b &= b - 1) {
      const PetscInt  c  = (PetscInt)(64 * w + __builtin_ctzll(b));
      const PetscInt *q4 = sl + 4 * c;
      if (gl[2 * c] > 0) { /* not inside: the tet's own test */
        if (msim::TetWithinSafeRadius(std::max(std::max(m2[q4[0]], m2[q4[1]]), std::max(m2[q4[2]], m2[q4[3]])), gl[2 * c], gl[2 * c + 1])) continue;
        drifted++;
      }
      T.active.push_back(c);
    }
    bit[w] = 0;
  }
  return drifted;
}

/* f(c, x[4]) for every tet of this rank at X (t: the fixed slots' time). xloc gets X's owned rows
   too (a copy, cheap next to the tets), so that each vertex is read from one array, without a
   branch per vertex in the per-iteration passes. With skip (CanSkip), only the tets the reference
   does not prove safe (ActiveTets with m2 = |x_s - xref_s|^2): J > jhat at the others, where the
   barrier alone is zero, with its gradient and Hessian. Where more than 1 tet in 128 that the
   reference had above jhat is no longer skipped, the next gradient pass takes a new reference. */
template <class F>
static PetscErrorCode ForEachTet(MSimSystem sys, PetscReal t, Vec X, F &&f, bool skip = false)
{
  const PetscScalar *xo;
  PetscScalar       *xl;
  MSimTets          &T  = sys->tets;
  const PetscInt    *sl = T.slot.data();

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGhostsBegin(sys, X, sys->xloc));
  PetscCall(MSimSystemGhostsEnd(sys, t, X, sys->xloc));
  PetscCall(VecGetArrayRead(X, &xo));
  PetscCall(VecGetArray(sys->xloc, &xl));
  PetscCall(PetscArraycpy(xl, xo, 3 * sys->nown));
  auto one = [&](size_t c) {
    const PetscInt *q4   = sl + 4 * c;
    const double   *x[4] = {xl + 3 * q4[0], xl + 3 * q4[1], xl + 3 * q4[2], xl + 3 * q4[3]};
    f(c, x);
  };
  if (skip) {
    const double *xr = T.xref.data();
    T.m2.resize(sys->nloc);
    for (PetscInt s = 0; s < sys->nloc; s++) {
      const double d0 = xl[3 * s] - xr[3 * s], d1 = xl[3 * s + 1] - xr[3 * s + 1], d2 = xl[3 * s + 2] - xr[3 * s + 2];
      T.m2[s]         = d0 * d0 + d1 * d1 + d2 * d2;
    }
    if (128 * ActiveTets(sys) > T.V0.size()) T.refresh = true;
    for (PetscInt c : T.active) one(c);
  } else
    for (size_t c = 0; c < T.V0.size(); c++) one(c);
  PetscCall(VecRestoreArray(sys->xloc, &xl));
  PetscCall(VecRestoreArrayRead(X, &xo));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeSetUp(MSimSystem sys, PetscReal modulus)
{
  MSimTets &T = sys->tets;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS);
  /* a tenth of the springs' modulus: the springs' own bulk modulus is 2E/3 (Poisson ratio 1/4),
     so the term stiffens uniform compression by 15% and the explicit limit little; the barrier,
     not kv, keeps tets from inverting */
  if (T.kv < 0) T.kv = 0.1 * modulus;
  /* the barrier alone (kv = 0) keeps the stiffness kv would have had by default */
  if (T.kappa < 0) T.kappa = T.kv > 0 ? T.kv : 0.1 * modulus;
  if (T.kv == 0 && T.kappa == 0) {
    T.ntet = 0; /* nothing to compute */
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(VecDuplicate(sys->xloc, &T.yloc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeCountInverted(MSimSystem sys, PetscReal t, Vec X, PetscInt *n)
{
  PetscInt        local = 0;
  MSimTets       &T = sys->tets;
  const bool      refresh = T.refresh;

  PetscFunctionBeginUser;
  /* where the passes may skip, so may the count: the tets the reference proves above jhat are
     upright. A count is no pass of the term's: it leaves the reference's renewal to them */
  PetscCall(ForEachTet(sys, t, X, [&](size_t c, const double *const x[4]) {
    if (!(msim::TetSignedVolume(x[0], x[1], x[2], x[3]) > 0)) local++;
  }, CanSkip(sys)));
  T.refresh = refresh;
  PetscCallMPI(MPI_Allreduce(&local, n, 1, MPIU_INT, MPI_SUM, sys->comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The barrier is infinite at an inverted or flat tet: a run cannot start there, at the scene's
   start (a -msim_perturb or -msim_prestretch that inverts tets) or at a checkpoint's state (one
   written without the barrier: a box squashed by 50 g held 48 inverted tets at step 3, and a
   restart with the barrier from there failed its first step's line search), and neither can the
   spectrum, whose K holds the barrier's Hessian there (the implicit term's check_start and
   MSimSpectrumFromOptions both call this) */
PetscErrorCode MSimSystemVolumeCheckStart(MSimSystem sys, PetscReal t, Vec X, const char *restart)
{
  PetscInt bad;

  PetscFunctionBeginUser;
  if (!sys->tets.ntet || sys->tets.kappa == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimSystemVolumeCountInverted(sys, t, X, &bad));
  if (restart) PetscCheck(!bad, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_volume: %" PetscInt_FMT " tets are inverted or flat in %s (written without the inversion barrier?): the barrier needs every tet positive (-msim_volume_kappa 0 turns it off)", bad, restart);
  PetscCheck(!bad, sys->comm, PETSC_ERR_ARG_WRONG, "-msim_volume: %" PetscInt_FMT " tets are inverted or flat at the start (-msim_perturb or -msim_prestretch?): the inversion barrier needs every tet positive (-msim_volume_kappa 0 turns it off)", bad);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The handles' move over a step (-msim_fix_velocity w, from t to tx) with the free vertices at X:
   each tet inverted or flat at (X, b(tx)) is flattened somewhere along that move, at the first
   zero a of its volume along (X + w dt, b(tx)) - a (w dt on the free slots), a in [0, 1]: the
   configuration at a = 0 is (X, b(t)) moved rigidly. The least such a over the ranks and that
   tet's centroid at (X, b(t)) name the worst one. */
PetscErrorCode MSimSystemVolumeHandleStart(MSimSystem sys, PetscReal t, PetscReal tx, Vec X, PetscInt *ninv, PetscReal *a, PetscReal where[3])
{
  const MSimTets        &T = sys->tets;
  const PetscInt         nfree = sys->nown + sys->nghost; /* local slots below it are free */
  const PetscReal        dt = tx - t, *w = sys->fix_velocity;
  PetscInt               local = 0;
  PetscReal              mine[4] = {PETSC_INFINITY, 0, 0, 0};
  std::vector<PetscReal> all(4 * sys->size);

  PetscFunctionBeginUser;
  PetscCall(ForEachTet(sys, tx, X, [&](size_t c, const double *const x[4]) {
    if (msim::TetSignedVolume(x[0], x[1], x[2], x[3]) > 0) return;
    const PetscInt *q4 = T.slot.data() + 4 * c;
    double          xs[4][3], ys[4][3];
    for (int q = 0; q < 4; q++)
      for (int k = 0; k < 3; k++) {
        ys[q][k] = q4[q] < nfree ? w[k] * dt : 0.0;
        xs[q][k] = x[q][k] + ys[q][k];
      }
    const double *xp[4] = {xs[0], xs[1], xs[2], xs[3]}, *yp[4] = {ys[0], ys[1], ys[2], ys[3]};
    const double  z     = msim::TetFirstZero(T.V0[c], xp, yp, 1.0);
    local++;
    if (z < mine[0]) {
      mine[0] = z;
      for (int k = 0; k < 3; k++) mine[1 + k] = 0.25 * (xs[0][k] + xs[1][k] + xs[2][k] + xs[3][k]) - w[k] * dt; /* at (X, b(t)) */
    }
  }));
  PetscCallMPI(MPI_Allreduce(&local, ninv, 1, MPIU_INT, MPI_SUM, sys->comm));
  PetscCallMPI(MPI_Allgather(mine, 4, MPIU_REAL, all.data(), 4, MPIU_REAL, sys->comm));
  *a = PETSC_INFINITY;
  for (PetscMPIInt r = 0; r < sys->size; r++)
    if (all[4 * r] < *a) {
      *a = all[4 * r];
      for (int k = 0; k < 3; k++) where[k] = all[4 * r + 1 + k];
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* max_step's reference: X's local slots, as the pass just filled xloc */
static PetscErrorCode KeepReference(MSimSystem sys)
{
  MSimTets          &T = sys->tets;
  const PetscScalar *xl;

  PetscFunctionBeginUser;
  PetscCall(VecGetArrayRead(sys->xloc, &xl));
  PetscCall(PetscArraycpy(T.xref.data(), xl, 3 * sys->nloc));
  PetscCall(VecRestoreArrayRead(sys->xloc, &xl));
  if (T.s2t_ptr.size() != (size_t)(sys->nloc + 1)) { /* the slots' tets, once */
    T.s2t_ptr.assign(sys->nloc + 1, 0);
    for (PetscInt q : T.slot) T.s2t_ptr[q + 1]++;
    for (PetscInt s = 0; s < sys->nloc; s++) T.s2t_ptr[s + 1] += T.s2t_ptr[s];
    std::vector<PetscInt> next(T.s2t_ptr.begin(), T.s2t_ptr.end() - 1);
    T.s2t.resize(T.slot.size());
    for (size_t c = 0; c < T.V0.size(); c++)
      for (int q = 0; q < 4; q++) T.s2t[next[T.slot[4 * c + q]]++] = (PetscInt)c;
    T.mark.assign((T.V0.size() + 63) / 64, 0);
  }
  /* each slot's least radius^2 over its tets above jhat: r^2 < min(L / 100, g^2 / (2.78 L)^2),
     taken short by 1e-9 so that m2 below it passes msim::TetWithinSafeRadius despite the roundoff
     of the division; the others (g <= 0, or NaN) are always computed (inside); slots of no such
     tet never bound anything */
  T.r2slot.assign(sys->nloc, PETSC_INFINITY);
  T.inside.clear();
  for (size_t c = 0; c < T.V0.size(); c++) {
    const double g = T.gl[2 * c], L = T.gl[2 * c + 1];
    if (!(g > 0 && L > 0)) {
      T.inside.push_back((PetscInt)c);
      continue;
    }
    const double r2 = std::min(0.01 * L, g * g / (7.7284 * L * L)) * (1 - 1e-9);
    for (int q = 0; q < 4; q++) {
      double &r = T.r2slot[T.slot[4 * c + q]];
      r         = std::min(r, r2);
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVolumeGradient(MSimSystem sys, PetscReal t, Vec X, PetscReal w, Vec F, PetscReal *e, PetscBool clamp)
{
  MSimTets               &T = sys->tets;
  const msim::TetMaterial m = Material(sys);
  PetscScalar            *f = NULL, *fl = NULL;
  PetscReal               local = 0;
  /* a gradient pass with the barrier also keeps each tet's safe radius at X, so that max_step
     from (near) X skips the tets no vertex motion of the step can bring to jhat (and, with the
     barrier alone, so do the passes); only when max_step or a pass asked for it (T.refresh): an
     old reference stays valid, only less tight. Such a pass computes every tet. */
  const bool radii = F && T.kappa > 0 && T.refresh;
  const bool skip  = !radii && CanSkip(sys);
  PetscReal *gl    = NULL;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Volume, X, F, 0, 0));
  if (F) { /* every slot's force into floc (fixed slots' unused), then owned rows to F */
    PetscCall(VecGetArray(F, &f));
    PetscCall(VecGetArray(sys->floc, &fl));
    PetscCall(PetscArrayzero(fl, 3 * sys->nloc));
  }
  if (radii) {
    T.gl.resize(2 * T.V0.size());
    T.xref.resize(3 * sys->nloc);
    gl        = T.gl.data();
    T.refresh = false;
  }
  PetscCall(ForEachTet(sys, t, X, [&](size_t c, const double *const x[4]) {
    double       g[12] = {0}, psi = 0, dpsi = 0; /* g: set where F is (the compiler cannot tell) */
    const double V0 = T.V0[c]; /* > 0 */
    /* a reference pass of the barrier alone computes every tet's J, and dJ/dx only below jhat */
    const bool   lazy = gl && m.kv == 0;
    const double J    = (F && !lazy ? msim::TetVolumeGradient(x, g) : msim::TetSignedVolume(x[0], x[1], x[2], x[3])) * T.iV0[c];
    if (gl) {
      gl[2 * c]     = 6 * V0 * (J - m.jhat); /* msim::TetSafeGap, V0 > 0 */
      gl[2 * c + 1] = msim::TetEdgeSquares(x);
    }
    if (lazy) {
      if (J >= m.jhat) return; /* psi = psi' = 0 (clamp or not) */
      if (F) msim::TetVolumeGradient(x, g);
    }
    /* clamp (the explicit force): J held at jhat/100 or more in the barrier, so that an inverted
       tet is pushed back by a finite force instead of none (psi is +inf there) */
    const double Jc = clamp ? PetscMax(J, 0.01 * m.jhat) : J;
    msim::TetPsi(m, Jc, &psi, &dpsi, NULL);
    dpsi += m.kv * (J - Jc); /* the quadratic part at the true J */
    if (e) local += V0 * psi;
    if (!F) return;
    const double coef = w * dpsi; /* V0 psi'(J) dJ/dV */
    for (int q = 0; q < 4; q++) {
      double *fs = fl + 3 * T.slot[4 * c + q];
      for (int k = 0; k < 3; k++) fs[k] += coef * g[3 * q + k];
    }
  }, skip));
  if (F) {
    for (PetscInt i = 0; i < 3 * sys->nown; i++) f[i] += fl[i];
    PetscCall(VecRestoreArray(sys->floc, &fl));
    PetscCall(VecRestoreArray(F, &f));
    if (radii) PetscCall(KeepReference(sys));
    PetscCall(MSimSystemGhostsAdd(sys, sys->floc, F));
  }
  if (e) *e += local;
  PetscCall(PetscLogFlops((skip ? 15.0 : 150.0) * T.V0.size()));
  PetscCall(PetscLogEventEnd(MSIM_Volume, X, F, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Each rank adds to its own rows only: its tets' blocks there, then its halo tets' (another
   rank's tets with an owned vertex, computed again here). PETSc's assembly would sum the blocks
   that several ranks send to one row in the order the messages arrive, so that at 3 ranks and
   more two runs of one scene differed in the last bits (the springs' matrices do the same,
   src/springs/matrix.cpp). With the barrier alone a halo tet at or above jhat adds a zero block:
   skipped (J as TetEnergy takes it), as the pass skips the tets the reference proves there. */
PetscErrorCode MSimSystemVolumeHessian(MSimSystem sys, PetscReal t, Vec X, PetscReal w, PetscBool psd, Mat J)
{
  const MSimTets         &T   = sys->tets; /* a skipped tet's block is zero (kv = 0, J > jhat) */
  const msim::TetMaterial m   = Material(sys);
  const PetscInt          nfl = sys->nown + sys->nghost;
  const PetscScalar      *xl;
  PetscErrorCode          ierr = PETSC_SUCCESS;

  PetscFunctionBeginUser;
  if (!T.ntet) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Volume, X, J, 0, 0));
  auto add = [&](const PetscInt *q4, PetscReal V0, const double *const x[4]) {
    msim::Mat12 H;
    PetscInt    row[12], col[12];
    PetscScalar blk[144];
    if (ierr) return;
    msim::TetEnergy(m, V0, x, NULL, &H, psd);
    /* fixed vertices are no unknowns: their rows and columns are left out (negative indices), as
       are the rows other ranks own */
    for (int q = 0; q < 4; q++)
      for (int k = 0; k < 3; k++) {
        col[3 * q + k] = q4[q] < nfl ? 3 * sys->local_to_global[q4[q]] + k : -1;
        row[3 * q + k] = q4[q] < sys->nown ? col[3 * q + k] : -1;
      }
    for (int a = 0; a < 12; a++)
      for (int b = 0; b < 12; b++) blk[12 * a + b] = w * H(a, b);
    ierr = MatSetValues(J, 12, row, 12, col, blk, ADD_VALUES);
  };
  PetscCall(ForEachTet(sys, t, X, [&](size_t c, const double *const x[4]) { add(&T.slot[4 * c], T.V0[c], x); }, CanSkip(sys)));
  PetscCall(ierr);
  PetscCall(VecGetArrayRead(sys->xloc, &xl)); /* X's local slots, as the pass left them */
  for (size_t c = 0; c < T.hV0.size(); c++) {
    const PetscInt *q4   = &T.hslot[4 * c];
    const double   *x[4] = {xl + 3 * q4[0], xl + 3 * q4[1], xl + 3 * q4[2], xl + 3 * q4[3]};
    msim::Vec12     g;
    if (m.kv == 0 && !T.noskip && msim::TetVolumeGradient(x, g) / T.hV0[c] >= m.jhat) continue; /* TetEnergy's J */
    add(q4, T.hV0[c], x);
  }
  PetscCall(VecRestoreArrayRead(sys->xloc, &xl));
  PetscCall(ierr);
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  PetscCall(PetscLogEventEnd(MSIM_Volume, X, J, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Per tet, the cubic's first root (TetFirstZero) only where the step may matter: with a reference
   from the last gradient pass (xref, gl), m_s = |x_s - xref_s| + amax |y_s| bounds how far each
   local slot gets from the reference along X - a Y, a in [0, amax]; a tet whose 4 slots all stay
   within its safe radius keeps J > jhat on the whole segment (msim::TetWithinSafeRadius): it
   neither inverts nor meets the barrier, so its root is beyond amax and it is skipped (the others
   found by ActiveTets). */
PetscErrorCode MSimSystemVolumeMaxStep(MSimSystem sys, PetscReal t, Vec X, Vec Y, PetscReal *alpha, PetscBool *barrier)
{
  MSimTets          &T = sys->tets;
  const PetscScalar *xo, *yo;
  PetscScalar       *xl, *yl;
  const PetscReal    amax = *alpha / 0.8;
  PetscReal          r[2] = {*alpha, 1}; /* the step, and 1 while no tet may meet the barrier */
  const bool         ref  = HasReference(sys);
  const PetscInt    *sl   = T.slot.data();
  PetscInt           exact = 0;

  PetscFunctionBeginUser;
  if (barrier) *barrier = PETSC_FALSE;
  if (!T.ntet || T.kappa == 0) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Volume, X, Y, 0, 0));
  /* X and Y at every local slot (as ForEachTet); Y is zero at the fixed slots, which do not move
     along it (the exchange wrote boundary positions there) */
  PetscCall(MSimSystemGhostsBegin(sys, Y, T.yloc));
  PetscCall(MSimSystemGhostsEnd(sys, t, Y, T.yloc));
  PetscCall(MSimSystemGhostsBegin(sys, X, sys->xloc));
  PetscCall(MSimSystemGhostsEnd(sys, t, X, sys->xloc));
  PetscCall(VecGetArrayRead(X, &xo));
  PetscCall(VecGetArrayRead(Y, &yo));
  PetscCall(VecGetArray(sys->xloc, &xl));
  PetscCall(VecGetArray(T.yloc, &yl));
  PetscCall(PetscArraycpy(xl, xo, 3 * sys->nown));
  PetscCall(PetscArraycpy(yl, yo, 3 * sys->nown));
  PetscCall(PetscArrayzero(yl + 3 * (sys->nown + sys->nghost), 3 * sys->nfix));
  if (ref) {
    T.m2.resize(sys->nloc);
    for (PetscInt s = 0; s < sys->nloc; s++) {
      const double *x = xl + 3 * s, *xr = T.xref.data() + 3 * s, *y = yl + 3 * s;
      double        dx = 0, dy = 0;
      for (int k = 0; k < 3; k++) {
        dx += (x[k] - xr[k]) * (x[k] - xr[k]);
        dy += y[k] * y[k];
      }
      /* (|a| + |b|)^2 <= 2 (a^2 + b^2): the bound without roots where it leaves the slot within
         its radius (most slots), the exact one elsewhere; either bounds the motion */
      const double m2 = 2 * (dx + amax * amax * dy);
      if (m2 < T.r2slot[s]) T.m2[s] = m2;
      else {
        const double mv = std::sqrt(dx) + amax * std::sqrt(dy);
        T.m2[s]         = mv * mv;
      }
    }
  }
  if (ref) (void)ActiveTets(sys); /* its drift is not max_step's rule: exact below */
  const size_t ncheck = ref ? T.active.size() : T.V0.size();
  for (size_t k = 0; k < ncheck; k++) {
    const size_t    c  = ref ? (size_t)T.active[k] : k;
    const PetscInt *q4 = sl + 4 * c;
    const double *x[4] = {xl + 3 * q4[0], xl + 3 * q4[1], xl + 3 * q4[2], xl + 3 * q4[3]};
    const double *y[4] = {yl + 3 * q4[0], yl + 3 * q4[1], yl + 3 * q4[2], yl + 3 * q4[3]};
    /* the barrier's 0.8 (IPC's CCD filter, as the obstacles): the line search starts short of
       the first flat tet, where the barrier is finite. Once the step is cut the barrier is met
       anyway, so the running step's segment is enough for the lower bound. */
    double       low;
    const double z = msim::TetFirstZero(T.V0[c], x, y, r[0] / 0.8, &low);
    exact++;
    if (0.8 * z < r[0]) r[0] = 0.8 * z;
    if (!(low >= 6 * T.V0[c] * T.jhat)) r[1] = 0;
  }
  PetscCall(VecRestoreArray(T.yloc, &yl));
  PetscCall(VecRestoreArray(sys->xloc, &xl));
  PetscCall(VecRestoreArrayRead(Y, &yo));
  PetscCall(VecRestoreArrayRead(X, &xo));
  if (r[0] < *alpha) r[1] = 0; /* a cut step met the barrier */
  /* the reference has drifted (or is missing) where more than 1 tet in 32 needed its root: the
     next gradient pass takes a new one (this rank's; it costs that pass ~30%) */
  if (!ref || 32 * exact > (PetscInt)T.V0.size()) T.refresh = true;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, r, 2, MPIU_REAL, MPIU_MIN, sys->comm));
  *alpha = r[0];
  if (barrier) *barrier = (PetscBool)(r[1] == 0);
  PetscCall(PetscLogFlops(20.0 * sys->nloc + 100.0 * exact));
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
