#include "local_edges.h"
#include <algorithm>
#include <msim/log.h>

namespace {
const int kTetEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
const int kTriEdges[3][2] = {{0, 1}, {0, 2}, {1, 2}};
struct Slot {
  PetscInt other, cell, which;
};
} // namespace

PetscErrorCode MSimLocalEdgesBuild(const MSimSceneData *s, MSimLocalEdges &E)
{
  const int    k = s->cell_size, ne = k == 4 ? 6 : 3;
  const int(*EV)[2] = k == 4 ? kTetEdges : kTriEdges;
  const size_t nc   = s->cells.size() / k;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_MeshEdges, 0, 0, 0, 0));
  MSimCompactIds(s->cells, E.ids, E.local);
  /* bucket every cell edge under its lower vertex */
  const PetscInt      nv = (PetscInt)E.ids.size();
  std::vector<size_t> bptr(nv + 1, 0);
  for (size_t c = 0; c < nc; c++)
    for (int e = 0; e < ne; e++) bptr[std::min(E.local[k * c + EV[e][0]], E.local[k * c + EV[e][1]]) + 1]++;
  for (PetscInt v = 0; v < nv; v++) bptr[v + 1] += bptr[v];
  std::vector<Slot> slot(bptr[nv]);
  {
    std::vector<size_t> fill(bptr.begin(), bptr.end() - 1);
    for (size_t c = 0; c < nc; c++)
      for (int e = 0; e < ne; e++) {
        const PetscInt p = E.local[k * c + EV[e][0]], q = E.local[k * c + EV[e][1]];
        slot[fill[std::min(p, q)]++] = {std::max(p, q), (PetscInt)c, e};
      }
  }
  E.a.clear();
  E.b.clear();
  E.cells.resize(slot.size());
  E.ptr.assign(1, 0);
  E.cell_edge.resize(ne * nc);
  for (PetscInt v = 0; v < nv; v++) {
    std::sort(slot.begin() + bptr[v], slot.begin() + bptr[v + 1], [](const Slot &x, const Slot &y) { return x.other < y.other || (x.other == y.other && x.cell < y.cell); });
    for (size_t q = bptr[v]; q < bptr[v + 1]; q++) {
      if (q == bptr[v] || slot[q].other != slot[q - 1].other) {
        E.a.push_back(v);
        E.b.push_back(slot[q].other);
        E.ptr.push_back(E.ptr.back());
      }
      E.cells[E.ptr.back()++] = slot[q].cell;
      E.cell_edge[ne * slot[q].cell + slot[q].which] = (PetscInt)E.a.size() - 1;
    }
  }
  PetscCall(PetscLogEventEnd(MSIM_MeshEdges, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
