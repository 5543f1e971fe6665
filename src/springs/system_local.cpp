/* Moving data between the global free-vertex Vecs and each rank's local slots. */
#include <msim/system.h>

PetscErrorCode MSimSystemBoundary(MSimSystem sys, PetscReal t, PetscReal *b)
{
  PetscFunctionBeginUser;
  for (PetscInt f = 0; f < sys->nfix; f++)
    for (int c = 0; c < 3; c++) b[3 * f + c] = sys->b0[3 * f + c] + t * sys->fix_velocity[c];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGlobalToLocal(MSimSystem sys, PetscReal t, Vec X, Vec xloc)
{
  PetscScalar *x;

  PetscFunctionBeginUser;
  PetscCall(VecScatterBegin(sys->g2l, X, xloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sys->g2l, X, xloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArray(xloc, &x));
  PetscCall(MSimSystemBoundary(sys, t, x + 3 * (sys->nown + sys->nghost)));
  PetscCall(VecRestoreArray(xloc, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the handles' velocity into vloc's fixed slots */
static PetscErrorCode MSimSystemFixedVelocities(MSimSystem sys, Vec vloc)
{
  PetscScalar *v;

  PetscFunctionBeginUser;
  PetscCall(VecGetArray(vloc, &v));
  for (PetscInt f = sys->nown + sys->nghost; f < sys->nloc; f++)
    for (int c = 0; c < 3; c++) v[3 * f + c] = sys->fix_velocity[c];
  PetscCall(VecRestoreArray(vloc, &v));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVelocityToLocal(MSimSystem sys, Vec V, Vec vloc)
{
  PetscFunctionBeginUser;
  PetscCall(VecScatterBegin(sys->g2l, V, vloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sys->g2l, V, vloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(MSimSystemFixedVelocities(sys, vloc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemLocalToGlobalAdd(MSimSystem sys, Vec floc, Vec F)
{
  PetscFunctionBeginUser;
  PetscCall(VecScatterBegin(sys->g2l, floc, F, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(sys->g2l, floc, F, ADD_VALUES, SCATTER_REVERSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* One rank has no ghosts: there the ghost scatters are skipped, which cost their calls alone (1.6 us
   of a 34-us force at N = 64) */
PetscErrorCode MSimSystemGhostsBegin(MSimSystem sys, Vec X, Vec xloc)
{
  PetscFunctionBeginUser;
  if (sys->size > 1) PetscCall(VecScatterBegin(sys->ghosts, X, xloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGhostsEnd(MSimSystem sys, PetscReal t, Vec X, Vec xloc)
{
  PetscScalar *x;

  PetscFunctionBeginUser;
  if (sys->size > 1) PetscCall(VecScatterEnd(sys->ghosts, X, xloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArray(xloc, &x));
  PetscCall(MSimSystemBoundary(sys, t, x + 3 * (sys->nown + sys->nghost)));
  PetscCall(VecRestoreArray(xloc, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVelocityGhostsBegin(MSimSystem sys, Vec V, Vec vloc)
{
  PetscFunctionBeginUser;
  if (sys->size > 1) PetscCall(VecScatterBegin(sys->vghosts, V, vloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVelocityGhostsEnd(MSimSystem sys, Vec V, Vec vloc)
{
  PetscFunctionBeginUser;
  if (sys->size > 1) PetscCall(VecScatterEnd(sys->vghosts, V, vloc, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(MSimSystemFixedVelocities(sys, vloc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGhostsAdd(MSimSystem sys, Vec floc, Vec F)
{
  PetscFunctionBeginUser;
  if (sys->size == 1) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecScatterBegin(sys->ghosts, floc, F, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(sys->ghosts, floc, F, ADD_VALUES, SCATTER_REVERSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MSimSystemGather(MSimSystem sys, PetscReal t, PetscBool positions, Vec X, std::vector<PetscReal> &all)
{
  PetscFunctionBeginUser;
  PetscCall(VecScatterBegin(sys->gather, X, sys->gathered, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sys->gather, X, sys->gathered, INSERT_VALUES, SCATTER_FORWARD));
  if (sys->rank == 0) {
    const PetscScalar     *g;
    std::vector<PetscReal> b(3 * sys->nfix);
    if (positions) PetscCall(MSimSystemBoundary(sys, t, b.data()));
    PetscCall(VecGetArrayRead(sys->gathered, &g));
    all.resize(3 * sys->nv);
    PetscInt nf = 0, nx = 0;
    for (PetscInt v = 0; v < sys->nv; v++) {
      const PetscReal *src = sys->fixed_flag[v] ? &b[3 * nx++] : &g[3 * nf++];
      for (int c = 0; c < 3; c++) all[3 * v + c] = src[c];
    }
    PetscCall(VecRestoreArrayRead(sys->gathered, &g));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGatherPositions(MSimSystem sys, PetscReal t, Vec X, std::vector<PetscReal> &all)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemGather(sys, t, PETSC_TRUE, X, all));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGatherVector(MSimSystem sys, Vec X, std::vector<PetscReal> &all)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemGather(sys, 0, PETSC_FALSE, X, all));
  PetscFunctionReturn(PETSC_SUCCESS);
}
