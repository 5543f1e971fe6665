/* ptscotch: PT-Scotch through PETSc's PetscPartitioner, on the distributed graph, in parallel. */
#include "../partitioner_impl.h"
#include <petscpartitioner.h>

static PetscErrorCode MSimPartitionerPartition_PTScotch(MSimPartitioner p, PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscPartitioner pp;
  PetscSection     sec;
  IS               is;
  const PetscInt  *pts;
  PetscMPIInt      size;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(p->comm, &size));
  PetscCall(PetscPartitionerCreate(p->comm, &pp));
  PetscCall(PetscPartitionerSetType(pp, PETSCPARTITIONERPTSCOTCH));
  PetscCall(PetscSectionCreate(p->comm, &sec));
  PetscCall(PetscPartitionerPartition(pp, size, n, xadj.data(), adjncy.data(), NULL, NULL, sec, &is));
  PetscCall(ISGetIndices(is, &pts));
  for (PetscMPIInt r = 0; r < size; r++) {
    PetscInt dof, off;
    PetscCall(PetscSectionGetDof(sec, r, &dof));
    PetscCall(PetscSectionGetOffset(sec, r, &off));
    for (PetscInt k = off; k < off + dof; k++) part[pts[k]] = r;
  }
  PetscCall(ISRestoreIndices(is, &pts));
  PetscCall(ISDestroy(&is));
  PetscCall(PetscSectionDestroy(&sec));
  PetscCall(PetscPartitionerDestroy(&pp));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerCreate_PTScotch(MSimPartitioner p)
{
  PetscFunctionBeginUser;
  p->partition = MSimPartitionerPartition_PTScotch;
  PetscFunctionReturn(PETSC_SUCCESS);
}
