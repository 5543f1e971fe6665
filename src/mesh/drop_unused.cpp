/* The one place where vertices no cell uses leave a mesh: points, curves and surfaces of a Gmsh
   model carry nodes of their own, OBJ exports hold loose vertices. Readers keep every vertex, so
   the ids users type stay the file's order whatever is dropped; the kept vertices keep their order
   and learn their file ids here. */
#include <msim/mesh.h>

PetscErrorCode MSimMeshDropUnused(MSimMesh *m)
{
  std::vector<PetscInt> to(m->nv, -1);
  PetscInt              kept = 0;

  PetscFunctionBeginUser;
  for (size_t k = 0; k < m->cell.size(); k++) {
    const PetscInt v = m->cell[k];
    if (v < 0 || v >= m->nv) {
      const PetscInt c = (PetscInt)(k / m->nper), line = (size_t)c < m->cline.size() ? m->cline[c] : 0;
      if (line > 0) SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the %s names vertex %" PetscInt_FMT ", outside [0, %" PetscInt_FMT "]", m->file.c_str(), line, m->cell_name, v, m->nv - 1);
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %s %" PetscInt_FMT " (counting from 1) names vertex %" PetscInt_FMT ", outside [0, %" PetscInt_FMT "]", m->file.c_str(), m->cell_name, c + 1, v, m->nv - 1);
    }
    to[v] = 0;
  }
  for (PetscInt v = 0; v < m->nv; v++)
    if (!to[v]) to[v] = kept++;
  const PetscInt dropped = m->nv - kept;
  if (m->nv_file < m->nv) m->nv_file = m->nv;
  if (!dropped) PetscFunctionReturn(PETSC_SUCCESS);
  /* in place: a kept vertex only moves down */
  std::vector<PetscInt> file_id(kept);
  for (PetscInt v = 0; v < m->nv; v++) {
    const PetscInt w = to[v];
    if (w < 0) continue;
    file_id[w] = MSimMeshFileId(m, v);
    for (int c = 0; c < 3; c++) m->x[3 * (size_t)w + c] = m->x[3 * (size_t)v + c];
    if ((size_t)v < m->vline.size()) m->vline[w] = m->vline[v];
  }
  for (PetscInt &v : m->cell) v = to[v];
  m->x.resize(3 * (size_t)kept);
  if (m->vline.size() > (size_t)kept) m->vline.resize(kept);
  m->file_id.swap(file_id);
  {
    /* "FILE: 389 of 1140 nodes belong to no tet and are dropped" */
    const std::string &f = m->vertex_file.empty() ? m->file : m->vertex_file;
    const char        *cell = m->nper == 4 ? "tet" : m->cell_name;
    char               buf[256];
    snprintf(buf, sizeof buf, ": %lld of %lld %s belong%s to no %s and %s dropped (%s unused)", (long long)dropped, (long long)m->nv, m->vertex_name, dropped == 1 ? "s" : "", cell, dropped == 1 ? "is" : "are", dropped == 1 ? "its id stays" : "their ids stay");
    m->notes.push_back(f + buf);
  }
  m->nv = kept;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshPrintNotes(const MSimMesh *m)
{
  PetscFunctionBeginUser;
  for (const std::string &n : m->notes) PetscCall(PetscFPrintf(PETSC_COMM_SELF, PETSC_STDERR, "msim: note: %s\n", n.c_str()));
  PetscFunctionReturn(PETSC_SUCCESS);
}
