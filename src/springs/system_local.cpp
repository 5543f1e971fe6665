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

/* One rank has no ghosts: there the exchange is skipped, which cost its calls alone (1.6 us of a
   34-us force at N = 64). Begin packs X's rows and posts the receives into xloc's ghost rows (a
   sequential Vec's array stays where it is); End waits for them. */
static PetscErrorCode GhostRowsBegin(MSimSystem sys, MSimGhostExchange *x, Vec X, Vec xloc)
{
  const PetscScalar *own;
  PetscScalar       *loc;

  PetscFunctionBeginUser;
  if (sys->size == 1) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecGetArrayRead(X, &own));
  PetscCall(VecGetArray(xloc, &loc));
  PetscCall(MSimGhostExchangeBegin(x, own, loc + 3 * sys->nown));
  PetscCall(VecRestoreArray(xloc, &loc));
  PetscCall(VecRestoreArrayRead(X, &own));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* No access of its own to mark xloc written: both callers write its fixed slots right after */
static PetscErrorCode GhostRowsEnd(MSimSystem sys, MSimGhostExchange *x)
{
  PetscFunctionBeginUser;
  if (sys->size > 1) PetscCall(MSimGhostExchangeEnd(x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGhostsBegin(MSimSystem sys, Vec X, Vec xloc)
{
  PetscFunctionBeginUser;
  PetscCall(GhostRowsBegin(sys, &sys->xghosts, X, xloc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGhostsEnd(MSimSystem sys, PetscReal t, Vec X, Vec xloc)
{
  PetscScalar *x;

  PetscFunctionBeginUser;
  PetscCall(GhostRowsEnd(sys, &sys->xghosts));
  PetscCall(VecGetArray(xloc, &x));
  PetscCall(MSimSystemBoundary(sys, t, x + 3 * (sys->nown + sys->nghost)));
  PetscCall(VecRestoreArray(xloc, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVelocityGhostsBegin(MSimSystem sys, Vec V, Vec vloc)
{
  PetscFunctionBeginUser;
  PetscCall(GhostRowsBegin(sys, &sys->vghosts, V, vloc));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemVelocityGhostsEnd(MSimSystem sys, Vec V, Vec vloc)
{
  PetscFunctionBeginUser;
  PetscCall(GhostRowsEnd(sys, &sys->vghosts));
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
