/* Ghost exchange: plan from a PetscSF, transfer in plain point-to-point MPI (msim/ghost_exchange.h). */
#include <msim/ghost_exchange.h>
#include <petscsf.h>
#include <algorithm>

PetscErrorCode MSimGhostExchangeCreate(MPI_Comm comm, PetscInt bs, PetscInt nown, PetscInt nghost, const PetscInt *ghosts, const PetscInt *ranges, MSimGhostExchange *x)
{
  PetscSF            sf;
  PetscSFNode       *remote;
  PetscMPIInt        size;
  PetscInt           niranks;
  const PetscMPIInt *iranks;
  const PetscInt    *ioffset, *irootloc;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(PetscCommDuplicate(comm, &x->comm, &x->tag));
  x->created = PETSC_TRUE;
  x->bs = bs;
  /* receiving side: ghosts ascend, so those of one owner are one run */
  PetscCall(PetscMalloc1(nghost, &remote));
  x->from.clear();
  x->from_off.clear();
  for (PetscInt g = 0; g < nghost; g++) {
    const PetscMPIInt r = (PetscMPIInt)(std::upper_bound(ranges, ranges + size + 1, ghosts[g]) - ranges - 1);
    PetscCheck(g == 0 || ghosts[g] > ghosts[g - 1], PETSC_COMM_SELF, PETSC_ERR_PLIB, "ghosts must ascend");
    remote[g].rank  = r;
    remote[g].index = ghosts[g] - ranges[r];
    if (x->from.empty() || x->from.back() != r) x->from.push_back(r), x->from_off.push_back(g);
  }
  x->from_off.push_back(nghost);
  /* sending side: the SF's roots that other ranks' leaves read, grouped by rank; ascending within a
     group, as the receiver's run of ghosts ascends, so each message lands in that run as it is */
  PetscCall(PetscSFCreate(comm, &sf));
  PetscCall(PetscSFSetGraph(sf, nown, nghost, NULL, PETSC_OWN_POINTER, remote, PETSC_OWN_POINTER));
  PetscCall(PetscSFSetUp(sf));
  PetscCall(PetscSFGetLeafRanks(sf, &niranks, &iranks, &ioffset, &irootloc));
  x->to.assign(iranks, iranks + niranks);
  x->to_off.assign(ioffset, ioffset + niranks + 1);
  x->rows.assign(irootloc, irootloc + ioffset[niranks]);
  for (PetscInt n = 0; n < niranks; n++) std::sort(x->rows.begin() + ioffset[n], x->rows.begin() + ioffset[n + 1]);
  PetscCall(PetscSFDestroy(&sf));
  x->buf.resize(bs * x->rows.size());
  x->req.resize(x->to.size() + x->from.size());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimGhostExchangeBegin(MSimGhostExchange *x, const PetscReal *own, PetscReal *ghost)
{
  const PetscInt bs = x->bs, nfrom = (PetscInt)x->from.size();

  PetscFunctionBeginUser;
  for (PetscInt n = 0; n < nfrom; n++) PetscCallMPI(MPI_Irecv(ghost + bs * x->from_off[n], (PetscMPIInt)(bs * (x->from_off[n + 1] - x->from_off[n])), MPIU_REAL, x->from[n], x->tag, x->comm, &x->req[n]));
  for (size_t n = 0; n < x->to.size(); n++) {
    PetscReal *b = x->buf.data() + bs * x->to_off[n];
    for (PetscInt k = x->to_off[n]; k < x->to_off[n + 1]; k++, b += bs)
      for (PetscInt c = 0; c < bs; c++) b[c] = own[bs * x->rows[k] + c];
    PetscCallMPI(MPI_Isend(x->buf.data() + bs * x->to_off[n], (PetscMPIInt)(bs * (x->to_off[n + 1] - x->to_off[n])), MPIU_REAL, x->to[n], x->tag, x->comm, &x->req[nfrom + n]));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimGhostExchangeEnd(MSimGhostExchange *x)
{
  PetscFunctionBeginUser;
  if (!x->req.empty()) PetscCallMPI(MPI_Waitall((PetscMPIInt)x->req.size(), x->req.data(), MPI_STATUSES_IGNORE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimGhostExchangeDestroy(MSimGhostExchange *x)
{
  PetscFunctionBeginUser;
  if (x->created) PetscCall(PetscCommDestroy(&x->comm));
  x->created = PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}
