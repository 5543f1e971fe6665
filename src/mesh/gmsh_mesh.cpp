#include "gmsh_mesh.h"

MSimGmshType MSimGmshTypeOf(int64_t t)
{
  switch (t) {
  case 1: return {2, 1, "line"};
  case 2: return {3, 2, "triangle"};
  case 3: return {4, 2, "quadrangle"};
  case 4: return {4, 3, "tetrahedron"};
  case 5: return {8, 3, "hexahedron"};
  case 6: return {6, 3, "prism"};
  case 7: return {5, 3, "pyramid"};
  case 15: return {1, 0, "point"};
  default: return {0, 0, ""};
  }
}

bool MSimGmshMesh::AddNode(int64_t tag, const PetscReal x[3], int64_t where)
{
  if (!index_.emplace(tag, (PetscInt)xwhere_.size()).second) return false;
  x_.insert(x_.end(), x, x + 3);
  xwhere_.push_back(where);
  return true;
}

bool MSimGmshMesh::AddElement(int64_t type, const int64_t *nodes, int64_t where)
{
  const MSimGmshType g = MSimGmshTypeOf(type);

  if (g.dim < top_) return true;
  if (g.dim > top_) { /* a higher dimension: what came before were its faces, edges or points */
    top_ = g.dim;
    cells_.clear();
    cwhere_.clear();
  }
  if (g.dim >= 2 && type != (g.dim == 3 ? 4 : 2)) return false;
  nper_ = g.nodes;
  cells_.insert(cells_.end(), nodes, nodes + g.nodes);
  cwhere_.push_back(where);
  return true;
}

PetscErrorCode MSimGmshMesh::Finish(const char file[], MSimMesh *m)
{
  const char *unit = lines_ ? "line" : "byte";

  PetscFunctionBeginUser;
  PetscCheck(top_ >= 2, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no tets or triangles (elements of dimension %d at most)", file, top_);
  /* the nodes the kept elements use, in the file's order */
  const PetscInt        nall = (PetscInt)xwhere_.size();
  std::vector<PetscInt> to(nall, -1), at(cells_.size());
  for (size_t k = 0; k < cells_.size(); k++) {
    auto it = index_.find(cells_[k]);
    PetscCheck(it != index_.end(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s %s %lld: node %lld is not in $Nodes", file, unit, (long long)cwhere_[k / nper_], (long long)cells_[k]);
    at[k]          = it->second;
    to[it->second] = 0;
  }
  m->file      = file;
  m->cell_name = "element";
  m->nper      = nper_;
  m->nv        = 0;
  m->x.clear();
  m->vline.clear();
  for (PetscInt v = 0; v < nall; v++)
    if (!to[v]) {
      to[v] = m->nv++;
      m->x.insert(m->x.end(), x_.begin() + 3 * v, x_.begin() + 3 * v + 3);
      m->vline.push_back(lines_ ? (PetscInt)xwhere_[v] : 0); /* 0: no line to name (mesh.h) */
    }
  m->ncell = (PetscInt)cwhere_.size();
  m->cell.resize(cells_.size());
  for (size_t k = 0; k < cells_.size(); k++) m->cell[k] = to[at[k]];
  m->cline.assign(m->ncell, 0);
  if (lines_)
    for (PetscInt c = 0; c < m->ncell; c++) m->cline[c] = (PetscInt)cwhere_[c];
  PetscFunctionReturn(PETSC_SUCCESS);
}
