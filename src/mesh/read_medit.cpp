/* Medit .mesh, ASCII (INRIA's format, written by libigl, TetGen -g, MMG, IPC's tools): keywords,
   each followed by its count and its records, whitespace-separated on as many lines as the writer
   likes; '#' starts a comment.
     MeshVersionFormatted 1|2|3   (first; 2 and 3 differ from 1 only in their binary form)
     Dimension 3                  (or 2: z = 0)
     Vertices n       then n x (x y [z] ref)
     Triangles n      then n x (v1 v2 v3 ref)         1-based vertex ids; ref: a label, not used
     Quadrilaterals n then n x (v1 v2 v3 v4 ref)      (split into triangles, mesh.h's rule)
     Tetrahedra n     then n x (v1 v2 v3 v4 ref)
     End
   The cells of the highest dimension are kept (tets, else triangles). Sections msim has no use
   for (Edges, Corners, Ridges, Required*, Normals, Tangents, NormalAt*, TangentAt*, Identifier,
   Geometry) are read past, their records counted and checked to be numbers; Hexahedra, Prisms
   and Pyramids are refused by name (their vertex order is not the one msim splits), and so is any
   other keyword, so a file that is not Medit fails where it stops being one. */
#include <msim/mesh.h>
#include "text_file.h"
#include <cstring>

namespace {
/* the file as a stream of tokens across lines */
struct Tokens {
  MSimTextFile tf;
  size_t       k = 0; /* next token of the current line */

