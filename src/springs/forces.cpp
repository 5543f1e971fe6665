/* Force and energy assembly over owned springs; the per-spring physics is in msim/kernels.hpp and,
   for the hot loops, msim/spring_sweep.h. Without spring damping the force is built in place in F:
   F starts as the external force, the springs with both ends owned add into F's array while the
   ghost positions (and, with spring damping, velocities) travel, the others (ghost or fixed ends)
   and the halo follow, each adding to its owned end only. */
#include <msim/system.h>
#include <msim/kernels.hpp>
#include <msim/spring_sweep.h>
#include <msim/contact.h>
#include <msim/volume.h>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <msim/private/contactimpl.h>

using msim::Vec3;
typedef Eigen::Map<const Vec3> CMap3;
typedef Eigen::Map<Vec3>       Map3;

/* F = m g + drag (wind - v) on owned rows [v0, nown) */
static PetscErrorCode MSimSystemExternalForce(MSimSystem sys, Vec V, Vec F, PetscInt v0)
{
  const PetscScalar *m, *vg = NULL;
  PetscScalar       *Fa;
  const PetscBool    drag = (PetscBool)(sys->drag > 0);

  PetscFunctionBeginUser;
  PetscCall(VecGetArrayWrite(F, &Fa));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  if (drag) PetscCall(VecGetArrayRead(V, &vg));
  for (PetscInt v = v0; v < sys->nown; v++)
    for (int c = 0; c < 3; c++) {
      const PetscInt i = 3 * v + c;
      Fa[i]            = m[i] * sys->gravity[c] + (drag ? sys->drag * (sys->wind[c] - vg[i]) : 0.0);
    }
  if (drag) PetscCall(VecRestoreArrayRead(V, &vg));
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayWrite(F, &Fa));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* F += alpha/beta spring sweep (spring_sweep.h) over every owned spring, in place in F's array;
   with energy, also this rank's spring energy (the callers sum it over ranks, with what else they
   reduce). With weight, the sliced vertices' rows of F start from m g instead of F's values (the
   sweep writes them whole). With V (the force only: alpha = -1, beta = 1), spring damping too,
   the ghost velocities travelling with the positions. */
