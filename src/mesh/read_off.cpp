/* OFF (Object File Format): "OFF" (or a variant such as COFF, NOFF), then "nv nf ne", nv vertex
   lines (x y z, anything after the third number ignored: colours, normals), nf face lines
   "n v1 ... vn" (anything after the n ids ignored: colours), 0-based ids. '#' starts a comment. */
#include <msim/mesh.h>
#include "text_file.h"
#include <cstring>

PetscErrorCode MSimMeshReadOFF(const char file[], MSimMesh *m)
{
  MSimTextFile          tf;
  PetscInt              nv, nf;
  size_t                first = 1;
  std::vector<PetscInt> ids;

  PetscFunctionBeginUser;
  PetscCall(tf.Load(file));
  m->file      = file;
  m->nper      = 3;
  m->cell_name = "face";
  PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  {
    const MSimToken &h = tf.tok[0];
    PetscCheck(h.n >= 3 && !strncmp(h.p + h.n - 3, "OFF", 3), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": not an OFF file (it must start with OFF, found '%s')", MSIM_AT(tf), tf.Show(0).c_str());
  }
  if (tf.tok.size() == 1) { /* counts on a line of their own, as usual */
    PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends before the counts line (nv nf ne)", MSIM_AT(tf));
    first = 0;
  }
  PetscCheck(tf.tok.size() == first + 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the counts line needs 3 values (vertices faces edges), found %zu", MSIM_AT(tf), tf.tok.size() - first);
  PetscCall(tf.Count(first, "vertex count", &nv));
  PetscCall(tf.Count(first + 1, "face count", &nf));
  PetscCheck(nv > 0 && nf > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": no %s (%" PetscInt_FMT " vertices, %" PetscInt_FMT " faces)", MSIM_AT(tf), nv ? "faces" : "vertices", nv, nf);
  m->x.reserve(3 * tf.Reserve(nv, 6));
  m->vline.reserve(tf.Reserve(nv, 6));
  for (PetscInt v = 0; v < nv; v++) {
    PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends after %" PetscInt_FMT " of %" PetscInt_FMT " vertices (truncated, or the counts are wrong)", MSIM_AT(tf), v, nv);
    PetscCheck(tf.tok.size() >= 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": vertex %" PetscInt_FMT " needs 3 coordinates, found %zu", MSIM_AT(tf), v, tf.tok.size());
    for (int c = 0; c < 3; c++) {
      PetscReal xc;
      PetscCall(tf.Real(c, "coordinate", &xc));
      m->x.push_back(xc);
    }
    m->vline.push_back(tf.line);
  }
  m->nv = nv;
  m->cell.reserve(3 * tf.Reserve(nf, 8));
  for (PetscInt f = 0; f < nf; f++) {
    int64_t n, id;
    PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends after %" PetscInt_FMT " of %" PetscInt_FMT " faces (truncated, or the counts are wrong)", MSIM_AT(tf), f, nf);
    PetscCall(tf.Int(0, "corner count", &n));
    PetscCheck(n >= 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": face %" PetscInt_FMT " has %lld corners (a face needs at least 3)", MSIM_AT(tf), f, (long long)n);
    PetscCheck((size_t)n + 1 <= tf.tok.size(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": face %" PetscInt_FMT " announces %lld corners but lists %zu", MSIM_AT(tf), f, (long long)n, tf.tok.size() - 1);
    ids.resize(n);
    for (int64_t k = 0; k < n; k++) {
      PetscCall(tf.Int(k + 1, "vertex id", &id));
      PetscCheck(id >= 0 && id < nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": face %" PetscInt_FMT " names vertex %lld, outside [0, %" PetscInt_FMT "]", MSIM_AT(tf), f, (long long)id, nv - 1);
      ids[k] = (PetscInt)id;
    }
    MSimMeshAddPolygon(m, ids.data(), (PetscInt)n, tf.line);
  }
  PetscCheck(!tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": more lines than the %" PetscInt_FMT " vertices and %" PetscInt_FMT " faces the header announces", MSIM_AT(tf), nv, nf);
  m->ncell = (PetscInt)m->cline.size();
  PetscFunctionReturn(PETSC_SUCCESS);
}
