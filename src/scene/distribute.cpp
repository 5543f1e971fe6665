/* The scene's distributed steps: vertices to their directory rank, cells spread by their first
   vertex, a mesh's springs from the unique edges of its cells, found where the lower vertex of the
   edge has its directory (so every edge is seen by one rank, whichever ranks hold its cells). */
#include "local_edges.h"
#include <cmath>
#include <msim/errors.h>

namespace {
struct VertexRecord {
  PetscInt  id;
  PetscInt  fid; /* id in the file (where the scene has file ids; in what would be padding) */
  PetscReal x[3];
};
struct CellRecord {
  PetscInt v[4];
  PetscInt id; /* its place in the scene's order (MSimSceneData::cell_id) */
};
/* one unique edge of one rank's cells, sent to the directory of its lower vertex a */
struct EdgeRecord {
  PetscInt  a, b;
  PetscInt  count;       /* cells around it on the sending rank */
  PetscInt  opposite[2]; /* triangles: the third vertex of the first two of them (bending springs) */
  PetscReal measure;     /* their volume or area */
  PetscReal length;
};
struct ShareRecord {
  PetscInt  id;
  PetscReal share;
};
struct PairRecord {
  PetscInt a, b;
};
/* a cell or spring drawn, on its way to the rank of its place in the scene's order */
struct DrawnCell {
  PetscInt place;
  PetscInt v[4];
};
struct DrawnSpring {
  PetscInt  place;
  PetscInt  a, b;
  PetscReal L;
};
} // namespace


