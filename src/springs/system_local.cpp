/* Moving data between the global free-vertex Vecs and each rank's local slots. */
#include <msim/system.h>
#include <msim/private/systemimpl.h>

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

/* What the fixed vertices hold in the natural Vec: their positions b(t), zero (a displacement-like
   vector) or the handles' velocity */
enum NaturalFixed { NATURAL_POSITION, NATURAL_ZERO, NATURAL_VELOCITY };

static PetscErrorCode MSimSystemNatural(MSimSystem sys, PetscReal t, NaturalFixed what, Vec X)
{
  PetscScalar *n;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemNaturalSetUp(sys));
  PetscCall(VecScatterBegin(sys->to_natural, X, sys->natural, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sys->to_natural, X, sys->natural, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArray(sys->natural, &n));
  for (size_t f = 0; f < sys->nat_fixed.size(); f++)
    for (int c = 0; c < 3; c++) n[3 * sys->nat_fixed[f] + c] = what == NATURAL_POSITION ? sys->nat_b0[3 * f + c] + t * sys->fix_velocity[c] : what == NATURAL_VELOCITY ? sys->fix_velocity[c] : 0.0;
  PetscCall(VecRestoreArray(sys->natural, &n));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemNaturalPositions(MSimSystem sys, PetscReal t, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemNatural(sys, t, NATURAL_POSITION, X));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemNaturalVector(MSimSystem sys, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemNatural(sys, 0, NATURAL_ZERO, X));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemNaturalVelocities(MSimSystem sys, Vec V)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemNatural(sys, 0, NATURAL_VELOCITY, V));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the natural Vec whole on rank 0 */
static PetscErrorCode MSimSystemNaturalToZero(MSimSystem sys, std::vector<PetscReal> &all)
{
  VecScatter         scatter;
  Vec                whole;
  const PetscScalar *w;

  PetscFunctionBeginUser;
  PetscCall(VecScatterCreateToZero(sys->natural, &scatter, &whole));
  PetscCall(VecScatterBegin(scatter, sys->natural, whole, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(scatter, sys->natural, whole, INSERT_VALUES, SCATTER_FORWARD));
  all.clear();
  if (sys->rank == 0) {
    PetscCall(VecGetArrayRead(whole, &w));
    all.assign(w, w + 3 * sys->nv);
    PetscCall(VecRestoreArrayRead(whole, &w));
  }
  PetscCall(VecScatterDestroy(&scatter));
  PetscCall(VecDestroy(&whole));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGatherPositions(MSimSystem sys, PetscReal t, Vec X, std::vector<PetscReal> &all)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemNaturalPositions(sys, t, X));
  PetscCall(MSimSystemNaturalToZero(sys, all));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGatherVelocities(MSimSystem sys, Vec V, std::vector<PetscReal> &all)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemNaturalVelocities(sys, V));
  PetscCall(MSimSystemNaturalToZero(sys, all));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGatherVector(MSimSystem sys, Vec X, std::vector<PetscReal> &all)
{
  PetscFunctionBeginUser;
  PetscCall(MSimSystemNaturalVector(sys, X));
  PetscCall(MSimSystemNaturalToZero(sys, all));
  PetscFunctionReturn(PETSC_SUCCESS);
}

template <typename T>
static PetscErrorCode GatherToZero(MSimSystem sys, const std::vector<T> &mine, std::vector<T> &all)
{
  int                      n = (int)mine.size();
  std::vector<int>         counts(sys->size), displ(sys->size + 1, 0);
  MPI_Datatype             type;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Gather(&n, 1, MPI_INT, counts.data(), 1, MPI_INT, 0, sys->comm));
  for (PetscMPIInt r = 0; r < sys->size; r++) displ[r + 1] = displ[r] + counts[r];
  all.resize(sys->rank == 0 ? displ[sys->size] : 0);
  PetscCallMPI(MPI_Type_contiguous((int)sizeof(T), MPI_BYTE, &type));
  PetscCallMPI(MPI_Type_commit(&type));
  PetscCallMPI(MPI_Gatherv(mine.data(), n, type, all.data(), counts.data(), displ.data(), type, 0, sys->comm));
  PetscCallMPI(MPI_Type_free(&type));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGatherTopology(MSimSystem sys, std::vector<char> &fixed, std::vector<PetscInt> &cells)
{
  PetscFunctionBeginUser;
  /* blocks ascend with the rank: gathered in rank order they are in input order */
  PetscCall(GatherToZero(sys, sys->nat_fixed_flag, fixed));
  PetscCall(GatherToZero(sys, sys->out_cells, cells));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemBlockFileIds(MSimSystem sys, std::vector<PetscInt> &ids)
{
  const PetscInt count = sys->dir.Count(sys->rank), start = sys->dir.Start(sys->rank);

  PetscFunctionBeginUser;
  if (!sys->nat_file_id.empty()) {
    PetscCheck((PetscInt)sys->nat_file_id.size() == count, PETSC_COMM_SELF, PETSC_ERR_PLIB, "file ids for %zu of the block's %" PetscInt_FMT " vertices", sys->nat_file_id.size(), count);
    ids = sys->nat_file_id;
  } else {
    ids.resize(count);
    for (PetscInt v = 0; v < count; v++) ids[v] = start + v;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGatherFrameTopology(MSimSystem sys, std::vector<PetscInt> &file_id, std::vector<PetscReal> &cell_V0, std::vector<PetscInt> &springs, std::vector<PetscReal> &spring_L)
{
  std::vector<PetscInt> mine;

  PetscFunctionBeginUser;
  PetscCall(MSimSystemBlockFileIds(sys, mine));
  PetscCall(GatherToZero(sys, mine, file_id));
  PetscCall(GatherToZero(sys, sys->out_cell_V0, cell_V0));
  PetscCall(GatherToZero(sys, sys->out_springs, springs));
  PetscCall(GatherToZero(sys, sys->out_spring_L, spring_L));
  PetscFunctionReturn(PETSC_SUCCESS);
}
