/* Gmsh ASCII .msh, versions 2.2 and 4.1, read by msim itself (binary ones: read_gmsh_binary.cpp).
   Fuzzing found PETSc 3.18's reader crashing, hanging, overflowing a buffer and asking
   for gigabytes on malformed files (runs/fuzz/README.md); this one checks every count, id and
   token and names the file and line of a fault, as the other readers do.
     2.2: $Nodes: n, then "id x y z"; $Elements: n, then "id type ntags tags... nodes...".
     4.1: $Nodes: "blocks nodes min max", per block "dim entity parametric n", its n tags, then
          its n coordinate lines "x y z [u v w]"; $Elements: "blocks elements min max", per
          block "dim entity type n", then n lines "tag nodes...".
   Other sections are skipped; what is kept of the nodes and elements: gmsh_mesh.h (hexahedra and
   prisms become tets, quadrangles triangles; pyramids and higher-order elements are refused by
   name). */
#include <msim/mesh.h>
#include "gmsh_mesh.h"
#include "text_file.h"

namespace {
struct Reader {
  MSimTextFile tf;
  MSimGmshMesh mesh{true};

  PetscErrorCode Line(const char what[])
  {
    PetscFunctionBeginUser;
    PetscCheck(tf.NextLine(0), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the file ends inside %s (truncated)", MSIM_AT(tf), what);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Node(int64_t tag, size_t first)
  {
    PetscReal x[3];

    PetscFunctionBeginUser;
    for (int c = 0; c < 3; c++) PetscCall(tf.Real(first + c, "coordinate", &x[c]));
    PetscCheck(mesh.AddNode(tag, x, tf.line), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": node %lld appears twice", MSIM_AT(tf), (long long)tag);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* an element of type t whose node tags are tokens first ... */
  PetscErrorCode Element(int64_t t, size_t first)
  {
    const MSimGmshType g = MSimGmshTypeOf(t);
    int64_t            v[8];

    PetscFunctionBeginUser;
    PetscCheck(g.nodes || !g.name, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": a %s (element type %lld): " MSIM_GMSH_READS, MSIM_AT(tf), g.name, (long long)t);
    PetscCheck(g.nodes, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": element type %lld: " MSIM_GMSH_READS, MSIM_AT(tf), (long long)t);
    PetscCall(tf.NeedTokens(first + g.nodes, first + g.nodes, "an element (its tag, then as many nodes as its type has)"));
    for (int k = 0; k < g.nodes; k++) PetscCall(tf.Int(first + k, "node", &v[k]));
    PetscCheck(mesh.AddElement(t, v, tf.line), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": a pyramid (element type 7): msim splits hexahedra and prisms into tets, not pyramids", MSIM_AT(tf));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* the next line (where: what the file should hold there), of ntok tokens (what), a node tag first */
  PetscErrorCode TagLine(const char where[], size_t ntok, const char what[], int64_t *tag)
  {
    PetscFunctionBeginUser;
    PetscCall(Line(where));
    PetscCall(tf.NeedTokens(ntok, ntok, what));
    PetscCall(tf.Int(0, "node tag", tag));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Nodes(double version)
  {
    PetscInt blocks = 1, n;

    PetscFunctionBeginUser;
    PetscCall(Line("$Nodes"));
    if (version < 3) {
      PetscCall(tf.NeedTokens(1, 1, "the node count"));
      PetscCall(tf.Count(0, "node count", &n));
      mesh.ReserveNodes(tf.Reserve(n, 8));
      for (PetscInt v = 0; v < n; v++) {
        int64_t tag;
        PetscCall(TagLine("$Nodes (fewer nodes than its count)", 4, "a node (tag, x, y, z)", &tag));
        PetscCall(Node(tag, 1));
      }
    } else {
      PetscInt total, seen = 0;
      PetscCall(tf.NeedTokens(4, 4, "the $Nodes header (blocks, nodes, smallest and largest tag)"));
      PetscCall(tf.Count(0, "block count", &blocks));
      PetscCall(tf.Count(1, "node count", &total));
      mesh.ReserveNodes(tf.Reserve(total, 8));
      for (PetscInt b = 0; b < blocks; b++) {
        int64_t param, dim;
        PetscCall(Line("$Nodes (fewer blocks than its count)"));
        PetscCall(tf.NeedTokens(4, 4, "a node block header (dimension, entity, parametric, nodes)"));
        PetscCall(tf.Int(0, "entity dimension", &dim));
        PetscCall(tf.Int(2, "parametric flag", &param));
        PetscCall(tf.Count(3, "nodes in the block", &n));
        PetscCheck(dim >= 0 && dim <= 3 && (param == 0 || param == 1), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": entity dimension %lld and parametric flag %lld (0-3 and 0 or 1)", MSIM_AT(tf), (long long)dim, (long long)param);
        PetscCheck(n <= total - seen, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the blocks hold more nodes than the %" PetscInt_FMT " the header announces", MSIM_AT(tf), total);
        std::vector<int64_t> tags;
        tags.reserve(tf.Reserve(n, 2));
        for (PetscInt v = 0; v < n; v++) {
          int64_t tag;
          PetscCall(TagLine("a node block's tags", 1, "a node tag", &tag));
          tags.push_back(tag);
        }
        const size_t ncoord = 3 + (param ? (size_t)dim : 0);
        for (PetscInt v = 0; v < n; v++) {
          PetscCall(Line("a node block's coordinates"));
          PetscCall(tf.NeedTokens(ncoord, ncoord, "a node's coordinates (x y z, and the parametric ones if the block has them)"));
          PetscCall(Node(tags[v], 0));
        }
        seen += n;
      }
      PetscCheck(seen == total, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the blocks hold %" PetscInt_FMT " nodes, the header announces %" PetscInt_FMT, MSIM_AT(tf), seen, total);
    }
    PetscCall(End("$EndNodes"));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode Elements(double version)
  {
    PetscInt n;

    PetscFunctionBeginUser;
    PetscCall(Line("$Elements"));
    if (version < 3) {
      PetscCall(tf.NeedTokens(1, 1, "the element count"));
      PetscCall(tf.Count(0, "element count", &n));
      for (PetscInt e = 0; e < n; e++) {
        int64_t type, ntags;
        PetscCall(Line("$Elements (fewer elements than its count)"));
        PetscCall(tf.NeedTokens(3, 1000, "an element (tag, type, tag count, tags, nodes)"));
        PetscCall(tf.Int(1, "element type", &type));
        PetscCall(tf.Int(2, "tag count", &ntags));
        PetscCheck(ntags >= 0 && ntags < 100, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": tag count %lld (0 to 99)", MSIM_AT(tf), (long long)ntags);
        PetscCall(Element(type, 3 + (size_t)ntags));
      }
    } else {
      PetscInt blocks, total, seen = 0;
      PetscCall(tf.NeedTokens(4, 4, "the $Elements header (blocks, elements, smallest and largest tag)"));
      PetscCall(tf.Count(0, "block count", &blocks));
      PetscCall(tf.Count(1, "element count", &total));
      for (PetscInt b = 0; b < blocks; b++) {
        int64_t type;
        PetscCall(Line("$Elements (fewer blocks than its count)"));
        PetscCall(tf.NeedTokens(4, 4, "an element block header (dimension, entity, type, elements)"));
        PetscCall(tf.Int(2, "element type", &type));
        PetscCall(tf.Count(3, "elements in the block", &n));
        PetscCheck(n <= total - seen, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the blocks hold more elements than the %" PetscInt_FMT " the header announces", MSIM_AT(tf), total);
        for (PetscInt e = 0; e < n; e++) {
          PetscCall(Line("an element block"));
          PetscCall(Element(type, 1));
        }
        seen += n;
      }
      PetscCheck(seen == total, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": the blocks hold %" PetscInt_FMT " elements, the header announces %" PetscInt_FMT, MSIM_AT(tf), seen, total);
    }
    PetscCall(End("$EndElements"));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscErrorCode End(const char word[])
  {
    PetscFunctionBeginUser;
    PetscCall(Line(word));
    PetscCheck(tf.tok.size() == 1 && tf.Is(0, word), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": '%s' where %s should be (a count is wrong)", MSIM_AT(tf), tf.Show(0).c_str(), word);
    PetscFunctionReturn(PETSC_SUCCESS);
  }
};
} // namespace

PetscErrorCode MSimMeshReadGmshASCII(const char file[], MSimMesh *m)
{
  Reader    r;
  PetscReal version = 0;
  bool      nodes = false, elements = false;

  PetscFunctionBeginUser;
  PetscCall(r.tf.Load(file));
  MSimTextFile &tf = r.tf;
  while (tf.NextLine(0)) {
    const std::string section(tf.tok[0].p, tf.tok[0].n);
    if (section == "$MeshFormat") {
      int64_t type;
      PetscCall(r.Line("$MeshFormat"));
      PetscCall(tf.NeedTokens(3, 3, "the format line (version, file type, data size)"));
      PetscCall(tf.Real(0, "version", &version));
      PetscCall(tf.Int(1, "file type", &type));
      PetscCheck(type == 0 && (version == 2.2 || version == 4.1), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": an ASCII file of version 2.2 or 4.1 expected here (Gmsh writes 4.1 with -format msh41)", MSIM_AT(tf));
      PetscCall(r.End("$EndMeshFormat"));
    } else if (section == "$Nodes") {
      PetscCheck(version > 0 && !nodes, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": $Nodes %s", MSIM_AT(tf), version > 0 ? "a second time" : "before $MeshFormat");
      PetscCall(r.Nodes(version));
      nodes = true;
    } else if (section == "$Elements") {
      PetscCheck(nodes && !elements, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": $Elements %s", MSIM_AT(tf), nodes ? "a second time" : "before $Nodes");
      PetscCall(r.Elements(version));
      elements = true;
    } else {
      /* a section msim does not use ($PhysicalNames, $Entities, $Comments, ...): to its end */
      PetscCheck(section.size() > 1 && section[0] == '$' && section.compare(0, 4, "$End"), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": '%s' where a section ($Name) should begin", MSIM_AT(tf), tf.Show(0).c_str());
      const std::string end = "$End" + section.substr(1);
      const PetscInt    at  = tf.line;
      bool              closed = false;
      while (!closed && tf.NextLine(0)) {
        closed = tf.tok.size() == 1 && tf.tok[0].n == end.size() && !end.compare(0, end.size(), tf.tok[0].p, tf.tok[0].n);
        if (!closed && section == "$PhysicalNames" && tf.line > at + 1) {
          /* "dim tag "name"": msim does not use the names, but a file that breaks them is malformed */
          const std::string text(tf.tok.front().p, tf.tok.back().p + tf.tok.back().n);
          const size_t      q0 = text.find('"'), q1 = text.rfind('"');
          PetscCheck(q0 != std::string::npos && q1 > q0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": a physical name must be in double quotes", MSIM_AT(tf));
        }
      }
      PetscCheck(closed, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": section %s has no %s line", file, at, section.c_str(), end.c_str());
    }
  }
  PetscCheck(elements, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no %s section", file, nodes ? "$Elements" : "$Nodes");
  PetscCall(r.mesh.Finish(file, m));
  PetscFunctionReturn(PETSC_SUCCESS);
}
