/* metis: METIS k-way with a fixed seed, on rank 0, which gathers the graph. */
#include "../partitioner_impl.h"
#include <metis.h>

/* METIS k-way on rank 0: the graph is gathered there, partitioned with a fixed seed, and each rank
   gets its rows' parts back */
static PetscErrorCode MSimPartitionerPartition_Metis(MSimPartitioner p, PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscMPIInt              rank, size;
  std::vector<PetscMPIInt> rows, edges, rdispl, edispl;
  std::vector<PetscInt>    deg(n), alldeg, alladj;
  std::vector<PetscMPIInt> allpart;
  MPI_Comm                 comm = p->comm;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  const PetscMPIInt nrow = (PetscMPIInt)n, nedge = (PetscMPIInt)adjncy.size();
  for (PetscInt k = 0; k < n; k++) deg[k] = xadj[k + 1] - xadj[k];
  if (rank == 0) {
    rows.resize(size);
    edges.resize(size);
  }
  PetscCallMPI(MPI_Gather(&nrow, 1, MPI_INT, rows.data(), 1, MPI_INT, 0, comm));
  PetscCallMPI(MPI_Gather(&nedge, 1, MPI_INT, edges.data(), 1, MPI_INT, 0, comm));
  if (rank == 0) {
    rdispl.assign(size + 1, 0);
    edispl.assign(size + 1, 0);
    for (PetscMPIInt r = 0; r < size; r++) {
      rdispl[r + 1] = rdispl[r] + rows[r];
      edispl[r + 1] = edispl[r] + edges[r];
    }
    alldeg.resize(nfree);
    alladj.resize(edispl[size]);
  }
  PetscCallMPI(MPI_Gatherv(deg.data(), nrow, MPIU_INT, alldeg.data(), rows.data(), rdispl.data(), MPIU_INT, 0, comm));
  PetscCallMPI(MPI_Gatherv(adjncy.data(), nedge, MPIU_INT, alladj.data(), edges.data(), edispl.data(), MPIU_INT, 0, comm));
  if (rank == 0) {
    idx_t              nvtxs = nfree, ncon = 1, nparts = size, objval;
    std::vector<idx_t> xa(nfree + 1, 0), adj(alladj.begin(), alladj.end()), where(nfree);
    idx_t              options[METIS_NOPTIONS];
    for (PetscInt v = 0; v < nfree; v++) xa[v + 1] = xa[v] + alldeg[v];
    alladj.clear();
    alladj.shrink_to_fit();
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = 7;
    int ret = METIS_PartGraphKway(&nvtxs, &ncon, xa.data(), adj.data(), NULL, NULL, NULL, &nparts, NULL, NULL, options, &objval, where.data());
    PetscCheck(ret == METIS_OK, PETSC_COMM_SELF, PETSC_ERR_LIB, "METIS_PartGraphKway failed (code %d)", ret);
    allpart.assign(where.begin(), where.end());
  }
  PetscCallMPI(MPI_Scatterv(allpart.data(), rows.data(), rdispl.data(), MPI_INT, part.data(), nrow, MPI_INT, 0, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartitionerCreate_Metis(MSimPartitioner p)
{
  PetscFunctionBeginUser;
  p->partition = MSimPartitionerPartition_Metis;
  PetscFunctionReturn(PETSC_SUCCESS);
}
