#include <msim/partition.h>
#include <metis.h>
#include <petscpartitioner.h>

/* contiguous blocks of the free vertices in input order, the first nfree % size one larger */
static void MSimPartitionNatural(PetscInt nfree, PetscMPIInt size, PetscInt start, PetscInt n, std::vector<PetscMPIInt> &part)
{
  const PetscInt base = nfree / size, rem = nfree % size, big = rem * (base + 1);
  for (PetscInt k = 0; k < n; k++) {
    const PetscInt f = start + k;
    part[k]          = (PetscMPIInt)(f < big ? f / (base + 1) : rem + (f - big) / PetscMax(base, 1));
  }
}

/* METIS k-way on rank 0: the graph is gathered there, partitioned with a fixed seed, and each rank
   gets its rows' parts back */
static PetscErrorCode MSimPartitionMetis(MPI_Comm comm, PetscInt nfree, PetscInt start, PetscInt n, const std::vector<PetscInt> &xadj, const std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscMPIInt              rank, size;
  std::vector<PetscMPIInt> rows, edges, rdispl, edispl;
  std::vector<PetscInt>    deg(n), alldeg, alladj;
  std::vector<PetscMPIInt> allpart;
  PetscBool                empty = PETSC_FALSE;

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
    std::vector<idx_t> xa(nfree + 1, 0), adj(alladj.begin(), alladj.end()), p(nfree);
    idx_t              options[METIS_NOPTIONS];
    for (PetscInt v = 0; v < nfree; v++) xa[v + 1] = xa[v] + alldeg[v];
    alladj.clear();
    alladj.shrink_to_fit();
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = 7;
    int ret = METIS_PartGraphKway(&nvtxs, &ncon, xa.data(), adj.data(), NULL, NULL, NULL, &nparts, NULL, NULL, options, &objval, p.data());
    PetscCheck(ret == METIS_OK, PETSC_COMM_SELF, PETSC_ERR_LIB, "METIS_PartGraphKway failed (code %d)", ret);
    allpart.assign(p.begin(), p.end());
    std::vector<PetscInt> count(size, 0);
    for (PetscInt v = 0; v < nfree; v++) count[allpart[v]]++;
    for (PetscMPIInt r = 0; r < size; r++) empty = (PetscBool)(empty || !count[r]);
  }
  PetscCallMPI(MPI_Scatterv(allpart.data(), rows.data(), rdispl.data(), MPI_INT, part.data(), nrow, MPI_INT, 0, comm));
  /* METIS may leave a part empty on tiny graphs; every rank must own a vertex */
  PetscCallMPI(MPI_Bcast(&empty, 1, MPIU_BOOL, 0, comm));
  if (empty) MSimPartitionNatural(nfree, size, start, n, part);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* PT-Scotch through PetscPartitioner, on the distributed graph */
static PetscErrorCode MSimPartitionPetsc(MPI_Comm comm, const char type[], PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscPartitioner p;
  PetscSection     sec;
  IS               is;
  const PetscInt  *pts;
  PetscMPIInt      size;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(PetscPartitionerCreate(comm, &p));
  PetscCall(PetscPartitionerSetType(p, type));
  PetscCall(PetscSectionCreate(comm, &sec));
  PetscCall(PetscPartitionerPartition(p, size, n, xadj.data(), adjncy.data(), NULL, NULL, sec, &is));
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
  PetscCall(PetscPartitionerDestroy(&p));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartition(MPI_Comm comm, const char type[], PetscInt nfree, PetscInt start, PetscInt n, std::vector<PetscInt> &xadj, std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscMPIInt size;
  PetscBool   natural, metis, ptscotch;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  part.assign(n, 0);
  PetscCall(PetscStrcmp(type, "natural", &natural));
  PetscCall(PetscStrcmp(type, "metis", &metis));
  PetscCall(PetscStrcmp(type, "ptscotch", &ptscotch));
  PetscCheck(natural || metis || ptscotch, comm, PETSC_ERR_ARG_UNKNOWN_TYPE, "-msim_partition %s is not known (use metis, ptscotch or natural)", type);
  if (size == 1) PetscFunctionReturn(PETSC_SUCCESS);
  if (natural) MSimPartitionNatural(nfree, size, start, n, part);
  else if (metis) PetscCall(MSimPartitionMetis(comm, nfree, start, n, xadj, adjncy, part));
  else {
    PetscCall(MSimPartitionPetsc(comm, PETSCPARTITIONERPTSCOTCH, n, xadj, adjncy, part));
    /* PT-Scotch too may leave a rank without a vertex on a tiny graph */
    std::vector<PetscInt> count(size, 0);
    PetscInt              empty = 0;
    for (PetscMPIInt r : part) count[r]++;
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, count.data(), size, MPIU_INT, MPI_SUM, comm));
    for (PetscMPIInt r = 0; r < size; r++) empty += !count[r];
    if (empty) MSimPartitionNatural(nfree, size, start, n, part);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
