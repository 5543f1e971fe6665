/* What a partition costs: the edge cut and the ghosts set the exchange's size, the balance the
   time the slowest rank takes. */
#include <msim/system.h>
#include <msim/private/systemimpl.h>
#include <algorithm>

PetscErrorCode MSimSystemViewPartition(MSimSystem sys, const char partition[], PetscInt cut, PetscInt between_free)
{
  PetscInt              mine[4] = {sys->nown, sys->nghost, sys->springs.total, (PetscInt)sys->springs.hi.size()};
  std::vector<PetscInt> all(4 * sys->size);

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Gather(mine, 4, MPIU_INT, all.data(), 4, MPIU_INT, 0, sys->comm));
  PetscCall(PetscPrintf(sys->comm, "partition (%s, %d rank%s): %" PetscInt_FMT " vertices (%" PetscInt_FMT " free, %" PetscInt_FMT " fixed), ", partition, sys->size, sys->size > 1 ? "s" : "", sys->nv, sys->nfree, sys->nfix_global));
  if (sys->ncell_global) PetscCall(PetscPrintf(sys->comm, "%" PetscInt_FMT " %s, ", sys->ncell_global, sys->cell_size == 4 ? "tets" : "triangles"));
  PetscCall(PetscPrintf(sys->comm, "%" PetscInt_FMT " springs (%" PetscInt_FMT " with a free end)\n", sys->nspring_total, sys->nspring_global));
  PetscCall(PetscPrintf(sys->comm, "  edge cut: %" PetscInt_FMT " springs (%.2f%% of the %" PetscInt_FMT " between free vertices)\n", cut, between_free ? 100.0 * cut / between_free : 0.0, between_free));
  PetscCall(PetscPrintf(sys->comm, "  rank   owned  ghosts  springs    halo\n"));
  if (sys->rank == 0) {
    PetscReal sum[4] = {0, 0, 0, 0}, max[4] = {0, 0, 0, 0};
    for (PetscMPIInt r = 0; r < sys->size; r++) {
      PetscCall(PetscPrintf(PETSC_COMM_SELF, "  %4d %7" PetscInt_FMT " %7" PetscInt_FMT " %8" PetscInt_FMT " %7" PetscInt_FMT "\n", r, all[4 * r], all[4 * r + 1], all[4 * r + 2], all[4 * r + 3]));
      for (int q = 0; q < 4; q++) {
        sum[q] += all[4 * r + q];
        max[q] = std::max(max[q], (PetscReal)all[4 * r + q]);
      }
    }
    PetscCall(PetscPrintf(PETSC_COMM_SELF, "  balance (max / mean): vertices %.3f, springs %.3f, ghosts %.3f\n", max[0] * sys->size / PetscMax(sum[0], 1), max[2] * sys->size / PetscMax(sum[2], 1), max[1] * sys->size / PetscMax(sum[1], 1)));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
