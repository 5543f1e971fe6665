/* The partitioner's body, for the types under impls/ alone. */
#pragma once
#include <msim/partition.h>

struct _n_MSimPartitioner {
  MPI_Comm    comm;
  PetscMPIInt size;
  char        type[64];
  PetscBool   uses_graph;
  /* fills part (n entries, already sized) on more than one rank; every rank calls it */
  PetscErrorCode (*partition)(MSimPartitioner, PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part);
};

/* contiguous blocks of the free vertices in input order, the first nfree % size one larger */
void MSimPartitionBlocks(PetscInt nfree, PetscMPIInt size, PetscInt start, PetscInt n, std::vector<PetscMPIInt> &part);
