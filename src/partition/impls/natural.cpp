/* natural: contiguous blocks of the free vertices in input order (regular grids, tests); no graph. */
#include "../partitioner_impl.h"

static PetscErrorCode MSimPartitionerPartition_Natural(MSimPartitioner p, PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &, std::vector<PetscInt> &, std::vector<PetscMPIInt> &part)
{
  PetscFunctionBeginUser;
  MSimPartitionBlocks(nfree, p->size, start, n, part);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerCreate_Natural(MSimPartitioner p)
{
  PetscFunctionBeginUser;
  p->uses_graph = PETSC_FALSE;
  p->partition  = MSimPartitionerPartition_Natural;
  PetscFunctionReturn(PETSC_SUCCESS);
}
