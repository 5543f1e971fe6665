/* Partition layer: assigns each free vertex to a rank. natural: contiguous blocks in input order
   (regular grids, tests). metis: METIS k-way on the free-vertex graph. The system then numbers
   vertices so each rank owns a contiguous block. */
#pragma once
#include <msim/sys.h>
#include <vector>

/* xadj/adjncy: CSR graph of the n free vertices. part: out, the owning rank of each. */
PetscErrorCode MSimPartition(MPI_Comm comm, const char type[], PetscInt n, const std::vector<PetscInt> &xadj, const std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part);
