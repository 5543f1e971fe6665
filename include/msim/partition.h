/* Partition layer: assigns each free vertex to a rank, from the graph alone. The graph comes
   distributed: rank r holds the rows of free vertices [start, start + n) (in input order) with
   their neighbours' global free numbers. Partitioners are types by name (-msim_partition, listed
   by -help): natural, contiguous blocks in input order (regular grids, tests; needs no graph);
   metis, METIS k-way on rank 0, which gathers the graph (it is the one rank that holds more than
   its part, transiently, as when it reads a file); ptscotch, PT-Scotch through PETSc's
   PetscPartitioner, in parallel. Whatever the type, every rank gets a vertex. The system then
   numbers vertices so each rank owns a contiguous block. */
#pragma once
#include <msim/petsc_compat.h>
#include <vector>

typedef struct _n_MSimPartitioner *MSimPartitioner;

#define MSIMPARTITIONNATURAL  "natural"
#define MSIMPARTITIONMETIS    "metis"
#define MSIMPARTITIONPTSCOTCH "ptscotch"

PetscErrorCode MSimPartitionerRegister(const char name[], PetscErrorCode (*create)(MSimPartitioner));
PetscErrorCode MSimPartitionerRegisterAll(void);
PetscErrorCode MSimPartitionerFinalizePackage(void);

/* Collective. The type is metis on several ranks, natural on one, until set. */
PetscErrorCode MSimPartitionerCreate(MPI_Comm comm, MSimPartitioner *p);
PetscErrorCode MSimPartitionerSetType(MSimPartitioner p, const char type[]);
/* -msim_partition */
PetscErrorCode MSimPartitionerSetFromOptions(MSimPartitioner p);
PetscErrorCode MSimPartitionerGetType(MSimPartitioner p, const char **type);
/* whether Partition reads xadj/adjncy (natural does not: callers may skip building them) */
PetscErrorCode MSimPartitionerUsesGraph(MSimPartitioner p, PetscBool *uses);
/* xadj/adjncy: this rank's CSR rows (n of them, global free numbers as columns), nfree the total.
   part: out, the owning rank of each of the n. Collective. */
PetscErrorCode MSimPartitionerPartition(MSimPartitioner p, PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part);
PetscErrorCode MSimPartitionerDestroy(MSimPartitioner *p);

PETSC_EXTERN PetscErrorCode MSimPartitionerCreate_Natural(MSimPartitioner);
PETSC_EXTERN PetscErrorCode MSimPartitionerCreate_Metis(MSimPartitioner);
PETSC_EXTERN PetscErrorCode MSimPartitionerCreate_PTScotch(MSimPartitioner);