static PetscErrorCode SpringSweep(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec F, PetscBool weight, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  const MSimSprings &sp = sys->springs;
  const PetscScalar *x, *xl, *m = NULL, *v = NULL, *vl = NULL;
  PetscScalar       *f = NULL;
  PetscReal          e = 0;
  MSimSweepBase      base;
  MSimSweepDamping   damp;

  PetscFunctionBeginUser;
  PetscCheck(!V || (F && alpha == -1 && beta == 1 && !energy), sys->comm, PETSC_ERR_PLIB, "the damped sweep computes the force only");
  PetscCall(MSimSystemGhostsBegin(sys, X, sys->xloc));
  if (V) PetscCall(MSimSystemVelocityGhostsBegin(sys, V, sys->vloc));
  PetscCall(VecGetArrayRead(X, &x));
  if (V) PetscCall(VecGetArrayRead(V, &v));
  if (F) PetscCall(VecGetArray(F, &f));
  if (weight) {
    PetscCall(VecGetArrayRead(sys->mass, &m));
    base.m = m;
    for (int c = 0; c < 3; c++) base.a[c] = sys->gravity[c];
  }
  damp.v  = v;
  damp.kd = sys->damping;
  MSimSpringSweepSlices(&sp.slices, &sys->sweep, x, f, weight ? &base : NULL, V ? &damp : NULL, alpha, beta, energy ? &e : NULL);
  if (weight) PetscCall(VecRestoreArrayRead(sys->mass, &m));
  if (V) MSimSpringForceSlotsDamped(0, sp.ninner, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), sys->nown, x, NULL, v, NULL, sys->damping, f);
  else MSimSpringSweep(sp.ninner, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x, f, alpha, beta, energy ? &e : NULL);
  PetscCall(MSimSystemGhostsEnd(sys, t, X, sys->xloc));
  if (V) PetscCall(MSimSystemVelocityGhostsEnd(sys, V, sys->vloc));
  /* springs with a ghost or fixed end, then the halo (their energy is their owners'): each adds
     to its owned end only, so no force goes back to an owner */
  PetscCall(VecGetArrayRead(sys->xloc, &xl));
  if (V) {
    PetscCall(VecGetArrayRead(sys->vloc, &vl));
    MSimSpringForceSlotsDamped(sp.ninner, sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), sys->nown, x, xl, v, vl, sys->damping, f);
    MSimSpringForceSlotsDamped(0, (PetscInt)sp.hi.size(), sp.hi.data(), sp.hj.data(), sp.hk.data(), sp.hL.data(), sys->nown, x, xl, v, vl, sys->damping, f);
    PetscCall(VecRestoreArrayRead(sys->vloc, &vl));
  } else {
    MSimSpringSweepSlots(sp.ninner, sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), sys->nown, x, xl, f, NULL, alpha, beta, energy ? &e : NULL);
    if (F) MSimSpringSweepSlots(0, (PetscInt)sp.hi.size(), sp.hi.data(), sp.hj.data(), sp.hk.data(), sp.hL.data(), sys->nown, x, xl, f, NULL, alpha, beta, NULL);
  }
  PetscCall(VecRestoreArrayRead(sys->xloc, &xl));
  PetscCall(VecRestoreArrayRead(X, &x));
  if (V) PetscCall(VecRestoreArrayRead(V, &v));
  if (F) PetscCall(VecRestoreArray(F, &f));
  if (energy) *energy = e;
  PetscCall(PetscLogFlops(F ? (V ? 45.0 : 30.0) * (sp.total + (PetscReal)sp.hi.size()) : 12.0 * sp.total));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemSpringSweep(MSimSystem sys, PetscReal t, Vec X, Vec F, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  PetscReal e;

  PetscFunctionBeginUser;
  PetscCall(SpringSweep(sys, t, X, NULL, F, PETSC_FALSE, alpha, beta, energy ? &e : NULL));
  if (energy) PetscCall(MPIU_Allreduce(&e, energy, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemComputeForce(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec F)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Force, X, F, 0, 0));
  PetscCheck(V || (sys->damping == 0 && sys->drag == 0), sys->comm, PETSC_ERR_ARG_NULL, "velocity needed for damping and drag");
  /* without drag the weight of the sliced vertices comes with the sweep, which writes their rows
     whole: one pass over F instead of two */
  const PetscBool weight = (PetscBool)(sys->drag == 0);
  PetscCall(MSimSystemExternalForce(sys, V, F, weight ? 4 * sys->springs.slices.nslice : 0));
  PetscCall(SpringSweep(sys, t, X, sys->damping > 0 ? V : NULL, F, weight, -1.0, 1.0, NULL));
  PetscCall(MSimContactAddPenaltyForce(sys, t, X, F)); /* obstacles' penalty (msim/contact.h), if any */
  PetscCall(MSimSystemVolumeGradient(sys, t, X, -1.0, F, NULL, PETSC_TRUE)); /* tets' volume term, if any */
  PetscCall(PetscLogEventEnd(MSIM_Force, X, F, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemSpringEnergy(MSimSystem sys, PetscReal t, Vec X, PetscReal *E)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Energy, X, 0, 0, 0));
  PetscCall(MSimSystemSpringSweep(sys, t, X, NULL, 0, 0, E));
  PetscCall(PetscLogEventEnd(MSIM_Energy, X, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Called every step while monitoring (the divergence test's energies are the monitor's): one
   reduction for the springs', gravity's and the kinetic energy; the vertex sums run vertex by
   vertex, component by component (an index mod 3 per entry cost more than the sums), in the
   order they always had, so the monitored values keep their bits. */
PetscErrorCode MSimSystemComputeEnergy(MSimSystem sys, PetscReal t, Vec X, Vec V, PetscReal *kinetic, PetscReal *potential)
{
  const PetscScalar *x, *m, *v = NULL;
  PetscReal          local[4] = {0, 0, 0, 0}; /* springs; tets and gravity; kinetic; a shell's side lost */
  const PetscReal    g[3]     = {sys->gravity[0], sys->gravity[1], sys->gravity[2]};
  PetscBool          lost;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Energy, X, V, 0, 0));
  PetscCall(SpringSweep(sys, t, X, NULL, NULL, PETSC_FALSE, 0, 0, &local[0]));
  PetscCall(MSimSystemVolumeGradient(sys, t, X, 0.0, NULL, &local[1], PETSC_TRUE)); /* summed below */
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  if (V) PetscCall(VecGetArrayRead(V, &v));
  /* a loop per sum: fused, GCC paired the two sums in one vector add and left out the fused
     multiply-adds it makes of each alone, which changed their last bits */
  for (PetscInt i = 0; i < 3 * sys->nown; i += 3)
    for (int c = 0; c < 3; c++) local[1] -= m[i + c] * g[c] * x[i + c];
  if (v)
    for (PetscInt i = 0; i < 3 * sys->nown; i += 3)
      for (int c = 0; c < 3; c++) local[2] += 0.5 * m[i + c] * v[i + c] * v[i + c];
  if (V) PetscCall(VecRestoreArrayRead(V, &v));
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(X, &x));
  /* the time loop's check of each checked step: its reduction also says whether a rank lost a
     shell's side, which the penalty force notes without communicating (msim/contact.h) */
  PetscCall(MSimContactShellSideLost(sys, &lost));
  local[3] = lost ? 1 : 0;
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, local, 4, MPIU_REAL, MPIU_SUM, sys->comm));
  if (local[3] > 0) PetscCall(MSimContactCheckShellSides(sys));
  *potential = local[0] + local[1];
  *kinetic   = local[2];
  PetscCall(PetscLogFlops((V ? 7.0 : 3.0) * 3 * sys->nown));
  PetscCall(PetscLogEventEnd(MSIM_Energy, X, V, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGershgorin(MSimSystem sys, PetscReal *omega2)
{
  const MSimSprings &sp = sys->springs;
  const PetscScalar *m;
  PetscScalar       *f;
  PetscReal          best = 0, kc = 0;
  Vec                ksum;
  MSimContact        ct;

  PetscFunctionBeginUser;
  /* an obstacle's penalty adds up to kc to a vertex's diagonal (msim/contact.h), each obstacle
     it is pressed into: every vertex as if pressed into every obstacle, as the SLEPc guard takes
     it. One kc whatever the obstacles left a cloth lying on two coincident surfaces (a plane and
     a box's top) with 2 kc at a step the guard let pass: it bounced off them, 24 J of kinetic
     energy from a 2 cm drop, with no warning */
  PetscCall(MSimContactGet(sys, &ct));
  if (ct) kc = ct->kc * (PetscReal)ct->obs.size();
  /* row sums of |K| at rest: each spring contributes k to both ends' diagonal and off-diagonal */
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArray(sys->floc, &f));
  MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal) {
    f[3 * i] += k;
    f[3 * j] += k;
  });
  PetscCall(MSimSystemVolumeRowSums(sys, f)); /* the tets' volume term, in each slot's second entry */
  PetscCall(VecRestoreArray(sys->floc, &f));
  PetscCall(VecDuplicate(sys->mass, &ksum));
  PetscCall(VecZeroEntries(ksum));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, sys->floc, ksum));
  PetscCall(VecGetArray(ksum, &f));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < sys->nown; i++) best = PetscMax(best, (2.0 * f[3 * i] + f[3 * i + 1] + kc) / m[3 * i]);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArray(ksum, &f));
  PetscCall(VecDestroy(&ksum));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &best, 1, MPIU_REAL, MPIU_MAX, sys->comm));
  *omega2 = best;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemAcceleration(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec A)
{
  Vec massinv;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGetInverseMass(sys, &massinv));
  PetscCall(MSimSystemComputeForce(sys, t, X, V, A));
  PetscCall(VecPointwiseMult(A, A, massinv));
  PetscFunctionReturn(PETSC_SUCCESS);
}