PetscErrorCode MSimSceneToDirectory(MPI_Comm comm, MSimSceneData *s)
{
  PetscMPIInt               rank, size;
  std::vector<PetscMPIInt>  dest(s->vid.size());
  std::vector<VertexRecord> send(s->vid.size()), recv;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  s->dir.Set(s->nv, size);
  for (size_t k = 0; k < s->vid.size(); k++) {
    PetscCheck(s->vid[k] >= 0 && s->vid[k] < s->nv, PETSC_COMM_SELF, PETSC_ERR_PLIB, "the %s scene made vertex %" PetscInt_FMT " outside [0, %" PetscInt_FMT ")", s->name.c_str(), s->vid[k], s->nv);
    dest[k] = s->dir.Owner(s->vid[k]);
    send[k].id  = s->vid[k];
    send[k].fid = s->nv_file > 0 ? s->vfile[k] : s->vid[k];
    for (int c = 0; c < 3; c++) send[k].x[c] = s->vx[3 * k + c];
  }
  s->vid.clear();
  s->vid.shrink_to_fit();
  s->vx.clear();
  s->vx.shrink_to_fit();
  s->vfile.clear();
  s->vfile.shrink_to_fit();
  PetscCall(MSimExchange(comm, dest, std::move(send), recv));
  send.clear();
  send.shrink_to_fit();
  const PetscInt start = s->dir.Start(rank), count = s->dir.Count(rank);
  std::vector<char> seen(count, 0);
  s->x0.assign(3 * (size_t)count, 0.0);
  if (s->nv_file > 0) s->file_id.assign(count, -1);
  else s->file_id.clear();
  for (const VertexRecord &r : recv) {
    PetscCheck(!seen[r.id - start], PETSC_COMM_SELF, PETSC_ERR_PLIB, "the %s scene made vertex %" PetscInt_FMT " twice", s->name.c_str(), r.id);
    seen[r.id - start] = 1;
    if (s->nv_file > 0) s->file_id[r.id - start] = r.fid;
    for (int c = 0; c < 3; c++) s->x0[3 * (size_t)(r.id - start) + c] = r.x[c];
  }
  PetscCheck((PetscInt)recv.size() == count, PETSC_COMM_SELF, PETSC_ERR_PLIB, "the %s scene left %" PetscInt_FMT " vertices of rank %d's block unmade", s->name.c_str(), count - (PetscInt)recv.size(), rank);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneFetchPositions(MPI_Comm comm, const MSimSceneData *s, const std::vector<PetscInt> &ids, std::vector<PetscReal> &x)
{
  std::vector<VertexRecord> table, got;
  PetscMPIInt               rank;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  table.resize(s->x0.size() / 3);
  for (size_t v = 0; v < table.size(); v++) {
    table[v].id = s->dir.Start(rank) + (PetscInt)v;
    for (int c = 0; c < 3; c++) table[v].x[c] = s->x0[3 * v + c];
  }
  PetscCall(MSimFetch(comm, s->dir, table, ids, got));
  x.resize(3 * ids.size());
  for (size_t k = 0; k < ids.size(); k++)
    for (int c = 0; c < 3; c++) x[3 * k + c] = got[k].x[c];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneSpreadCells(MPI_Comm comm, MSimSceneData *s)
{
  const int                k = s->cell_size;
  const size_t             nc = k ? s->cells.size() / k : 0;
  std::vector<PetscMPIInt> dest(nc);
  std::vector<CellRecord>  send(nc), recv;
  PetscMPIInt              rank;
  PetscInt                 first = 0, mine = (PetscInt)nc;

  PetscFunctionBeginUser;
  /* each cell keeps its place in the scene's order, which the spread loses: the first spread
     finds them in that order (a file's on rank 0, a generator's in rank order), a refined mesh's
     spread has its children's places */
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Exscan(&mine, &first, 1, MPIU_INT, MPI_SUM, comm));
  if (rank == 0) first = 0;
  for (size_t c = 0; c < nc; c++) {
    dest[c] = s->dir.Owner(s->cells[k * c]);
    for (int q = 0; q < 4; q++) send[c].v[q] = q < k ? s->cells[k * c + q] : -1;
    send[c].id = s->cell_id.empty() ? first + (PetscInt)c : s->cell_id[c];
  }
  s->cells.clear();
  s->cells.shrink_to_fit();
  PetscCall(MSimExchange(comm, dest, std::move(send), recv));
  s->cells.resize(k * recv.size());
  s->cell_id.resize(recv.size());
  for (size_t c = 0; c < recv.size(); c++) {
    for (int q = 0; q < k; q++) s->cells[k * c + q] = recv[c].v[q];
    s->cell_id[c] = recv[c].id;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneCellSprings(MPI_Comm comm, MSimSceneData *s)
{
  const int                k  = s->cell_size;
  const size_t             nc = s->cells.size() / k;
  PetscMPIInt              rank;
  MSimLocalEdges           E;
  std::vector<PetscReal>   x, meas(nc), share;
  std::vector<PetscMPIInt> dest;
  std::vector<EdgeRecord>  edges, got;
  std::vector<ShareRecord> shares, gotshares;
  PetscReal                measure = 0;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCall(MSimLocalEdgesBuild(s, E));
  PetscCall(MSimSceneFetchPositions(comm, s, E.ids, x));
  share.assign(E.ids.size(), 0.0);
  for (size_t c = 0; c < nc; c++) {
    const PetscInt *l = &E.local[k * c];
    meas[c] = k == 4 ? MSimTetVolume(&x[3 * l[0]], &x[3 * l[1]], &x[3 * l[2]], &x[3 * l[3]]) : MSimTriangleArea(&x[3 * l[0]], &x[3 * l[1]], &x[3 * l[2]]);
    measure += meas[c];
    for (int q = 0; q < k; q++) share[l[q]] += meas[c] / k;
  }
  PetscCallMPI(MPI_Allreduce(&measure, &s->measure, 1, MPIU_REAL, MPIU_SUM, comm));
  /* the measure shares, summed where the vertex has its directory */
  shares.resize(E.ids.size());
  dest.resize(E.ids.size());
  for (size_t v = 0; v < E.ids.size(); v++) {
    shares[v] = {E.ids[v], share[v]};
    dest[v]   = s->dir.Owner(E.ids[v]);
  }
  PetscCall(MSimExchange(comm, dest, std::move(shares), gotshares));
  const PetscInt start = s->dir.Start(rank);
  s->share.assign(s->dir.Count(rank), 0.0);
  for (const ShareRecord &r : gotshares) s->share[r.id - start] += r.share;
  /* one record per unique edge of this rank's cells */
  const size_t ne = E.a.size();
  edges.resize(ne);
  dest.resize(ne);
  for (size_t e = 0; e < ne; e++) {
    const PetscReal *p = &x[3 * E.a[e]], *q = &x[3 * E.b[e]];
    EdgeRecord      &r = edges[e];
    r.a                = E.ids[E.a[e]];
    r.b                = E.ids[E.b[e]];
    r.count            = E.ptr[e + 1] - E.ptr[e];
    r.measure          = 0;
    r.opposite[0] = r.opposite[1] = -1;
    for (PetscInt q2 = E.ptr[e]; q2 < E.ptr[e + 1]; q2++) {
      const PetscInt c = E.cells[q2];
      r.measure += meas[c];
      if (k == 3 && q2 - E.ptr[e] < 2) {
        const PetscInt *g = &s->cells[3 * c];
        r.opposite[q2 - E.ptr[e]] = g[0] != r.a && g[0] != r.b ? g[0] : g[1] != r.a && g[1] != r.b ? g[1] : g[2];
      }
    }
    r.length = std::sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]));
    dest[e]  = s->dir.Owner(r.a);
  }
  E = MSimLocalEdges();
  PetscCall(MSimExchange(comm, dest, std::move(edges), got));
  edges.clear();
  edges.shrink_to_fit();
  /* one spring per edge; Young's modulus: k = E V_e / L^2. Under any uniform strain eps the
     springs then store sum_e k_e (eps L_e)^2 / 2 = E eps^2 sum_e V_e / 2 = 3 E eps^2 V (each tet
     has 6 edges): the strain energy of an isotropic solid of modulus E and Poisson ratio 1/4 (the
     ratio of a lattice of central springs) dilated by eps. */
  std::sort(got.begin(), got.end(), [](const EdgeRecord &u, const EdgeRecord &v) { return u.a < v.a || (u.a == v.a && u.b < v.b); });
  std::vector<PairRecord>  bend;
  std::vector<PetscMPIInt> bdest;
  for (size_t q = 0; q < got.size();) {
    size_t    r      = q;
    PetscReal around = 0;
    PetscInt  cells = 0, opp[2] = {-1, -1}, nopp = 0;
    for (; r < got.size() && got[r].a == got[q].a && got[r].b == got[q].b; r++) {
      around += got[r].measure;
      cells += got[r].count;
      for (int o = 0; o < 2; o++)
        if (got[r].opposite[o] >= 0 && nopp < 2) opp[nopp++] = got[r].opposite[o];
    }
    s->si.push_back(got[q].a);
    s->sj.push_back(got[q].b);
    s->sL.push_back(got[q].length);
    s->sk.push_back(s->young > 0 ? s->young * around / (got[q].length * got[q].length) : s->k_cell);
    if (s->k_bend > 0 && cells == 2) {
      bend.push_back({std::min(opp[0], opp[1]), std::max(opp[0], opp[1])});
      bdest.push_back(s->dir.Owner(bend.back().a));
    }
    q = r;
  }
  got.clear();
  got.shrink_to_fit();
  if (s->k_bend > 0) {
    /* one bending spring per pair of opposite vertices, none where an edge already joins them (a
       pair can face two edges, e.g. on a tetrahedron's surface); the edges from c are all here */
    std::vector<PairRecord> pairs;
    PetscCall(MSimExchange(comm, bdest, std::move(bend), pairs));
    std::sort(pairs.begin(), pairs.end(), [](const PairRecord &u, const PairRecord &v) { return u.a < v.a || (u.a == v.a && u.b < v.b); });
    pairs.erase(std::unique(pairs.begin(), pairs.end(), [](const PairRecord &u, const PairRecord &v) { return u.a == v.a && u.b == v.b; }), pairs.end());
    std::vector<PetscInt> far;
    std::vector<PairRecord> keep;
    const size_t nedge = s->si.size();
    for (const PairRecord &p : pairs) {
      auto lo = std::lower_bound(s->si.begin(), s->si.begin() + nedge, p.a);
      auto hi = std::upper_bound(lo, s->si.begin() + nedge, p.a);
      if (std::binary_search(s->sj.begin() + (lo - s->si.begin()), s->sj.begin() + (hi - s->si.begin()), p.b)) continue;
      keep.push_back(p);
      far.push_back(p.b);
    }
    std::vector<PetscReal> xb;
    s->nbend = (PetscInt)keep.size();
    PetscCall(MSimSceneFetchPositions(comm, s, far, xb));
    std::string bad;
    for (size_t q = 0; q < keep.size(); q++) {
      const PetscReal *xa = &s->x0[3 * (size_t)(keep[q].a - start)], *pb = &xb[3 * q];
      const PetscReal  L  = std::sqrt((xa[0] - pb[0]) * (xa[0] - pb[0]) + (xa[1] - pb[1]) * (xa[1] - pb[1]) + (xa[2] - pb[2]) * (xa[2] - pb[2]));
      if (!(L > 0) && bad.empty()) bad = s->source + ": vertices " + std::to_string(keep[q].a) + " and " + std::to_string(keep[q].b) + ", opposite across an edge, are at the same place (a bending spring of zero length: the surface folds onto itself)";
      s->si.push_back(keep[q].a);
      s->sj.push_back(keep[q].b);
      s->sk.push_back(s->k_bend);
      s->sL.push_back(L);
    }
    PetscCall(MSimCollectiveCheck(comm, (PetscBool)bad.empty(), bad));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the records to the ranks of their places, ordered there; every place in [0, total) arrives once */
template <typename R>
static PetscErrorCode ToPlaces(MPI_Comm comm, std::vector<R> &&send, std::vector<R> &got)
{
  PetscMPIInt              rank, size;
  PetscInt                 total = (PetscInt)send.size();
  MSimBlockLayout          layout;
  std::vector<PetscMPIInt> dest(send.size());

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &total, 1, MPIU_INT, MPI_SUM, comm));
  layout.Set(total, size);
  for (size_t k = 0; k < send.size(); k++) dest[k] = layout.Owner(send[k].place);
  PetscCall(MSimExchange(comm, dest, std::move(send), got));
  std::sort(got.begin(), got.end(), [](const R &u, const R &v) { return u.place < v.place; });
  const PetscInt start = layout.Start(rank);
  PetscCheck((PetscInt)got.size() == layout.Count(rank), PETSC_COMM_SELF, PETSC_ERR_PLIB, "%zu drawn items for a block of %" PetscInt_FMT, got.size(), layout.Count(rank));
  for (size_t k = 0; k < got.size(); k++) PetscCheck(got[k].place == start + (PetscInt)k, PETSC_COMM_SELF, PETSC_ERR_PLIB, "drawn item at place %" PetscInt_FMT " where %" PetscInt_FMT " belongs", got[k].place, start + (PetscInt)k);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneDrawnCells(MPI_Comm comm, const MSimSceneData *s, std::vector<PetscInt> &cells)
{
  const int              k  = s->cell_size;
  const size_t           nc = s->cells.size() / k;
  PetscMPIInt            rank;
  PetscInt               first = 0, mine = (PetscInt)nc;
  std::vector<DrawnCell> send(nc), got;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Exscan(&mine, &first, 1, MPIU_INT, MPI_SUM, comm));
  if (rank == 0) first = 0;
  for (size_t c = 0; c < nc; c++) {
    send[c].place = s->cell_id.empty() ? first + (PetscInt)c : s->cell_id[c];
    for (int q = 0; q < 4; q++) send[c].v[q] = q < k ? s->cells[k * c + q] : -1;
  }
  PetscCall(ToPlaces(comm, std::move(send), got));
  cells.resize(k * got.size());
  for (size_t c = 0; c < got.size(); c++)
    for (int q = 0; q < k; q++) cells[k * c + q] = got[c].v[q];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneDrawnSprings(MPI_Comm comm, const MSimSceneData *s, std::vector<PetscInt> &ends, std::vector<PetscReal> &L)
{
  const size_t             n = s->si.size();
  const PetscInt           nother = (PetscInt)n - s->nbend;
  PetscMPIInt              rank;
  PetscInt                 mine[2] = {nother, s->nbend}, first[2] = {0, 0}, total[2];
  std::vector<DrawnSpring> send(n), got;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Exscan(mine, first, 2, MPIU_INT, MPI_SUM, comm));
  if (rank == 0) first[0] = first[1] = 0;
  PetscCallMPI(MPI_Allreduce(mine, total, 2, MPIU_INT, MPI_SUM, comm));
  for (size_t q = 0; q < n; q++) {
    const PetscInt i = (PetscInt)q;
    send[q]          = {i < nother ? first[0] + i : total[0] + first[1] + i - nother, s->si[q], s->sj[q], s->sL[q]};
  }
  PetscCall(ToPlaces(comm, std::move(send), got));
  ends.resize(2 * got.size());
  L.resize(got.size());
  for (size_t q = 0; q < got.size(); q++) {
    ends[2 * q]     = got[q].a;
    ends[2 * q + 1] = got[q].b;
    L[q]            = got[q].L;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
