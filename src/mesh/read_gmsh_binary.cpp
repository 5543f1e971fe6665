/* Gmsh binary .msh, versions 2.2 and 4.1, read by msim itself: PETSc 3.18's reader corrupted
   memory on malformed binary files under fuzzing (runs/fuzz/README.md). Every count is held
   against the bytes left in the file before anything is reserved, and a fault names the file and
   the byte offset where it lies (a binary file has no lines).
   Section names, the format line and 2.2's counts are text lines; the records are binary in the
   byte order that the integer 1 after the format line shows (the other order is swapped):
     2.2 (data size 8: doubles): $Nodes: "n" line, then n x (int tag, 3 doubles); $Elements:
          "n" line, then blocks (int type, int count, int ntags) of count x (int tag, ntags ints,
          the type's node ints).
     4.1 (data size: sizeof(size_t), 4 or 8): $Nodes: 4 size_t (blocks, nodes, min, max tag), per
          block 3 ints (dim, entity, parametric) and size_t n, n size_t tags, n x (3 doubles and
          dim more when parametric); $Elements: 4 size_t, per block 3 ints (dim, entity, type) and
          size_t n, then n x (1 + the type's nodes) size_t.
   Other sections ($Entities, $PhysicalNames, ...) are skipped to their end line. What is kept:
   gmsh_mesh.h (hexahedra and prisms become tets, quadrangles triangles; pyramids and higher-order
   elements are refused by name). */
#include <msim/mesh.h>
#include "gmsh_mesh.h"
#include "text_file.h"
#include <cerrno>
#include <cmath>
#include <cstring>

namespace {
struct Bytes {
  const char *file;
  std::string data;
  size_t      pos     = 0;
  bool        swap    = false;
  int         size_t_ = 8;  /* bytes of a size_t record (4.1's data size) */
  const char *section = ""; /* for messages */

