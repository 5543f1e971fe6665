/* Force and energy assembly over owned springs; the per-spring physics is in msim/kernels.hpp and,
   for the hot loops, msim/spring_sweep.h. Without spring damping the force is built in place in F:
   F starts as the external force, the springs with both ends owned add into F's array while the
   ghost positions travel, the others (ghost or fixed ends) and the halo follow, each adding to its
   owned end only. With damping every spring goes through the local slots, and the ghost slots'
   sums go to their owners. */
#include <msim/system.h>
#include <msim/kernels.hpp>
#include <msim/spring_sweep.h>

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
   with energy, also the spring energy (summed over ranks). With weight, the sliced vertices' rows
   of F start from m g instead of F's values (the sweep writes them whole). */
static PetscErrorCode SpringSweep(MSimSystem sys, PetscReal t, Vec X, Vec F, PetscBool weight, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  const MSimSprings &sp = sys->springs;
  const PetscScalar *x, *xl, *m = NULL;
  PetscScalar       *f = NULL;
  PetscReal          e = 0;
  MSimSweepBase      base;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGhostsBegin(sys, X, sys->xloc));
  PetscCall(VecGetArrayRead(X, &x));
  if (F) PetscCall(VecGetArray(F, &f));
  if (weight) {
    PetscCall(VecGetArrayRead(sys->mass, &m));
    base.m = m;
    for (int c = 0; c < 3; c++) base.a[c] = sys->gravity[c];
  }
  MSimSpringSweepSlices(&sp.slices, &sys->sweep, x, f, weight ? &base : NULL, alpha, beta, energy ? &e : NULL);
  if (weight) PetscCall(VecRestoreArrayRead(sys->mass, &m));
  MSimSpringSweep(sp.ninner, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), x, f, alpha, beta, energy ? &e : NULL);
  PetscCall(VecRestoreArrayRead(X, &x));
  if (F) PetscCall(VecRestoreArray(F, &f));
  PetscCall(MSimSystemGhostsEnd(sys, t, X, sys->xloc));
  /* springs with a ghost or fixed end, then the halo (their energy is their owners'): each adds
     to its owned end only, so no force goes back to an owner */
  if (F) PetscCall(VecGetArray(F, &f));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(sys->xloc, &xl));
  MSimSpringSweepSlots(sp.ninner, sp.n, sp.i.data(), sp.j.data(), sp.k.data(), sp.L.data(), sys->nown, x, xl, f, NULL, alpha, beta, energy ? &e : NULL);
  if (F) MSimSpringSweepSlots(0, (PetscInt)sp.hi.size(), sp.hi.data(), sp.hj.data(), sp.hk.data(), sp.hL.data(), sys->nown, x, xl, f, NULL, alpha, beta, NULL);
  PetscCall(VecRestoreArrayRead(sys->xloc, &xl));
  PetscCall(VecRestoreArrayRead(X, &x));
  if (F) PetscCall(VecRestoreArray(F, &f));
  if (energy) PetscCall(MPIU_Allreduce(&e, energy, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  PetscCall(PetscLogFlops(F ? 30.0 * (sp.total + (PetscReal)sp.hi.size()) : 12.0 * sp.total));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemSpringSweep(MSimSystem sys, PetscReal t, Vec X, Vec F, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  PetscFunctionBeginUser;
  PetscCall(SpringSweep(sys, t, X, F, PETSC_FALSE, alpha, beta, energy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* With spring damping: every spring through the local slots (positions and velocities). */
static PetscErrorCode MSimSystemDampedSpringForce(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec F)
{
  const MSimSprings &sp = sys->springs;
  const PetscScalar *x, *v;
  PetscScalar       *f;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemGlobalToLocal(sys, t, X, sys->xloc));
  PetscCall(MSimSystemVelocityToLocal(sys, V, sys->vloc));
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArrayRead(sys->xloc, &x));
  PetscCall(VecGetArrayRead(sys->vloc, &v));
  PetscCall(VecGetArray(sys->floc, &f));
  MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal L) {
    Vec3 fi = msim::SpringForce(CMap3(x + 3 * i), CMap3(x + 3 * j), k, L);
    fi += msim::SpringDampingForce(CMap3(x + 3 * i), CMap3(x + 3 * j), CMap3(v + 3 * i), CMap3(v + 3 * j), sys->damping);
    Map3(f + 3 * i) += fi;
    Map3(f + 3 * j) -= fi;
  });
  PetscCall(VecRestoreArray(sys->floc, &f));
  PetscCall(VecRestoreArrayRead(sys->vloc, &v));
  PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, sys->floc, F));
  PetscCall(PetscLogFlops(60.0 * sp.total));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemComputeForce(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec F)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Force, X, F, 0, 0));
  PetscCheck(V || (sys->damping == 0 && sys->drag == 0), sys->comm, PETSC_ERR_ARG_NULL, "velocity needed for damping and drag");
  /* without damping and drag the weight of the sliced vertices comes with the sweep, which writes
     their rows whole: one pass over F instead of two */
  const PetscBool weight = (PetscBool)(sys->damping == 0 && sys->drag == 0);
  PetscCall(MSimSystemExternalForce(sys, V, F, weight ? 4 * sys->springs.slices.nslice : 0));
  if (sys->damping > 0) PetscCall(MSimSystemDampedSpringForce(sys, t, X, V, F));
  else PetscCall(SpringSweep(sys, t, X, F, weight, -1.0, 1.0, NULL));
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

PetscErrorCode MSimSystemComputeEnergy(MSimSystem sys, PetscReal t, Vec X, Vec V, PetscReal *kinetic, PetscReal *potential)
{
  const PetscScalar *x, *m, *v;
  PetscReal          local[2] = {0, 0}, Es;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemSpringEnergy(sys, t, X, &Es));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) local[0] -= m[i] * sys->gravity[i % 3] * x[i];
  if (V) {
    PetscCall(VecGetArrayRead(V, &v));
    for (PetscInt i = 0; i < 3 * sys->nown; i++) local[1] += 0.5 * m[i] * v[i] * v[i];
    PetscCall(VecRestoreArrayRead(V, &v));
  }
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, local, 2, MPIU_REAL, MPIU_SUM, sys->comm));
  *potential = Es + local[0];
  *kinetic   = local[1];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGershgorin(MSimSystem sys, PetscReal *omega2)
{
  const MSimSprings &sp = sys->springs;
  const PetscScalar *m;
  PetscScalar       *f;
  PetscReal          best = 0;
  Vec                ksum;

  PetscFunctionBeginUser;
  /* row sums of |K| at rest: each spring contributes k to both ends' diagonal and off-diagonal */
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArray(sys->floc, &f));
  MSimSpringsForEach(sp, [&](PetscInt i, PetscInt j, PetscReal k, PetscReal) {
    f[3 * i] += k;
    f[3 * j] += k;
  });
  PetscCall(VecRestoreArray(sys->floc, &f));
  PetscCall(VecDuplicate(sys->mass, &ksum));
  PetscCall(VecZeroEntries(ksum));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, sys->floc, ksum));
  PetscCall(VecGetArray(ksum, &f));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  for (PetscInt i = 0; i < sys->nown; i++) best = PetscMax(best, 2.0 * f[3 * i] / m[3 * i]);
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArray(ksum, &f));
  PetscCall(VecDestroy(&ksum));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &best, 1, MPIU_REAL, MPIU_MAX, sys->comm));
  *omega2 = best;
  PetscFunctionReturn(PETSC_SUCCESS);
}
