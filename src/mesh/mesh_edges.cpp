/* The unique edges of a mesh and what meets at them. Each cell's edges are bucketed by their lower
   vertex, so that sorting happens within a vertex's few neighbours, never across the whole mesh:
   work and memory grow with the number of cells (12 bytes per cell edge, transient). */
#include <msim/mesh.h>
#include <msim/log.h>
#include <algorithm>
#include <cmath>

namespace {
struct Entry {
  PetscInt other, cell;
  bool     operator<(const Entry &e) const { return other < e.other || (other == e.other && cell < e.cell); }
};
const int kTetEdges[6][2] = {{0, 1}, {0, 2}, {0, 3}, {1, 2}, {1, 3}, {2, 3}};
const int kTriEdges[3][2] = {{0, 1}, {0, 2}, {1, 2}};

/* Cell edges bucketed by lower vertex: bucket v is [ptr[v], ptr[v+1]) of ent, sorted. */
struct Buckets {
  std::vector<size_t> ptr;
  std::vector<Entry>  ent;
};

void BuildBuckets(const MSimMesh *m, Buckets &b)
{
  const int nper = m->nper, ne = nper == 4 ? 6 : 3;
  const int(*E)[2] = nper == 4 ? kTetEdges : kTriEdges;
  b.ptr.assign(m->nv + 1, 0);
  for (PetscInt c = 0; c < m->ncell; c++)
    for (int e = 0; e < ne; e++) {
      const PetscInt a = m->cell[(size_t)nper * c + E[e][0]], d = m->cell[(size_t)nper * c + E[e][1]];
      b.ptr[std::min(a, d) + 1]++;
    }
  for (PetscInt v = 0; v < m->nv; v++) b.ptr[v + 1] += b.ptr[v];
  b.ent.resize(b.ptr[m->nv]);
  std::vector<size_t> fill(b.ptr.begin(), b.ptr.end() - 1);
  for (PetscInt c = 0; c < m->ncell; c++)
    for (int e = 0; e < ne; e++) {
      const PetscInt a = m->cell[(size_t)nper * c + E[e][0]], d = m->cell[(size_t)nper * c + E[e][1]];
      b.ent[fill[std::min(a, d)]++] = {std::max(a, d), c};
    }
  for (PetscInt v = 0; v < m->nv; v++) std::sort(b.ent.begin() + b.ptr[v], b.ent.begin() + b.ptr[v + 1]);
}

PetscReal CellMeasure(const MSimMesh *m, PetscInt c)
{
  const PetscInt *id = &m->cell[(size_t)m->nper * c];
  const PetscReal *x = m->x.data();
  return m->nper == 4 ? MSimTetVolume(&x[3 * id[0]], &x[3 * id[1]], &x[3 * id[2]], &x[3 * id[3]]) : MSimTriangleArea(&x[3 * id[0]], &x[3 * id[1]], &x[3 * id[2]]);
}

PetscInt Opposite(const MSimMesh *m, PetscInt c, PetscInt a, PetscInt b)
{
  for (int k = 0; k < 3; k++) {
    const PetscInt v = m->cell[3 * (size_t)c + k];
    if (v != a && v != b) return v;
  }
  return -1;
}
} // namespace

PetscErrorCode MSimMeshEdges(const MSimMesh *m, std::vector<PetscInt> &ei, std::vector<PetscInt> &ej, std::vector<PetscReal> *edge_measure, std::vector<PetscInt> *opposite)
{
  Buckets b;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_MeshEdges, 0, 0, 0, 0));
  BuildBuckets(m, b);
  ei.clear();
  ej.clear();
  if (edge_measure) edge_measure->clear();
  if (opposite) opposite->clear();
  for (PetscInt v = 0; v < m->nv; v++)
    for (size_t q = b.ptr[v]; q < b.ptr[v + 1];) {
      size_t r = q;
      PetscReal meas = 0;
      while (r < b.ptr[v + 1] && b.ent[r].other == b.ent[q].other) {
        if (edge_measure) meas += CellMeasure(m, b.ent[r].cell);
        r++;
      }
      ei.push_back(v);
      ej.push_back(b.ent[q].other);
      if (edge_measure) edge_measure->push_back(meas);
      if (opposite && m->nper == 3 && r - q == 2) {
        opposite->push_back(Opposite(m, b.ent[q].cell, v, b.ent[q].other));
        opposite->push_back(Opposite(m, b.ent[q + 1].cell, v, b.ent[q].other));
      }
      q = r;
    }
  PetscCall(PetscLogEventEnd(MSIM_MeshEdges, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshCheckClosed(const MSimMesh *m)
{
  Buckets b;

  PetscFunctionBeginUser;
  BuildBuckets(m, b);
  for (PetscInt v = 0; v < m->nv; v++)
    for (size_t q = b.ptr[v]; q < b.ptr[v + 1];) {
      size_t r = q;
      while (r < b.ptr[v + 1] && b.ent[r].other == b.ent[q].other) r++;
      if (r - q != 2) {
        const PetscInt c = b.ent[q].cell;
        char           where[64];
        if (m->cline.size() > (size_t)c && m->cline[c] > 0) snprintf(where, sizeof(where), " line %lld", (long long)m->cline[c]);
        else snprintf(where, sizeof(where), " (%s %lld counting from 1)", m->cell_name, (long long)c + 1);
        SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s%s: the surface is not closed: the edge between vertices %lld and %lld is in %zu %s%s (TetGen needs a closed surface, every edge in exactly 2)", m->file.c_str(), where, (long long)v, (long long)b.ent[q].other, r - q, m->cell_name, r - q == 1 ? "" : "s");
      }
      q = r;
    }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshVertexMeasure(const MSimMesh *m, std::vector<PetscReal> &share, PetscReal *total)
{
  PetscFunctionBeginUser;
  share.assign(m->nv, 0.0);
  *total = 0;
  for (PetscInt c = 0; c < m->ncell; c++) {
    const PetscReal meas = CellMeasure(m, c);
    *total += meas;
    for (int k = 0; k < m->nper; k++) share[m->cell[(size_t)m->nper * c + k]] += meas / m->nper;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
