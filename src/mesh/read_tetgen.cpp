/* TetGen's .node and .ele files (TetGen manual, section 5.2):
     .node: "<points> <dimension = 3> <attributes> <boundary markers 0|1>", then per point
            "<id> <x> <y> <z> [attributes] [marker]";
     .ele:  "<tets> <nodes per tet = 4> <attributes>", then per tet "<id> <n1> <n2> <n3> <n4>
            [attributes]".
   Ids start at 0 or 1 (the first point's id decides, for both files) and run consecutively. '#'
   starts a comment. Attributes and markers are read past. */
#include <msim/mesh.h>
#include "text_file.h"
#include <cstring>

/* The two file names from either one (or their stem). */
static void TetGenNames(const char file[], std::string &node, std::string &ele)
{
  std::string f(file), stem = f;
  auto        ends = [&](const char *suffix) { size_t n = strlen(suffix); return f.size() >= n && f.compare(f.size() - n, n, suffix) == 0; };
  if (ends(".node")) stem = f.substr(0, f.size() - 5);
  else if (ends(".ele")) stem = f.substr(0, f.size() - 4);
  node = stem + ".node";
  ele  = stem + ".ele";
}

static PetscErrorCode ReadNodes(const char file[], MSimMesh *m, int64_t *base)
{
  MSimTextFile tf;
  PetscInt     nv;
  int64_t      dim, nattr, nmark, id;

  PetscFunctionBeginUser;
  PetscCall(tf.Load(file));
  PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  {
    /* a point line "id x y z ..." where the header should be: its second value is a coordinate,
       not the dimension 3 (a header of 4 values has 3 there) */
    const bool header = tf.tok.size() >= 2 && tf.tok.size() <= 4 && tf.IsInt(1) && (tf.tok.size() < 4 || tf.Is(1, "3"));
    PetscCheck(header || !(tf.tok.size() >= 4 && tf.IsReal(1)), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the header line is missing: a .node file starts with '<points> 3 <attributes> <boundary markers>', and this line looks like a point (id x y z)", MSIM_AT(tf));
  }
  PetscCall(tf.NeedTokens(2, 4, "the header (points, dimension, attributes, boundary markers)"));
  PetscCall(tf.Count(0, "point count", &nv));
  PetscCall(tf.Int(1, "dimension", &dim));
  nattr = nmark = 0;
  if (tf.tok.size() > 2) PetscCall(tf.Int(2, "attribute count", &nattr));
  if (tf.tok.size() > 3) PetscCall(tf.Int(3, "boundary marker flag", &nmark));
  PetscCheck(dim == 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": dimension %lld (msim reads 3-D meshes)", MSIM_AT(tf), (long long)dim);
  PetscCheck(nattr >= 0 && nattr <= 1000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": attribute count %lld is not in [0, 1000]", MSIM_AT(tf), (long long)nattr);
  PetscCheck(nmark == 0 || nmark == 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the boundary marker flag is %lld (0 or 1)", MSIM_AT(tf), (long long)nmark);
  PetscCheck(nv > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": no points", MSIM_AT(tf));
  m->x.reserve(3 * tf.Reserve(nv, 8));
  m->vline.reserve(tf.Reserve(nv, 8));
  const size_t ntok = 4 + (size_t)nattr + (size_t)nmark;
  for (PetscInt v = 0; v < nv; v++) {
    PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends after %" PetscInt_FMT " of %" PetscInt_FMT " points (truncated, or the count is wrong)", MSIM_AT(tf), v, nv);
    PetscCall(tf.NeedTokens(ntok, ntok, "a point (id, x, y, z, attributes, marker as the header says)"));
    PetscCall(tf.Int(0, "point id", &id));
    if (v == 0) {
      PetscCheck(id == 0 || id == 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the first point's id is %lld (ids start at 0 or 1)", MSIM_AT(tf), (long long)id);
      *base = id;
    }
    PetscCheck(id == v + *base, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": point id %lld out of sequence (expected %lld)", MSIM_AT(tf), (long long)id, (long long)(v + *base));
    for (int c = 0; c < 3; c++) {
      PetscReal xc;
      PetscCall(tf.Real(1 + c, "coordinate", &xc));
      m->x.push_back(xc);
    }
    for (size_t k = 4; k < ntok; k++) {
      PetscReal a;
      PetscCall(tf.Real(k, k < 4 + (size_t)nattr ? "attribute" : "boundary marker", &a));
    }
    m->vline.push_back(tf.line);
  }
  m->nv = nv;
  PetscCheck(!tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": more lines than the %" PetscInt_FMT " points the header announces", MSIM_AT(tf), nv);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode ReadElements(const char file[], int64_t base, MSimMesh *m)
{
  MSimTextFile tf;
  PetscInt     nt;
  int64_t      nper, nattr = 0, id;

  PetscFunctionBeginUser;
  PetscCall(tf.Load(file));
  PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  PetscCall(tf.NeedTokens(2, 3, "the header (tets, nodes per tet, attributes)"));
  PetscCall(tf.Count(0, "tet count", &nt));
  PetscCall(tf.Int(1, "nodes per tet", &nper));
  if (tf.tok.size() > 2) PetscCall(tf.Int(2, "attribute count", &nattr));
  PetscCheck(nper == 4, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %lld nodes per tet (msim reads linear tets, 4 nodes)", MSIM_AT(tf), (long long)nper);
  PetscCheck(nattr >= 0 && nattr <= 1000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": attribute count %lld is not in [0, 1000]", MSIM_AT(tf), (long long)nattr);
  PetscCheck(nt > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": no tets", MSIM_AT(tf));
  m->cell.reserve(4 * tf.Reserve(nt, 10));
  m->cline.reserve(tf.Reserve(nt, 10));
  const size_t ntok = 5 + (size_t)nattr;
  for (PetscInt t = 0; t < nt; t++) {
    PetscCheck(tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends after %" PetscInt_FMT " of %" PetscInt_FMT " tets (truncated, or the count is wrong)", MSIM_AT(tf), t, nt);
    PetscCall(tf.NeedTokens(ntok, ntok, "a tet (id, 4 point ids, attributes as the header says)"));
    PetscCall(tf.Int(0, "tet id", &id));
    PetscCheck(id == t + base, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": tet id %lld out of sequence (expected %lld: ids start where the .node file's do)", MSIM_AT(tf), (long long)id, (long long)(t + base));
    for (int k = 0; k < 4; k++) {
      int64_t v;
      PetscCall(tf.Int(1 + k, "point id", &v));
      PetscCheck(v >= base && v < m->nv + base, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": tet %lld names point %lld, outside [%lld, %lld]", MSIM_AT(tf), (long long)id, (long long)v, (long long)base, (long long)(m->nv - 1 + base));
      m->cell.push_back((PetscInt)(v - base));
    }
    for (size_t k = 5; k < ntok; k++) {
      PetscReal a;
      PetscCall(tf.Real(k, "attribute", &a));
    }
    m->cline.push_back(tf.line);
  }
  m->ncell = nt;
  PetscCheck(!tf.NextLine('#'), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": more lines than the %" PetscInt_FMT " tets the header announces", MSIM_AT(tf), nt);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshReadTetGen(const char file[], MSimMesh *m)
{
  std::string node, ele;
  int64_t     base = 0;

  PetscFunctionBeginUser;
  TetGenNames(file, node, ele);
  m->nper        = 4;
  m->cell_name   = "tet";
  m->vertex_name = "points";
  PetscCall(ReadNodes(node.c_str(), m, &base));
  PetscCall(ReadElements(ele.c_str(), base, m));
  m->file        = ele;
  m->vertex_file = node;
  PetscFunctionReturn(PETSC_SUCCESS);
}
