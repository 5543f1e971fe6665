/* Force and energy assembly over owned springs; the per-spring physics is in msim/kernels.hpp. */
#include <msim/system.h>
#include <msim/kernels.hpp>

using msim::Vec3;
typedef Eigen::Map<const Vec3> CMap3;
typedef Eigen::Map<Vec3>       Map3;

PetscErrorCode MSimSystemComputeForce(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec F)
{
  const PetscScalar *x, *v = NULL, *m, *vg = NULL;
  PetscScalar       *f, *Fa;
  const PetscBool    damp = (PetscBool)(sys->damping > 0), drag = (PetscBool)(sys->drag > 0);

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Force, X, F, 0, 0));
  PetscCheck(V || (!damp && !drag), sys->comm, PETSC_ERR_ARG_NULL, "velocity needed for damping and drag");
  PetscCall(MSimSystemGlobalToLocal(sys, t, X, sys->xloc));
  if (damp) PetscCall(MSimSystemVelocityToLocal(sys, V, sys->vloc));
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArrayRead(sys->xloc, &x));
  PetscCall(VecGetArray(sys->floc, &f));
  if (damp) PetscCall(VecGetArrayRead(sys->vloc, &v));
  for (const MSimSpring &s : sys->springs) {
    Vec3 fi = msim::SpringForce(CMap3(x + 3 * s.i), CMap3(x + 3 * s.j), s.k, s.L);
    if (damp) fi += msim::SpringDampingForce(CMap3(x + 3 * s.i), CMap3(x + 3 * s.j), CMap3(v + 3 * s.i), CMap3(v + 3 * s.j), sys->damping);
    Map3(f + 3 * s.i) += fi;
    Map3(f + 3 * s.j) -= fi;
  }
  if (damp) PetscCall(VecRestoreArrayRead(sys->vloc, &v));
  PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  PetscCall(VecRestoreArray(sys->floc, &f));
  PetscCall(VecZeroEntries(F));
  PetscCall(MSimSystemLocalToGlobalAdd(sys, sys->floc, F));
  /* external forces on owned vertices: gravity, drag towards the wind */
  PetscCall(VecGetArray(F, &Fa));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  if (drag) PetscCall(VecGetArrayRead(V, &vg));
  for (PetscInt i = 0; i < 3 * sys->nown; i++) {
    const int c = i % 3;
    Fa[i] += m[i] * sys->gravity[c];
    if (drag) Fa[i] += sys->drag * (sys->wind[c] - vg[i]);
  }
  if (drag) PetscCall(VecRestoreArrayRead(V, &vg));
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArray(F, &Fa));
  PetscCall(PetscLogFlops(30.0 * sys->springs.size()));
  PetscCall(PetscLogEventEnd(MSIM_Force, X, F, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemSpringEnergy(MSimSystem sys, PetscReal t, Vec X, PetscReal *E)
{
  const PetscScalar *x;
  PetscReal          e = 0;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Energy, X, 0, 0, 0));
  PetscCall(MSimSystemGlobalToLocal(sys, t, X, sys->xloc));
  PetscCall(VecGetArrayRead(sys->xloc, &x));
  for (const MSimSpring &s : sys->springs) e += msim::SpringEnergy(CMap3(x + 3 * s.i), CMap3(x + 3 * s.j), s.k, s.L);
  PetscCall(VecRestoreArrayRead(sys->xloc, &x));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &e, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  *E = e;
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
  const PetscScalar *m;
  PetscScalar       *f;
  PetscReal          best = 0;
  Vec                ksum;

  PetscFunctionBeginUser;
  /* row sums of |K| at rest: each spring contributes k to both ends' diagonal and off-diagonal */
  PetscCall(VecZeroEntries(sys->floc));
  PetscCall(VecGetArray(sys->floc, &f));
  for (const MSimSpring &s : sys->springs) {
    f[3 * s.i] += s.k;
    f[3 * s.j] += s.k;
  }
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