  size_t Left() const { return data.size() - pos; }
  PetscErrorCode Need(size_t bytes, const char what[])
  {
    PetscFunctionBeginUser;
    PetscCheck(bytes <= Left(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the file ends inside %s, in %s (truncated)", file, pos, section, what);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  template <class T>
  T Take()
  {
    unsigned char b[sizeof(T)];
    T             v;
    memcpy(b, data.data() + pos, sizeof b);
    if (swap)
      for (size_t i = 0; i < sizeof b / 2; i++) std::swap(b[i], b[sizeof b - 1 - i]);
    memcpy(&v, b, sizeof v);
    pos += sizeof v;
    return v;
  }
  PetscErrorCode Int(const char what[], int64_t *v)
  {
    PetscFunctionBeginUser;
    PetscCall(Need(4, what));
    *v = Take<int32_t>();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Size(const char what[], uint64_t *v)
  {
    PetscFunctionBeginUser;
    PetscCall(Need(size_t_, what));
    *v = size_t_ == 8 ? Take<uint64_t>() : Take<uint32_t>();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* a tag stored as size_t: Gmsh's tags are positive and below 2^63 */
  PetscErrorCode Tag(const char what[], int64_t *v)
  {
    uint64_t u;

    PetscFunctionBeginUser;
    PetscCall(Size(what, &u));
    PetscCheck(u <= (uint64_t)INT64_MAX, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: %s %llu is out of range", file, pos - size_t_, what, (unsigned long long)u);
    *v = (int64_t)u;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Real(PetscReal *v)
  {
    PetscFunctionBeginUser;
    PetscCall(Need(8, "a coordinate"));
    const double d = Take<double>();
    PetscCheck(std::isfinite(d), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: coordinate %g is not finite", file, pos - 8, d);
    *v = (PetscReal)d;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* A count (read at byte `at`) of records of at least `bytes` each: no more than the rest of the
     file can hold (so a corrupt count never allocates) and small enough for this build's indices. */
  PetscErrorCode Count(size_t at, uint64_t n, size_t bytes, const char what[], PetscInt *count) const
  {
    PetscFunctionBeginUser;
    PetscCheck(n <= Left() / bytes && n <= (uint64_t)PETSC_MAX_INT, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: %s %llu is more than the rest of the file holds (a corrupt or truncated file)", file, at, what, (unsigned long long)n);
    *count = (PetscInt)n;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* The next text line after any blank space (section names, 2.2's counts), its trailing space
     cut; false at the end of the file. */
  bool TextLine(std::string *s)
  {
    while (pos < data.size() && isspace((unsigned char)data[pos])) pos++;
    if (pos == data.size()) return false;
    size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) eol = data.size();
    s->assign(data, pos, eol - pos);
    while (!s->empty() && isspace((unsigned char)s->back())) s->pop_back();
    pos = eol;
    return true;
  }
  /* past the newline that ends a text line, where binary records start */
  void SkipNewline()
  {
    if (pos < data.size()) pos++;
  }
  /* a text line shown safely in a message */
  static std::string Show(const std::string &s) { return MSimShowBytes(s.data(), s.size()); }
  PetscErrorCode End(const char word[])
  {
    std::string s;
    size_t      at;

    PetscFunctionBeginUser;
    at = pos;
    PetscCheck(TextLine(&s) && s == word, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: '%s' where %s should be (a count is wrong)", file, at, Show(s).c_str(), word);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
};

struct Reader {
  Bytes        in;
  MSimGmshMesh mesh{false};
  double       version = 0;

  PetscErrorCode Node(int64_t tag, size_t at, const PetscReal x[3])
  {
    PetscFunctionBeginUser;
    PetscCheck(mesh.AddNode(tag, x, (int64_t)at), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: node %lld appears twice", in.file, at, (long long)tag);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Element(int64_t type, const int64_t *v, size_t at)
  {
    PetscFunctionBeginUser;
    PetscCheck(mesh.AddElement(type, v, (int64_t)at), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: a pyramid (element type 7): msim splits hexahedra and prisms into tets, not pyramids", in.file, at);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Type(int64_t type, size_t at, MSimGmshType *g)
  {
    PetscFunctionBeginUser;
    *g = MSimGmshTypeOf(type);
    PetscCheck(g->nodes || !g->name, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: a %s (element type %lld): " MSIM_GMSH_READS, in.file, at, g->name, (long long)type);
    PetscCheck(g->nodes, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: element type %lld: " MSIM_GMSH_READS, in.file, at, (long long)type);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* 2.2's counts are a text line */
  PetscErrorCode TextCount(const char what[], PetscInt *n)
  {
    std::string s;
    char       *end;

    PetscFunctionBeginUser;
    const size_t at = in.pos;
    PetscCheck(in.TextLine(&s), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the file ends before the %s", in.file, at, what);
    errno                 = 0;
    const long long value = strtoll(s.c_str(), &end, 10);
    PetscCheck(!s.empty() && !*end && !errno && value >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: '%s' is not a %s", in.file, at, Bytes::Show(s).c_str(), what);
    in.SkipNewline();
    PetscCall(in.Count(at, (uint64_t)value, 1, what, n));
    PetscFunctionReturn(PETSC_SUCCESS);
  }

  PetscErrorCode Format()
  {
    std::string s;
    int         type = -1, size = 0;

    PetscFunctionBeginUser;
    const size_t at = in.pos;
    PetscCheck(in.TextLine(&s) && sscanf(s.c_str(), "%lf %d %d", &version, &type, &size) == 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the format line (version, file type, data size) expected", in.file, at);
    PetscCheck(type == 1 && (version == 2.2 || version == 4.1), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: a binary file of version 2.2 or 4.1 expected here (Gmsh writes 4.1 with -format msh41)", in.file, at);
    PetscCheck(version == 4.1 ? size == 4 || size == 8 : size == 8, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: data size %d (%s)", in.file, at, size, version == 4.1 ? "4 or 8: the bytes of a size_t" : "8: the bytes of a double");
    in.size_t_ = size;
    in.SkipNewline();
    PetscCall(in.Need(4, "the byte-order mark (the integer 1)"));
    uint32_t one;
    memcpy(&one, in.data.data() + in.pos, 4);
    PetscCheck(one == 1 || one == 0x01000000u, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the byte-order mark is %u, not 1 in either byte order", in.file, in.pos, one);
    in.swap = one != 1;
    in.pos += 4;
    PetscCall(in.End("$EndMeshFormat"));
    PetscFunctionReturn(PETSC_SUCCESS);
  }

  PetscErrorCode Nodes()
  {
    PetscReal x[3], skip;
    PetscInt  n = 0;

    PetscFunctionBeginUser;
    if (version < 3) {
      const size_t at = in.pos;
      PetscCall(TextCount("node count", &n));
      PetscCall(in.Count(at, (uint64_t)n, 28, "node count", &n));
      mesh.ReserveNodes((size_t)n);
      for (PetscInt v = 0; v < n; v++) {
        int64_t      tag = 0;
        const size_t at = in.pos;
        PetscCall(in.Int("a node tag", &tag));
        for (int c = 0; c < 3; c++) PetscCall(in.Real(&x[c]));
        PetscCall(Node(tag, at, x));
      }
    } else {
      uint64_t head[4] = {0, 0, 0, 0};
      PetscInt blocks = 0, total = 0, seen = 0;
      const size_t at = in.pos;
      for (uint64_t &h : head) PetscCall(in.Size("the $Nodes header", &h));
      PetscCall(in.Count(at, head[0], 12 + in.size_t_, "block count", &blocks));
      PetscCall(in.Count(at + in.size_t_, head[1], in.size_t_ + 24, "node count", &total));
      mesh.ReserveNodes((size_t)total);
      for (PetscInt b = 0; b < blocks; b++) {
        int64_t      dim = 0, entity, param = 0;
        uint64_t     count = 0;
        const size_t at = in.pos;
        PetscCall(in.Int("a node block header", &dim));
        PetscCall(in.Int("a node block header", &entity));
        PetscCall(in.Int("a node block header", &param));
        PetscCall(in.Size("a node block header", &count));
        PetscCheck(dim >= 0 && dim <= 3 && (param == 0 || param == 1), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: entity dimension %lld and parametric flag %lld (0-3 and 0 or 1)", in.file, at, (long long)dim, (long long)param);
        PetscCheck(count <= (uint64_t)(total - seen), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the blocks hold more nodes than the %" PetscInt_FMT " the header announces", in.file, at, total);
        const size_t extra = param ? (size_t)dim : 0;
        PetscCall(in.Count(at + 12, count, in.size_t_ + 8 * (3 + extra), "nodes in the block", &n));
        std::vector<int64_t> tags(n);
        for (int64_t &tag : tags) PetscCall(in.Tag("node tag", &tag));
        for (PetscInt v = 0; v < n; v++) {
          const size_t where = in.pos;
          for (int c = 0; c < 3; c++) PetscCall(in.Real(&x[c]));
          for (size_t c = 0; c < extra; c++) PetscCall(in.Real(&skip));
          PetscCall(Node(tags[v], where, x));
        }
        seen += n;
      }
      PetscCheck(seen == total, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the blocks hold %" PetscInt_FMT " nodes, the header announces %" PetscInt_FMT, in.file, in.pos, seen, total);
    }
    PetscCall(in.End("$EndNodes"));
    PetscFunctionReturn(PETSC_SUCCESS);
  }

  PetscErrorCode Elements()
  {
    int64_t      v[8];
    MSimGmshType g;
    PetscInt     total = 0, seen = 0, n = 0;

    PetscFunctionBeginUser;
    if (version < 3) {
      PetscCall(TextCount("element count", &total));
      while (seen < total) {
        int64_t      type = 0, count = 0, ntags = 0, skip;
        const size_t at = in.pos;
        PetscCall(in.Int("an element block header (type, count, tag count)", &type));
        PetscCall(in.Int("an element block header (type, count, tag count)", &count));
        PetscCall(in.Int("an element block header (type, count, tag count)", &ntags));
        PetscCall(Type(type, at, &g));
        PetscCheck(count > 0 && count <= total - seen && ntags >= 0 && ntags < 100, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: an element block of %lld elements with %lld tags (1 to the %" PetscInt_FMT " elements left, 0 to 99 tags)", in.file, at, (long long)count, (long long)ntags, total - seen);
        PetscCall(in.Count(at + 4, (uint64_t)count, 4 * (1 + ntags + g.nodes), "elements in the block", &n));
        for (PetscInt e = 0; e < n; e++) {
          const size_t where = in.pos;
          for (int64_t k = 0; k <= ntags; k++) PetscCall(in.Int("an element's tags", &skip));
          for (int k = 0; k < g.nodes; k++) PetscCall(in.Int("an element's nodes", &v[k]));
          PetscCall(Element(type, v, where));
        }
        seen += n;
      }
    } else {
      uint64_t head[4] = {0, 0, 0, 0};
      PetscInt blocks = 0;
      const size_t at = in.pos;
      for (uint64_t &h : head) PetscCall(in.Size("the $Elements header", &h));
      PetscCall(in.Count(at, head[0], 12 + in.size_t_, "block count", &blocks));
      PetscCall(in.Count(at + in.size_t_, head[1], 2 * in.size_t_, "element count", &total));
      for (PetscInt b = 0; b < blocks; b++) {
        int64_t      dim, entity, type = 0, tag;
        uint64_t     count = 0;
        const size_t at = in.pos;
        PetscCall(in.Int("an element block header", &dim));
        PetscCall(in.Int("an element block header", &entity));
        PetscCall(in.Int("an element block header", &type));
        PetscCall(in.Size("an element block header", &count));
        PetscCall(Type(type, at, &g));
        PetscCheck(count <= (uint64_t)(total - seen), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the blocks hold more elements than the %" PetscInt_FMT " the header announces", in.file, at, total);
        PetscCall(in.Count(at + 12, count, in.size_t_ * (1 + g.nodes), "elements in the block", &n));
        for (PetscInt e = 0; e < n; e++) {
          const size_t where = in.pos;
          PetscCall(in.Tag("element tag", &tag));
          for (int k = 0; k < g.nodes; k++) PetscCall(in.Tag("node tag", &v[k]));
          PetscCall(Element(type, v, where));
        }
        seen += n;
      }
      PetscCheck(seen == total, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: the blocks hold %" PetscInt_FMT " elements, the header announces %" PetscInt_FMT, in.file, in.pos, seen, total);
    }
    PetscCall(in.End("$EndElements"));
    PetscFunctionReturn(PETSC_SUCCESS);
  }

  /* A section msim does not use: to its end line, "$EndName" at the start of a line and alone on
     it (binary bytes may come before it). */
  PetscErrorCode Skip(const std::string &name, size_t at)
  {
    const std::string end = "\n$End" + name.substr(1);

    PetscFunctionBeginUser;
    size_t p = in.pos;
    while ((p = in.data.find(end, p)) != std::string::npos) {
      const size_t after = p + end.size();
      if (after == in.data.size() || isspace((unsigned char)in.data[after])) break;
      p = after;
    }
    PetscCheck(p != std::string::npos, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: section %s has no $End%s line", in.file, at, Bytes::Show(name).c_str(), Bytes::Show(name).c_str() + 1);
    in.pos = p + end.size();
    PetscFunctionReturn(PETSC_SUCCESS);
  }
};
} // namespace

PetscErrorCode MSimMeshReadGmshBinary(const char file[], MSimMesh *m)
{
  Reader      r;
  std::string name;
  bool        nodes = false, elements = false;

  PetscFunctionBeginUser;
  {
    MSimTextFile tf;
    PetscCall(tf.Load(file));
    r.in.data.swap(tf.data);
  }
  r.in.file = file;
  while (true) {
    const size_t at = r.in.pos;
    if (!r.in.TextLine(&name)) break;
    r.in.section = name.c_str();
    if (name == "$MeshFormat") {
      PetscCheck(r.version == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: $MeshFormat a second time", file, at);
      PetscCall(r.Format());
    } else if (name == "$Nodes") {
      PetscCheck(r.version > 0 && !nodes, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: $Nodes %s", file, at, r.version > 0 ? "a second time" : "before $MeshFormat");
      r.in.SkipNewline();
      PetscCall(r.Nodes());
      nodes = true;
    } else if (name == "$Elements") {
      PetscCheck(nodes && !elements, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: $Elements %s", file, at, nodes ? "a second time" : "before $Nodes");
      r.in.SkipNewline();
      PetscCall(r.Elements());
      elements = true;
    } else {
      PetscCheck(name.size() > 1 && name[0] == '$' && name.compare(0, 4, "$End"), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s byte %zu: '%s' where a section ($Name) should begin", file, at, Bytes::Show(name).c_str());
      PetscCall(r.Skip(name, at));
    }
  }
  PetscCheck(elements, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no %s section", file, nodes ? "$Elements" : "$Nodes");
  PetscCall(r.mesh.Finish(file, m));
  PetscFunctionReturn(PETSC_SUCCESS);
}
