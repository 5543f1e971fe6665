/* Wavefront OBJ: "v x y z [w]" vertices, "f i j k ..." faces whose corners are "v", "v/vt",
   "v//vn" or "v/vt/vn" with 1-based or negative (relative) vertex ids. Texture coordinates,
   normals, groups, materials, lines, points, crease tags (t) and the other statements of the
   format are skipped, as common OBJ loaders do, with one note that lists them; anything else is an
   error, so a file that is not OBJ fails on its first line. Vertices no face uses are kept here and
   dropped by MSimMeshDropUnused, so the ids of the others stay the file's. */
#include <msim/mesh.h>
#include "text_file.h"
#include <charconv>
#include <cstring>

/* the statements of the OBJ format that carry nothing msim uses */
static const char *const kSkipped[] = {"vt", "vn", "vp", "t", "vw", "l", "p", "g", "o", "s", "usemtl", "mtllib", "cstype", "deg", "bmat", "step", "curv", "curv2", "surf", "parm", "trim", "hole", "scrv", "sp", "end", "con", "mg", "bevel", "c_interp", "d_interp", "lod", "maplib", "usemap", "shadow_obj", "trace_obj", "ctech", "stech", "call", "csh"};

PetscErrorCode MSimMeshReadOBJ(const char file[], MSimMesh *m)
{
  MSimTextFile          tf;
  std::vector<PetscInt> ids;
  const size_t          nkinds = sizeof kSkipped / sizeof kSkipped[0];
  std::vector<PetscInt> skipped(nkinds, 0); /* lines of each skipped statement, for the note */

  PetscFunctionBeginUser;
  PetscCall(tf.Load(file));
  m->file      = file;
  m->nper      = 3;
  m->cell_name = "face";
  PetscCheck(!tf.data.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  while (tf.NextLine('#')) {
    if (tf.Is(0, "v")) {
      PetscCheck(tf.tok.size() == 4 || tf.tok.size() == 5 || tf.tok.size() == 7, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": a vertex needs x y z (and optionally w, or r g b), found %zu values", MSIM_AT(tf), tf.tok.size() - 1);
      for (int c = 0; c < 3; c++) {
        PetscReal xc;
        PetscCall(tf.Real(c + 1, "coordinate", &xc));
        m->x.push_back(xc);
      }
      m->vline.push_back(tf.line);
      PetscCheck((PetscInt)m->vline.size() < PETSC_MAX_INT / 12, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": too many vertices for this build's indices", MSIM_AT(tf));
    } else if (tf.Is(0, "f")) {
      const PetscInt nv = (PetscInt)m->vline.size();
      PetscCheck(tf.tok.size() >= 4, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": a face needs at least 3 corners, found %zu", MSIM_AT(tf), tf.tok.size() - 1);
      ids.clear();
      for (size_t k = 1; k < tf.tok.size(); k++) {
        const MSimToken &t     = tf.tok[k];
        const char      *slash = (const char *)memchr(t.p, '/', t.n);
        const char      *e     = slash ? slash : t.p + t.n;
        int64_t          id    = 0;
        auto             r     = std::from_chars(t.p, e, id);
        PetscCheck(r.ec == std::errc() && r.ptr == e, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": face corner '%s' is not a vertex id", MSIM_AT(tf), tf.Show(k).c_str());
        /* 1-based; negative ids count back from the last vertex read */
        const int64_t v = id > 0 ? id - 1 : nv + id;
        PetscCheck(id != 0 && v >= 0 && v < nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": face corner %lld names no vertex read so far (%" PetscInt_FMT " vertices; ids are 1-based, or negative counting back)", MSIM_AT(tf), (long long)id, nv);
        ids.push_back((PetscInt)v);
      }
      MSimMeshAddPolygon(m, ids.data(), (PetscInt)ids.size(), tf.line);
    } else {
      size_t kind = 0;
      while (kind < nkinds && !tf.Is(0, kSkipped[kind])) kind++;
      if (kind < nkinds) skipped[kind]++;
      PetscCheck(kind < nkinds, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": '%s' is not an OBJ statement", MSIM_AT(tf), tf.Show(0).c_str());
    }
  }
  m->nv    = (PetscInt)m->vline.size();
  m->ncell = (PetscInt)m->cline.size();
  PetscCheck(m->nv > 0 && m->ncell > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no %s", file, m->nv ? "faces" : "vertices");
  {
    std::string list;
    for (size_t kind = 0; kind < nkinds; kind++)
      if (skipped[kind]) list += (list.empty() ? "" : ", ") + std::string(kSkipped[kind]) + " (" + std::to_string(skipped[kind]) + (skipped[kind] == 1 ? " line)" : " lines)");
    if (!list.empty()) m->notes.push_back(std::string(file) + ": skipped the statements msim has no use for: " + list);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
