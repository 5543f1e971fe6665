/* The scene's distributed steps: vertices to their directory rank, cells spread by their first
   vertex, a mesh's springs from the unique edges of its cells, found where the lower vertex of the
   edge has its directory (so every edge is seen by one rank, whichever ranks hold its cells). */
#include <msim/scene.h>
#include <cmath>

namespace {
struct VertexRecord {
  PetscInt  id;
  PetscReal x[3];
};
struct CellRecord {
  PetscInt v[4];
};
/* one edge of one cell, sent to the directory of its lower vertex a */
struct EdgeRecord {
  PetscInt  a, b;
  PetscInt  opposite; /* triangles: the cell's third vertex (bending springs) */
  PetscReal measure;  /* the cell's volume or area */
  PetscReal length;
};
struct ShareRecord {
  PetscInt  id;
  PetscReal share;
};
struct PairRecord {
  PetscInt a, b;
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
    send[k].id = s->vid[k];
    for (int c = 0; c < 3; c++) send[k].x[c] = s->vx[3 * k + c];
  }
  s->vid.clear();
  s->vid.shrink_to_fit();
  s->vx.clear();
  s->vx.shrink_to_fit();
  PetscCall(MSimExchange(comm, dest, send, recv));
  send.clear();
  send.shrink_to_fit();
  const PetscInt start = s->dir.Start(rank), count = s->dir.Count(rank);
  std::vector<char> seen(count, 0);
  s->x0.assign(3 * (size_t)count, 0.0);
  for (const VertexRecord &r : recv) {
    PetscCheck(!seen[r.id - start], PETSC_COMM_SELF, PETSC_ERR_PLIB, "the %s scene made vertex %" PetscInt_FMT " twice", s->name.c_str(), r.id);
    seen[r.id - start] = 1;
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

  PetscFunctionBeginUser;
  for (size_t c = 0; c < nc; c++) {
    dest[c] = s->dir.Owner(s->cells[k * c]);
    for (int q = 0; q < 4; q++) send[c].v[q] = q < k ? s->cells[k * c + q] : -1;
  }
  s->cells.clear();
  s->cells.shrink_to_fit();
  PetscCall(MSimExchange(comm, dest, send, recv));
  s->cells.resize(k * recv.size());
  for (size_t c = 0; c < recv.size(); c++)
    for (int q = 0; q < k; q++) s->cells[k * c + q] = recv[c].v[q];
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Unique ids of the vertices the held cells name, and the cells rewritten as indices into them. */
static void CellVertices(const MSimSceneData *s, std::vector<PetscInt> &ids, std::vector<PetscInt> &local)
{
  ids = s->cells;
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());
  local.resize(s->cells.size());
  for (size_t q = 0; q < s->cells.size(); q++) local[q] = (PetscInt)(std::lower_bound(ids.begin(), ids.end(), s->cells[q]) - ids.begin());
}

PetscErrorCode MSimSceneCellSprings(MPI_Comm comm, MSimSceneData *s)
{
  static const int         tet_edges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}}, tri_edges[3][2] = {{0, 1}, {0, 2}, {1, 2}};
  const int                k = s->cell_size, ne = k == 4 ? 6 : 3;
  const int(*E)[2]         = k == 4 ? tet_edges : tri_edges;
  const size_t             nc = s->cells.size() / k;
  PetscMPIInt              rank;
  std::vector<PetscInt>    ids, local;
  std::vector<PetscReal>   x;
  std::vector<PetscMPIInt> dest;
  std::vector<EdgeRecord>  edges, got;
  std::vector<ShareRecord> shares, gotshares;
  PetscReal                measure = 0;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  CellVertices(s, ids, local);
  PetscCall(MSimSceneFetchPositions(comm, s, ids, x));
  edges.reserve(ne * nc);
  dest.reserve(ne * nc);
  shares.reserve(k * nc);
  for (size_t c = 0; c < nc; c++) {
    const PetscInt *l = &local[k * c], *g = &s->cells[k * c];
    const PetscReal m = k == 4 ? MSimTetVolume(&x[3 * l[0]], &x[3 * l[1]], &x[3 * l[2]], &x[3 * l[3]]) : MSimTriangleArea(&x[3 * l[0]], &x[3 * l[1]], &x[3 * l[2]]);
    measure += m;
    for (int e = 0; e < ne; e++) {
      const int  p = E[e][0], q = E[e][1];
      EdgeRecord r;
      r.a        = std::min(g[p], g[q]);
      r.b        = std::max(g[p], g[q]);
      r.opposite = k == 3 ? g[3 - p - q] : -1;
      r.measure  = m;
      r.length   = std::sqrt((x[3 * l[p]] - x[3 * l[q]]) * (x[3 * l[p]] - x[3 * l[q]]) + (x[3 * l[p] + 1] - x[3 * l[q] + 1]) * (x[3 * l[p] + 1] - x[3 * l[q] + 1]) + (x[3 * l[p] + 2] - x[3 * l[q] + 2]) * (x[3 * l[p] + 2] - x[3 * l[q] + 2]));
      edges.push_back(r);
      dest.push_back(s->dir.Owner(r.a));
    }
    for (int q = 0; q < k; q++) shares.push_back({g[q], m / k});
  }
  PetscCallMPI(MPI_Allreduce(&measure, &s->measure, 1, MPIU_REAL, MPIU_SUM, comm));
  PetscCall(MSimExchange(comm, dest, edges, got));
  edges.clear();
  edges.shrink_to_fit();
  /* the measure shares, summed where the vertex has its directory */
  dest.resize(shares.size());
  for (size_t q = 0; q < shares.size(); q++) dest[q] = s->dir.Owner(shares[q].id);
  PetscCall(MSimExchange(comm, dest, shares, gotshares));
  const PetscInt start = s->dir.Start(rank);
  s->share.assign(s->dir.Count(rank), 0.0);
  for (const ShareRecord &r : gotshares) s->share[r.id - start] += r.share;
  /* one spring per edge; Young's modulus: k = E V_e / L^2. Under any uniform strain eps the
     springs then store sum_e k_e (eps L_e)^2 / 2 = E eps^2 sum_e V_e / 2 = 3 E eps^2 V (each tet
     has 6 edges): the strain energy of an isotropic solid of modulus E and Poisson ratio 1/4 (the
     ratio of a lattice of central springs) dilated by eps. */
  std::sort(got.begin(), got.end(), [](const EdgeRecord &u, const EdgeRecord &v) { return u.a < v.a || (u.a == v.a && (u.b < v.b || (u.b == v.b && u.opposite < v.opposite))); });
  std::vector<PairRecord>  bend;
  std::vector<PetscMPIInt> bdest;
  for (size_t q = 0; q < got.size();) {
    size_t    r  = q;
    PetscReal around = 0;
    while (r < got.size() && got[r].a == got[q].a && got[r].b == got[q].b) around += got[r++].measure;
    s->si.push_back(got[q].a);
    s->sj.push_back(got[q].b);
    s->sL.push_back(got[q].length);
    s->sk.push_back(s->young > 0 ? s->young * around / (got[q].length * got[q].length) : s->k_cell);
    if (s->k_bend > 0 && r - q == 2) {
      const PetscInt c = std::min(got[q].opposite, got[q + 1].opposite), d = std::max(got[q].opposite, got[q + 1].opposite);
      bend.push_back({c, d});
      bdest.push_back(s->dir.Owner(c));
    }
    q = r;
  }
  got.clear();
  got.shrink_to_fit();
  if (s->k_bend > 0) {
    /* one bending spring per pair of opposite vertices, none where an edge already joins them (a
       pair can face two edges, e.g. on a tetrahedron's surface); the edges from c are all here */
    std::vector<PairRecord> pairs;
    PetscCall(MSimExchange(comm, bdest, bend, pairs));
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
