#include <msim/partition.h>
#include <metis.h>

static PetscErrorCode MSimPartitionNatural(PetscInt n, PetscMPIInt size, std::vector<PetscMPIInt> &part)
{
  PetscFunctionBeginUser;
  PetscInt v = 0;
  for (PetscMPIInt r = 0; r < size; r++) {
    const PetscInt cnt = n / size + (r < n % size ? 1 : 0);
    for (PetscInt k = 0; k < cnt; k++) part[v++] = r;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Every rank calls METIS on the same graph with the same seed, so all agree without communication. */
static PetscErrorCode MSimPartitionMetis(MPI_Comm comm, PetscInt n, PetscMPIInt size, const std::vector<PetscInt> &xadj, const std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscFunctionBeginUser;
  if (size == 1 || n == 0) {
    for (PetscInt v = 0; v < n; v++) part[v] = 0;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  idx_t              nvtxs = n, ncon = 1, nparts = size, objval;
  std::vector<idx_t> xa(xadj.begin(), xadj.end()), adj(adjncy.begin(), adjncy.end()), p(n);
  idx_t              options[METIS_NOPTIONS];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_SEED] = 7;
  int ret = METIS_PartGraphKway(&nvtxs, &ncon, xa.data(), adj.data(), NULL, NULL, NULL, &nparts, NULL, NULL, options, &objval, p.data());
  PetscCheck(ret == METIS_OK, comm, PETSC_ERR_LIB, "METIS_PartGraphKway failed (code %d)", ret);
  std::vector<PetscInt> count(size, 0);
  for (PetscInt v = 0; v < n; v++) count[part[v] = (PetscMPIInt)p[v]]++;
  /* METIS may leave a part empty on tiny graphs; every rank must own a vertex */
  for (PetscMPIInt r = 0; r < size; r++)
    if (!count[r]) PetscCall(MSimPartitionNatural(n, size, part));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPartition(MPI_Comm comm, const char type[], PetscInt n, const std::vector<PetscInt> &xadj, const std::vector<PetscInt> &adjncy, std::vector<PetscMPIInt> &part)
{
  PetscMPIInt size;
  PetscBool   natural, metis;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  part.assign(n, 0);
  PetscCall(PetscStrcmp(type, "natural", &natural));
  PetscCall(PetscStrcmp(type, "metis", &metis));
  PetscCheck(natural || metis, comm, PETSC_ERR_ARG_UNKNOWN_TYPE, "-msim_partition %s is not known (use metis or natural)", type);
  if (natural) PetscCall(MSimPartitionNatural(n, size, part));
  else PetscCall(MSimPartitionMetis(comm, n, size, xadj, adjncy, part));
  PetscFunctionReturn(PETSC_SUCCESS);
}