  bool More()
  {
    while (k >= tf.tok.size()) {
      if (!tf.NextLine('#')) return false;
      k = 0;
    }
    return true;
  }
  PetscErrorCode Need(const char what[])
  {
    PetscFunctionBeginUser;
    PetscCheck(More(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends where %s should be (truncated, or a count is wrong)", MSIM_AT(tf), what);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* the next token, wherever it stands, read by one of MSimTextFile's Int, Real or Count */
  template <class T>
  PetscErrorCode Next(PetscErrorCode (MSimTextFile::*read)(size_t, const char[], T *) const, const char what[], T *v)
  {
    PetscFunctionBeginUser;
    PetscCall(Need(what));
    PetscCall((tf.*read)(k++, what, v));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Int(const char what[], int64_t *v) { return Next(&MSimTextFile::Int, what, v); }
  PetscErrorCode Real(const char what[], PetscReal *v) { return Next(&MSimTextFile::Real, what, v); }
  PetscErrorCode Count(const char what[], PetscInt *n) { return Next(&MSimTextFile::Count, what, n); }
};

/* sections read past: name, numbers per record (0: Dimension's count of coordinates) */
struct Skipped {
  const char *name;
  int         per;
};
const Skipped kSkipped[] = {{"Edges", 3}, {"Corners", 1}, {"Ridges", 1}, {"RequiredVertices", 1}, {"RequiredEdges", 1}, {"RequiredTriangles", 1}, {"RequiredQuadrilaterals", 1}, {"RequiredTetrahedra", 1}, {"Normals", 0}, {"Tangents", 0}, {"NormalAtVertices", 2}, {"NormalAtTriangleVertices", 3}, {"NormalAtQuadrilateralVertices", 3}, {"TangentAtVertices", 2}, {"TangentAtEdges", 3}};
} // namespace

PetscErrorCode MSimMeshReadMedit(const char file[], MSimMesh *m)
{
  Tokens                t;
  MSimTextFile         &tf  = t.tf;
  int64_t               dim = 0, v;
  bool                  vertices = false;
  std::vector<PetscInt> tri, tet, triline, tetline; /* 0-based ids, and the lines they are on */
  MSimMesh              quad;                        /* scratch: one quadrilateral's triangles */

  PetscFunctionBeginUser;
  PetscCall(tf.Load(file));
  m->file      = file;
  m->cell_name = "element";
  PetscCheck(t.More(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  PetscCheck(tf.Is(0, "MeshVersionFormatted"), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": not a Medit file: an ASCII .mesh starts with MeshVersionFormatted, found '%s'", MSIM_AT(tf), tf.Show(0).c_str());
  t.k++;
  PetscCall(t.Int("the version", &v));
  PetscCheck(v >= 1 && v <= 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": MeshVersionFormatted %lld (1, 2 or 3)", MSIM_AT(tf), (long long)v);
  while (t.More()) {
    const size_t   key = t.k++;
    const PetscInt at  = tf.line;
    if (tf.Is(key, "End")) break;
    if (tf.Is(key, "Dimension")) {
      PetscCheck(!dim, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": Dimension a second time", MSIM_AT(tf));
      PetscCall(t.Int("the dimension", &dim));
      PetscCheck(dim == 2 || dim == 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": Dimension %lld (2 or 3)", MSIM_AT(tf), (long long)dim);
    } else if (tf.Is(key, "Vertices")) {
      PetscInt n;
      PetscCheck(dim, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": Vertices before Dimension", MSIM_AT(tf));
      PetscCheck(!vertices, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": Vertices a second time", MSIM_AT(tf));
      PetscCall(t.Count("the vertex count", &n));
      m->x.reserve(3 * tf.Reserve(n, 2 * (size_t)dim + 2));
      m->vline.reserve(tf.Reserve(n, 2 * (size_t)dim + 2));
      for (PetscInt i = 0; i < n; i++) {
        PetscReal x[3] = {0, 0, 0};
        int64_t   ref;
        PetscCall(t.Need("a vertex (its coordinates and reference)"));
        m->vline.push_back(tf.line);
        for (int c = 0; c < dim; c++) PetscCall(t.Real("coordinate", &x[c]));
        PetscCall(t.Int("vertex reference", &ref));
        m->x.insert(m->x.end(), x, x + 3);
      }
      m->nv    = n;
      vertices = true;
    } else if (tf.Is(key, "Triangles") || tf.Is(key, "Quadrilaterals") || tf.Is(key, "Tetrahedra")) {
      const bool             tets = tf.Is(key, "Tetrahedra");
      const int              per  = tf.Is(key, "Triangles") ? 3 : 4;
      std::vector<PetscInt> &ids = tets ? tet : tri, &lines = tets ? tetline : triline;
      const std::string      what = tets ? "a tet" : per == 3 ? "a triangle" : "a quadrilateral";
      PetscInt               n, id[4];
      PetscCall(t.Count("the element count", &n));
      ids.reserve(ids.size() + (per == 4 && !tets ? 6 : per) * tf.Reserve(n, 2 * per + 2));
      for (PetscInt i = 0; i < n; i++) {
        int64_t ref;
        PetscCall(t.Need((what + " (its vertices and reference)").c_str()));
        const PetscInt line = tf.line;
        for (int q = 0; q < per; q++) {
          int64_t w;
          PetscCall(t.Int("vertex id", &w));
          /* ids are checked against the vertex count once every section is read (Vertices may
             come last); here only against what an index holds */
          PetscCheck(w >= 1 && w <= PETSC_MAX_INT / 12, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s names vertex %lld (ids start at 1)", MSIM_AT(tf), what.c_str(), (long long)w);
          id[q] = (PetscInt)w - 1;
        }
        PetscCall(t.Int("element reference", &ref));
        if (per == 4 && !tets) {
          /* the fan through the smallest corner, as every reader cuts a quadrangle */
          quad.cell.clear();
          quad.cline.clear();
          MSimMeshAddPolygon(&quad, id, 4, line);
          ids.insert(ids.end(), quad.cell.begin(), quad.cell.end());
          lines.insert(lines.end(), quad.cline.begin(), quad.cline.end());
        } else {
          ids.insert(ids.end(), id, id + per);
          lines.push_back(line);
        }
      }
    } else if (tf.Is(key, "Hexahedra") || tf.Is(key, "Prisms") || tf.Is(key, "Pyramids")) {
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": Medit %s: msim reads Medit's Tetrahedra, Triangles and Quadrilaterals (a Gmsh .msh of hexahedra and prisms is split into tets)", file, at, tf.Show(key).c_str());
    } else if (tf.Is(key, "Identifier") || tf.Is(key, "Geometry")) {
      /* a quoted string, possibly of several tokens */
      PetscCall(t.Need("a quoted string"));
      const MSimToken first = tf.tok[t.k++];
      PetscCheck(first.n && first.p[0] == '"', PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": %s needs a quoted string", file, at, tf.Show(key).c_str());
      bool closed = first.n > 1 && first.p[first.n - 1] == '"';
      while (!closed && t.k < tf.tok.size()) {
        const MSimToken &w = tf.tok[t.k++];
        closed             = w.p[w.n - 1] == '"';
      }
      PetscCheck(closed, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the string after %s is not closed on its line", file, at, tf.Show(key).c_str());
    } else {
      const Skipped *s = NULL;
      for (const Skipped &q : kSkipped)
        if (tf.Is(key, q.name)) s = &q;
      PetscCheck(s, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": '%s' is not a Medit section msim knows (it reads Vertices, Triangles, Quadrilaterals and Tetrahedra, and reads past Edges, Corners, Ridges, Required*, Normals, Tangents and their At* sections)", file, at, tf.Show(key).c_str());
      PetscInt n;
      PetscCall(t.Count("the record count", &n));
      const int per = s->per ? s->per : (int)(dim ? dim : 3);
      for (PetscInt i = 0; i < n; i++)
        for (int q = 0; q < per; q++) {
          PetscReal x;
          PetscCall(t.Real(s->name, &x));
        }
    }
  }
  PetscCheck(vertices, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no Vertices section", file);
  const bool             tets  = !tet.empty();
  std::vector<PetscInt> &cells = tets ? tet : tri, &lines = tets ? tetline : triline;
  PetscCheck(!cells.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no Tetrahedra, Triangles or Quadrilaterals", file);
  const int per = tets ? 4 : 3;
  for (size_t k = 0; k < cells.size(); k++) PetscCheck(cells[k] < m->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the %s names vertex %lld, outside [1, %lld]", file, lines[k / per], tets ? "tet" : "element", (long long)cells[k] + 1, (long long)m->nv);
  m->nper      = per;
  m->cell_name = tets ? "tet" : "element";
  m->cell.swap(cells);
  m->cline.swap(lines);
  m->ncell = (PetscInt)m->cline.size();
  PetscFunctionReturn(PETSC_SUCCESS);
}
