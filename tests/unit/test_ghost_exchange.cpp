/* The ghost exchange (msim/ghost_exchange.h) on a made-up distribution: ranks own blocks of
   different sizes and read a scattered set of other ranks' rows. Every ghost row must equal its
   owner's row, for rows of 3 and of 1 value, on repeated use, and with two exchanges in flight at
   once (positions and velocities travel together in the damped force). ctest runs it at 1, 2, 3. */
#include "harness.h"
#include <msim/ghost_exchange.h>
#include <vector>

/* the value of global row g, component c, in round k */
static PetscReal Value(PetscInt g, PetscInt c, PetscInt k)
{
  return 1000.0 * g + c + 0.25 + 7.0 * k;
}

static PetscErrorCode Exchange(PetscInt bs)
{
  PetscMPIInt           rank, size;
  std::vector<PetscInt> ranges, ghosts;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  ranges.assign(size + 1, 0);
  for (PetscMPIInt r = 0; r < size; r++) ranges[r + 1] = ranges[r] + 5 + 3 * r;
  const PetscInt nown = ranges[rank + 1] - ranges[rank], N = ranges[size];
  /* every third row of the others, chosen differently on each rank, ascending */
  for (PetscInt g = 0; g < N; g++)
    if ((g < ranges[rank] || g >= ranges[rank + 1]) && (g * 7 + rank) % 3 == 0) ghosts.push_back(g);
  const PetscInt nghost = (PetscInt)ghosts.size();

  MSimGhostExchange a = {}, b = {};
  PetscCall(MSimGhostExchangeCreate(PETSC_COMM_WORLD, bs, nown, nghost, ghosts.data(), ranges.data(), &a));
  PetscCall(MSimGhostExchangeCreate(PETSC_COMM_WORLD, bs, nown, nghost, ghosts.data(), ranges.data(), &b));
  for (PetscInt k = 0; k < 3; k++) {
    std::vector<PetscReal> own(bs * nown), own2(bs * nown), ga(bs * nghost, -1.0), gb(bs * nghost, -1.0);
    for (PetscInt i = 0; i < nown; i++)
      for (PetscInt c = 0; c < bs; c++) own[bs * i + c] = Value(ranges[rank] + i, c, k), own2[bs * i + c] = -Value(ranges[rank] + i, c, k);
    PetscCall(MSimGhostExchangeBegin(&a, own.data(), ga.data()));
    PetscCall(MSimGhostExchangeBegin(&b, own2.data(), gb.data()));
    /* the sender's rows may change once Begin has returned: the rows travel from its copy */
    std::fill(own.begin(), own.end(), 0.0);
    PetscCall(MSimGhostExchangeEnd(&a));
    PetscCall(MSimGhostExchangeEnd(&b));
    PetscInt wrong = 0;
    for (PetscInt g = 0; g < nghost; g++)
      for (PetscInt c = 0; c < bs; c++) wrong += (ga[bs * g + c] != Value(ghosts[g], c, k)) + (gb[bs * g + c] != -Value(ghosts[g], c, k));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &wrong, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
    CHECK(wrong == 0, "rows of %" PetscInt_FMT ", round %" PetscInt_FMT ": %" PetscInt_FMT " ghost values differ from their owners'", bs, k, wrong);
  }
  PetscInt total = nghost;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
  CHECK(size == 1 ? total == 0 : total > 0, "%" PetscInt_FMT " ghosts on %d ranks", total, size);
  PetscCall(MSimGhostExchangeDestroy(&a));
  PetscCall(MSimGhostExchangeDestroy(&b));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Body(void)
{
  PetscFunctionBeginUser;
  PetscCall(Exchange(3));
  PetscCall(Exchange(1));
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(Body)
