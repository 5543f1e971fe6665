/* Regular refinement of a distributed tet mesh: each tet into 8 (Bey 1995): a new vertex at the
   middle of every edge, 4 corner tets, and the inner octahedron cut into 4 along its shortest
   diagonal. Done by msim rather than DMPlex so that the new vertices get ids that do not depend on
   the rank count or the partition: the vertex on edge (a, b), a < b, is nv + its place among all
   edges in the order of (a, b). Edges are numbered where a has its directory (one rank sees each
   edge; the blocks ascend with a), so outputs, fixed lists and final positions of a refined mesh
   are the same at any rank count. Old vertices keep their ids. */
#include "local_edges.h"
#include <array>
#include <cmath>

namespace {
struct EdgeQuestion {
  PetscInt  a, b;
  PetscReal mid[3];
};
struct MidVertex {
  PetscInt  a, b;
  PetscReal mid[3];
};

PetscReal Dist2(const PetscReal *p, const PetscReal *q)
{
  return (p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2]);
}
} // namespace

PetscErrorCode MSimSceneRefine(MPI_Comm comm, MSimSceneData *s)
{
  static const int          E[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
  const size_t              nt      = s->cells.size() / 4;
  PetscMPIInt               rank, size;
  MSimLocalEdges            LE;
  std::vector<PetscInt>     mids;
  std::vector<PetscReal>    x;
  std::vector<PetscMPIInt>  dest;
  std::vector<EdgeQuestion> questions;
  std::vector<MidVertex>    made;
  PetscInt                  nedge = 0, offset = 0, total = 0;

  PetscFunctionBeginUser;
  PetscCheck(s->cell_size == 4, comm, PETSC_ERR_ARG_WRONG, "-msim_refine refines tets: use it with -msim_scene tet or box");
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(MSimLocalEdgesBuild(s, LE));
  PetscCall(MSimSceneFetchPositions(comm, s, LE.ids, x));
  /* one question per unique edge of this rank's tets */
  questions.resize(LE.a.size());
  dest.resize(LE.a.size());
  for (size_t e = 0; e < LE.a.size(); e++) {
    EdgeQuestion &r = questions[e];
    r.a             = LE.ids[LE.a[e]];
    r.b             = LE.ids[LE.b[e]];
    for (int c = 0; c < 3; c++) r.mid[c] = 0.5 * (x[3 * LE.a[e] + c] + x[3 * LE.b[e] + c]);
    dest[e] = s->dir.Owner(r.a);
  }
  /* the directory of a numbers its unique edges; their ids follow the global order of (a, b) */
  PetscCall(MSimAsk(
    comm, dest, questions,
    [&](const std::vector<EdgeQuestion> &asked, std::vector<PetscInt> &answers) {
      std::vector<size_t> order(asked.size());
      for (size_t k = 0; k < order.size(); k++) order[k] = k;
      std::sort(order.begin(), order.end(), [&](size_t u, size_t v) { return asked[u].a < asked[v].a || (asked[u].a == asked[v].a && asked[u].b < asked[v].b); });
      for (size_t k = 0; k < order.size(); k++) {
        const EdgeQuestion &r = asked[order[k]];
        if (made.empty() || made.back().a != r.a || made.back().b != r.b) made.push_back({r.a, r.b, {r.mid[0], r.mid[1], r.mid[2]}});
        answers[order[k]] = (PetscInt)made.size() - 1; /* local index, made global below */
      }
      nedge = (PetscInt)made.size();
      PetscCallMPI(MPI_Exscan(&nedge, &offset, 1, MPIU_INT, MPI_SUM, comm));
      if (rank == 0) offset = 0;
      PetscCallMPI(MPI_Allreduce(&nedge, &total, 1, MPIU_INT, MPI_SUM, comm));
      PetscCheck((double)s->nv + total < PETSC_MAX_INT / 4, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-msim_refine: %g vertices are too many for this build's %d-bit indices", (double)s->nv + total, (int)(8 * sizeof(PetscInt)));
      for (PetscInt &a : answers) a += s->nv + offset;
      return PETSC_SUCCESS;
    },
    mids));
  questions.clear();
  questions.shrink_to_fit();

  /* the 8 children of each tet, each turned to positive volume */
  std::vector<PetscInt> children;
  children.reserve(32 * nt);
  for (size_t t = 0; t < nt; t++) {
    const PetscInt *v = &s->cells[4 * t], *lv = &LE.local[4 * t];
    PetscInt        m[6]; /* 01 02 03 12 13 23 */
    std::array<PetscReal, 18> mx;
    for (int e = 0; e < 6; e++) {
      m[e] = mids[LE.cell_edge[6 * t + e]];
      for (int c = 0; c < 3; c++) mx[3 * e + c] = 0.5 * (x[3 * lv[E[e][0]] + c] + x[3 * lv[E[e][1]] + c]);
    }
    auto X = [&](int vi, int e) -> const PetscReal * { return e >= 0 ? &mx[3 * e] : &x[3 * lv[vi]]; };
    /* corners, then the octahedron around the shortest of its diagonals 01-23, 02-13, 03-12, each
       with the ring of the other four midpoints in order around it */
    const PetscReal d[3]     = {Dist2(&mx[0], &mx[15]), Dist2(&mx[3], &mx[12]), Dist2(&mx[6], &mx[9])};
    const int       diag     = d[0] <= d[1] && d[0] <= d[2] ? 0 : d[1] <= d[2] ? 1 : 2;
    static const int ends[3][2] = {{0, 5}, {1, 4}, {2, 3}}, ring[3][4] = {{1, 2, 4, 3}, {0, 2, 5, 3}, {0, 1, 5, 4}};
    const int        tets[8][4][2] = {
      /* (vertex index 0-3 or -1, midpoint index 0-5 or -1) */
      {{0, -1}, {-1, 0}, {-1, 1}, {-1, 2}},
      {{-1, 0}, {1, -1}, {-1, 3}, {-1, 4}},
      {{-1, 1}, {-1, 3}, {2, -1}, {-1, 5}},
      {{-1, 2}, {-1, 4}, {-1, 5}, {3, -1}},
      {{-1, ends[diag][0]}, {-1, ends[diag][1]}, {-1, ring[diag][0]}, {-1, ring[diag][1]}},
      {{-1, ends[diag][0]}, {-1, ends[diag][1]}, {-1, ring[diag][1]}, {-1, ring[diag][2]}},
      {{-1, ends[diag][0]}, {-1, ends[diag][1]}, {-1, ring[diag][2]}, {-1, ring[diag][3]}},
      {{-1, ends[diag][0]}, {-1, ends[diag][1]}, {-1, ring[diag][3]}, {-1, ring[diag][0]}},
    };
    for (int c = 0; c < 8; c++) {
      PetscInt         id[4];
      const PetscReal *p[4];
      for (int q = 0; q < 4; q++) {
        const int vi = tets[c][q][0], mi = tets[c][q][1];
        id[q]        = vi >= 0 ? v[vi] : m[mi];
        p[q]         = vi >= 0 ? X(vi, -1) : X(-1, mi);
      }
      if (MSimTetVolume(p[0], p[1], p[2], p[3]) < 0) std::swap(id[1], id[2]);
      children.insert(children.end(), id, id + 4);
    }
  }
  s->cells.swap(children);
  /* the children follow their parent in the scene's order of the cells */
  if (!s->cell_id.empty()) {
    std::vector<PetscInt> ids(8 * nt);
    for (size_t t = 0; t < nt; t++)
      for (int c = 0; c < 8; c++) ids[8 * t + c] = 8 * s->cell_id[t] + c;
    s->cell_id.swap(ids);
  }
  children.clear();
  children.shrink_to_fit();
  LE = MSimLocalEdges();

  /* the vertices under the grown layout: the old ones keep their ids, the new ones follow */
  {
    const PetscInt start = s->dir.Start(rank), count = s->dir.Count(rank);
    s->vid.resize(count + made.size());
    s->vx.resize(3 * s->vid.size());
    for (PetscInt v = 0; v < count; v++) {
      s->vid[v] = start + v;
      for (int c = 0; c < 3; c++) s->vx[3 * v + c] = s->x0[3 * (size_t)v + c];
    }
    for (size_t k = 0; k < made.size(); k++) {
      s->vid[count + k] = s->nv + offset + (PetscInt)k;
      for (int c = 0; c < 3; c++) s->vx[3 * (count + k) + c] = made[k].mid[c];
    }
    if (s->nv_file > 0) { /* file ids: the new vertices numbered on from the file's, as their input ids are */
      s->vfile.assign(s->file_id.begin(), s->file_id.end());
      for (size_t k = 0; k < made.size(); k++) s->vfile.push_back(s->nv_file + offset + (PetscInt)k);
      s->nv_file += total;
    }
    s->x0.clear();
    s->x0.shrink_to_fit();
    s->nv += total;
  }
  PetscCall(MSimSceneToDirectory(comm, s));
  PetscCall(MSimSceneSpreadCells(comm, s));
  PetscFunctionReturn(PETSC_SUCCESS);
}
