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
  /* higher-order elements (Gmsh's element types), named so that the message says why */
  case 8: return {0, 1, "second-order line (3 nodes)"};
  case 9: return {0, 2, "second-order triangle (6 nodes)"};
  case 10: return {0, 2, "second-order quadrangle (9 nodes)"};
  case 11: return {0, 3, "second-order tetrahedron (10 nodes)"};
  case 12: return {0, 3, "second-order hexahedron (27 nodes)"};
  case 13: return {0, 3, "second-order prism (18 nodes)"};
  case 14: return {0, 3, "second-order pyramid (14 nodes)"};
  case 16: return {0, 2, "second-order quadrangle (8 nodes)"};
  case 17: return {0, 3, "second-order hexahedron (20 nodes)"};
  case 18: return {0, 3, "second-order prism (15 nodes)"};
  case 19: return {0, 3, "second-order pyramid (13 nodes)"};
  case 20: return {0, 2, "third-order triangle (9 nodes)"};
  case 21: return {0, 2, "third-order triangle (10 nodes)"};
  case 26: return {0, 1, "third-order line (4 nodes)"};
  case 29: return {0, 3, "third-order tetrahedron (20 nodes)"};
  default: return {0, 0, NULL};
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
    types_.clear();
    cells_.clear();
    cwhere_.clear();
  }
  if (type == 7) return false;
  types_.push_back((int8_t)type);
  cells_.insert(cells_.end(), nodes, nodes + g.nodes);
  cwhere_.push_back(where);
  return true;
}

PetscErrorCode MSimGmshMesh::Finish(const char file[], MSimMesh *m)
{
  const char *unit = lines_ ? "line" : "byte";

  PetscFunctionBeginUser;
  PetscCheck(top_ >= 2, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no tets or triangles (elements of dimension %d at most)", file, top_);
  m->file        = file;
  m->cell_name   = "element";
  m->vertex_name = "nodes";
  m->nper        = top_ == 3 ? 4 : 3;
  /* every node, in the file's order: its id is its place in $Nodes */
  m->nv = (PetscInt)xwhere_.size();
  m->x.swap(x_);
  m->vline.assign(m->nv, 0); /* 0: no line to name (mesh.h) */
  if (lines_)
    for (PetscInt v = 0; v < m->nv; v++) m->vline[v] = (PetscInt)xwhere_[v];
  m->cell.clear();
  m->cline.clear();
  size_t k = 0;
  for (size_t e = 0; e < types_.size(); e++) {
    const MSimGmshType g     = MSimGmshTypeOf(types_[e]);
    const PetscInt     where = lines_ ? (PetscInt)cwhere_[e] : 0;
    PetscInt           id[8];
    for (int q = 0; q < g.nodes; q++, k++) {
      auto it = index_.find(cells_[k]);
      PetscCheck(it != index_.end(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s %s %lld: node %lld is not in $Nodes", file, unit, (long long)cwhere_[e], (long long)cells_[k]);
      id[q] = it->second;
    }
    switch (types_[e]) {
    case 2:
    case 4:
      m->cell.insert(m->cell.end(), id, id + g.nodes);
      m->cline.push_back(where);
      break;
    case 3: MSimMeshAddPolygon(m, id, 4, where); break;
    case 5: MSimMeshAddHexahedron(m, id, where); break;
    case 6: MSimMeshAddPrism(m, id, where); break;
    }
  }
  m->ncell = (PetscInt)m->cline.size();
  PetscFunctionReturn(PETSC_SUCCESS);
}
