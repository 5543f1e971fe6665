/* The partitioner registry (-msim_partition) and what every type shares: one rank needs no
   partition, and no rank may be left without a vertex. */
#include "partitioner_impl.h"
#include <msim/options.h>
#include <msim/registry.h>

static MSimRegistry<PetscErrorCode (*)(MSimPartitioner)> MSimPartitioners;

PetscErrorCode MSimPartitionerRegister(const char name[], PetscErrorCode (*create)(MSimPartitioner))
{
  return MSimPartitioners.Add(name, create);
}

PetscErrorCode MSimPartitionerRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (!MSimPartitioners.Fill()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimPartitionerRegister(MSIMPARTITIONMETIS, MSimPartitionerCreate_Metis));
  PetscCall(MSimPartitionerRegister(MSIMPARTITIONPTSCOTCH, MSimPartitionerCreate_PTScotch));
  PetscCall(MSimPartitionerRegister(MSIMPARTITIONNATURAL, MSimPartitionerCreate_Natural));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerFinalizePackage(void)
{
  return MSimPartitioners.Destroy();
}

PetscErrorCode MSimPartitionerCreate(MPI_Comm comm, MSimPartitioner *p)
{
  PetscFunctionBeginUser;
  PetscCall(MSimPartitionerRegisterAll());
  *p         = new _n_MSimPartitioner();
  (*p)->comm = comm;
  PetscCallMPI(MPI_Comm_size(comm, &(*p)->size));
  PetscCall(MSimPartitionerSetType(*p, (*p)->size > 1 ? MSIMPARTITIONMETIS : MSIMPARTITIONNATURAL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerSetType(MSimPartitioner p, const char type[])
{
  PetscErrorCode (*create)(MSimPartitioner);

  PetscFunctionBeginUser;
  PetscCall(MSimPartitioners.Find(p->comm, "-msim_partition", type, &create));
  PetscCall(PetscStrncpy(p->type, type, sizeof(p->type)));
  p->uses_graph = PETSC_TRUE;
  p->partition  = NULL;
  PetscCall((*create)(p));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerSetFromOptions(MSimPartitioner p)
{
  char      type[64];
  PetscBool set;

  PetscFunctionBeginUser;
  PetscCall(PetscStrncpy(type, p->type, sizeof(type)));
  PetscOptionsBegin(p->comm, NULL, "msim partition", NULL);
  PetscCall(PetscOptionsFList("-msim_partition", "Distribution of vertices across ranks: metis (on rank 0), ptscotch (parallel) or natural (blocks in input order); default metis on several ranks, natural on one", NULL, MSimPartitioners.list, type, type, sizeof(type), &set));
  PetscOptionsEnd();
  if (set) PetscCall(MSimPartitionerSetType(p, type));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerGetType(MSimPartitioner p, const char **type)
{
  PetscFunctionBeginUser;
  *type = p->type;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerUsesGraph(MSimPartitioner p, PetscBool *uses)
{
  PetscFunctionBeginUser;
  *uses = p->uses_graph;
  PetscFunctionReturn(PETSC_SUCCESS);
}

void MSimPartitionBlocks(PetscInt nfree, PetscMPIInt size, PetscInt start, PetscInt n, std::vector<PetscMPIInt> &part)
{
  const PetscInt base = nfree / size, rem = nfree % size, big = rem * (base + 1);
  for (PetscInt k = 0; k < n; k++) {
    const PetscInt f = start + k;
    part[k]          = (PetscMPIInt)(f < big ? f / (base + 1) : rem + (f - big) / PetscMax(base, 1));
  }
}

PetscErrorCode MSimPartitionerPartition(MSimPartitioner p, PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscFunctionBeginUser;
  part.assign(n, 0);
  if (p->size == 1) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall((*p->partition)(p, nfree, start, n, xadj, adjncy, part));
  /* METIS and PT-Scotch may leave a rank without a vertex on a tiny graph; every rank must own one */
  std::vector<PetscInt> count(p->size, 0);
  PetscInt              empty = 0;
  for (PetscMPIInt r : part) count[r]++;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, count.data(), p->size, MPIU_INT, MPI_SUM, p->comm));
  for (PetscMPIInt r = 0; r < p->size; r++) empty += !count[r];
  if (empty) MSimPartitionBlocks(nfree, p->size, start, n, part);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerDestroy(MSimPartitioner *p)
{
  PetscFunctionBeginUser;
  delete *p;
  *p = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
