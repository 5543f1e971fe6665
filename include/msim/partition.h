/* Partition layer: assigns each free vertex to a rank. The graph comes distributed: rank r holds
   the rows of free vertices [start, start + n) (in input order) with their neighbours' global free
   numbers. natural: contiguous blocks in input order (regular grids, tests); metis: METIS k-way on
   rank 0, which gathers the graph (it is the one rank that holds more than its part, transiently,
   as when it reads a file); ptscotch: PT-Scotch through PETSc's PetscPartitioner, in parallel.
   The system then numbers vertices so each rank owns a contiguous block. */
#pragma once
#include <msim/sys.h>
#include <vector>

/* xadj/adjncy: this rank's CSR rows (n of them, global free numbers as columns), nfree the total.
   part: out, the owning rank of each of the n. Collective. */
PetscErrorCode MSimPartition(MPI_Comm comm, const char type[], PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part);
