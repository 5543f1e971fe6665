/* The volume term's tets to the ranks that compute them (msim/volume.h): each to the owner of its
   free vertex of least global number, and a halo copy to each other rank that owns one of its
   free vertices, in one personalized all-to-all of what each rank holds, and the springs'
   equivalent Young's modulus, from which the term's stiffness defaults. */
#include "system_distribute.h"
#include <algorithm>

PetscErrorCode MSimSystemDistributeTets(MPI_Comm comm, const MSimSceneData &S, const std::vector<MSimVertexOwner> &table, MSimLocalPart &L)
{
  std::vector<PetscInt>        ends, at;
  std::vector<MSimVertexOwner> info;
  std::vector<PetscReal>       x;
  std::vector<MSimRoutedTet>   send;
  std::vector<PetscMPIInt>     dest;
  PetscReal                    sums[2] = {0, 0}; /* sum_s k L^2 over the springs, sum |V0| over the tets */
  PetscMPIInt                  size;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  const size_t nc = S.cells.size() / 4;
  MSimCompactIds(S.cells, ends, at);
  PetscCall(MSimFetch(comm, S.dir, table, ends, info));
  PetscCall(MSimSceneFetchPositions(comm, &S, ends, x));
  for (size_t c = 0; c < nc; c++) {
    MSimRoutedTet r;
    PetscMPIInt   to[4]; /* the distinct owners of its free vertices */
    int           nto = 0;
    for (int q = 0; q < 4; q++) {
      const MSimVertexOwner &o = info[at[4 * c + q]];
      r.v[q]                   = S.cells[4 * c + q];
      r.g[q]                   = o.gnum;
      if (o.gnum >= 0 && std::find(to, to + nto, o.owner) == to + nto) to[nto++] = o.owner;
    }
    r.V0 = MSimTetVolume(&x[3 * at[4 * c]], &x[3 * at[4 * c + 1]], &x[3 * at[4 * c + 2]], &x[3 * at[4 * c + 3]]);
    sums[1] += PetscAbsReal(r.V0);
    if (!nto || r.V0 == 0) continue; /* all fixed: no effect on the motion; flat: no J */
    for (int k = 0; k < (size > 1 ? nto : 1); k++) {
      send.push_back(r);
      dest.push_back(size > 1 ? to[k] : 0);
    }
  }
  for (size_t s = 0; s < S.sk.size(); s++) sums[0] += S.sk[s] * S.sL[s] * S.sL[s];
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, sums, 2, MPIU_REAL, MPIU_SUM, comm));
  /* springs from Young's modulus E store sum_s k L^2 eps^2 / 2 = 3 E eps^2 V under a dilation eps
     (src/scene/distribute.cpp): this E, exact for them, is the modulus of any spring network */
  L.modulus = sums[1] > 0 ? sums[0] / (6 * sums[1]) : 0;
  PetscCall(MSimExchange(comm, dest, std::move(send), L.tets));
  /* this rank's tets (it owns the free vertex of least global number) first, then its halo; each
     in an order that does not depend on the rank count: by input ids */
  const auto mine = [&](const MSimRoutedTet &t) {
    PetscInt best = -1;
    for (int q = 0; q < 4; q++)
      if (t.g[q] >= 0 && (best < 0 || t.g[q] < best)) best = t.g[q];
    return best >= L.rstart && best < L.rstart + L.nown;
  };
  std::sort(L.tets.begin(), L.tets.end(), [&](const MSimRoutedTet &a, const MSimRoutedTet &b) {
    const bool ma = mine(a), mb = mine(b);
    return ma != mb ? ma : std::lexicographical_compare(a.v, a.v + 4, b.v, b.v + 4);
  });
  L.ntet_own = (PetscInt)(std::partition_point(L.tets.begin(), L.tets.end(), mine) - L.tets.begin());
  PetscInt n = L.ntet_own;
  PetscCallMPI(MPI_Allreduce(&n, &L.ntet, 1, MPIU_INT, MPI_SUM, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}
