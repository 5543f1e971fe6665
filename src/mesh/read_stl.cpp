/* STL, ASCII ("solid ... facet normal ... outer loop, vertex x y z x3, endloop, endfacet ...
   endsolid") or binary (80-byte header, a 32-bit facet count, 50 bytes per facet). STL repeats
   each vertex in every facet: vertices with bit-identical coordinates are merged, so the surface is
   connected and edges are shared. */
#include <msim/mesh.h>
#include "text_file.h"
#include <cmath>
#include <cstdint>
#include <cstring>
#include <unordered_map>

namespace {
struct Key {
  uint64_t b[3];
  bool operator==(const Key &o) const { return b[0] == o.b[0] && b[1] == o.b[1] && b[2] == o.b[2]; }
};
struct KeyHash {
  size_t operator()(const Key &k) const { return (size_t)(k.b[0] * 0x9E3779B97F4A7C15ull ^ (k.b[1] + 0x632BE59BD9B4E019ull) * 0xBF58476D1CE4E5B9ull ^ k.b[2] * 0x94D049BB133111EBull); }
};

/* Vertex ids by position, in order of first appearance. */
struct Welder {
  std::unordered_map<Key, PetscInt, KeyHash> ids;
  PetscInt Add(MSimMesh *m, const PetscReal p[3], PetscInt line)
  {
    Key k;
    for (int c = 0; c < 3; c++) {
      const double q = p[c] + 0.0; /* -0.0 and 0.0 are the same point */
      memcpy(&k.b[c], &q, sizeof(q));
    }
    auto it = ids.find(k);
    if (it != ids.end()) return it->second;
    const PetscInt v = (PetscInt)ids.size();
    ids.emplace(k, v);
    m->x.insert(m->x.end(), p, p + 3);
    m->vline.push_back(line);
    return v;
  }
};
} // namespace

static PetscErrorCode ReadBinary(const MSimTextFile &tf, uint32_t n, MSimMesh *m)
{
  Welder w;

  PetscFunctionBeginUser;
  m->cell_name = "facet";
  m->cell.resize(3 * (size_t)n);
  m->cline.assign(n, 0); /* binary: messages name the facet */
  w.ids.reserve(n / 2 + 16);
  for (uint32_t f = 0; f < n; f++) {
    const char *rec = tf.data.data() + 84 + 50 * (size_t)f;
    for (int k = 0; k < 3; k++) {
      float     q[3];
      PetscReal p[3];
      memcpy(q, rec + 12 * (k + 1), sizeof(q));
      for (int c = 0; c < 3; c++) {
        PetscCheck(std::isfinite(q[c]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: facet %u (binary, counting from 0): a coordinate is %s", tf.name.c_str(), f, std::isnan(q[c]) ? "NaN" : "infinite");
        p[c] = q[c];
      }
      m->cell[3 * (size_t)f + k] = w.Add(m, p, 0);
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the next line: `word` [`word2`] and ntok tokens in all (0: any number); `what` is the line
   expected, `why` (or "") a reason in parentheses after it */
static PetscErrorCode Expect(MSimTextFile &tf, const char *word, const char *word2, size_t ntok, const char *what, const char *why = "")
{
  PetscFunctionBeginUser;
  PetscCheck(tf.NextLine(0), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends inside a facet, expected '%s'%s (truncated?)", MSIM_AT(tf), what, why);
  PetscCheck(tf.Is(0, word) && (!word2 || tf.Is(1, word2)) && (!ntok || tf.tok.size() == ntok), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": expected '%s'%s, found '%s'", MSIM_AT(tf), what, why, tf.Show(0).c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* n: the facet count a binary header would hold, for the message when the file is neither */
static PetscErrorCode ReadASCII(MSimTextFile &tf, uint32_t n, MSimMesh *m)
{
  Welder w;
  bool   ended = false;

  PetscFunctionBeginUser;
  m->cell_name = "facet";
  PetscCheck(tf.NextLine(0) && tf.Is(0, "solid"), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: not an STL file: ASCII STL starts with 'solid', and a binary STL of %u facets (the count its header would hold) has %llu bytes, not %zu", tf.name.c_str(), n, (unsigned long long)(84 + 50 * (uint64_t)n), tf.data.size());
  while (tf.NextLine(0)) {
    if (tf.Is(0, "endsolid")) {
      ended = true;
      break;
    }
    PetscCheck(tf.Is(0, "facet") && tf.Is(1, "normal") && tf.tok.size() == 5, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": expected 'facet normal nx ny nz' or 'endsolid', found '%s'", MSIM_AT(tf), tf.Show(0).c_str());
    const PetscInt line = tf.line;
    PetscCall(Expect(tf, "outer", "loop", 2, "outer loop"));
    for (int k = 0; k < 3; k++) {
      PetscReal p[3];
      PetscCall(Expect(tf, "vertex", NULL, 0, "vertex x y z"));
      PetscCall(tf.NeedTokens(4, 4, "a facet's vertex (the word vertex and x y z)"));
      for (int c = 0; c < 3; c++) PetscCall(tf.Real(c + 1, "coordinate", &p[c]));
      m->cell.push_back(w.Add(m, p, tf.line));
    }
    PetscCall(Expect(tf, "endloop", NULL, 1, "endloop", " (STL facets are triangles)"));
    PetscCall(Expect(tf, "endfacet", NULL, 1, "endfacet"));
    m->cline.push_back(line);
  }
  PetscCheck(ended, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends without 'endsolid' (truncated?)", MSIM_AT(tf));
  PetscCheck(!tf.NextLine(0), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": text after 'endsolid' (one solid per file)", MSIM_AT(tf));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshReadSTL(const char file[], MSimMesh *m)
{
  MSimTextFile tf;
  uint32_t     n = 0;

  PetscFunctionBeginUser;
  PetscCall(tf.Load(file));
  m->file = file;
  m->nper = 3;
  PetscCheck(!tf.data.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  if (tf.data.size() >= 84) memcpy(&n, tf.data.data() + 80, 4);
  /* a binary STL's size is exact; its 80-byte header may itself begin with "solid" */
  if (tf.data.size() >= 84 && tf.data.size() == 84 + 50 * (uint64_t)n) {
    PetscCheck(n > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: binary STL with no facets", file);
    PetscCheck(n < (uint64_t)PETSC_MAX_INT / 12, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %u facets are too many for this build's indices", file, n);
    PetscCall(ReadBinary(tf, n, m));
  } else PetscCall(ReadASCII(tf, n, m));
  m->nv    = (PetscInt)m->vline.size();
  m->ncell = (PetscInt)(m->cell.size() / 3);
  PetscCheck(m->ncell > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no facets", file);
  PetscFunctionReturn(PETSC_SUCCESS);
}
