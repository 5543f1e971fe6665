/* Gmsh .msh: ASCII 2.2 and 4.1 go to msim's own reader (read_gmsh_ascii.cpp), the others (binary,
   4.0) to PETSc's (DMPlexCreateFromFile), on one process, after a check of their sections, guarded.
   For PETSc's: msim keeps the cells of the mesh's dimension (tets of a volume mesh,
   triangles of a surface mesh) and the vertices in the order PETSc numbers them, which is the
   order of the file's nodes. PETSc stores a tet with the opposite orientation to Gmsh's: msim swaps
   its first two vertices back. The reader gives no line numbers: faults name the element. */
#include <msim/mesh.h>
#include <petscdmplex.h>
#include <cctype>
#include <cerrno>
#include <cstring>

PetscErrorCode MSimCaptureError(const std::function<PetscErrorCode(void)> &fn, std::string &message);

/* For PETSc's reader (binary files, 4.0): every section "$Name" must close with "$EndName" before
   the next one opens. PETSc's reader
   skips a section it does not know ($Comments, ...) by reading until its end line and, when that
   line is missing, never returns at the end of the file (runs/fuzz/findings/gmsh/timeout-*): so
   msim walks the sections first (msim's ASCII reader checks them as it reads). Binary sections are skipped the same way, by searching for their
   end line; only the text between sections is required to be blank. */
static PetscErrorCode GmshCheckSections(const char file[], size_t *bytes)
{
  std::string data;

  PetscFunctionBeginUser;
  {
    FILE *fp = fopen(file, "rb");
    PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s: cannot open (%s)", file, strerror(errno));
    char   buf[1 << 16];
    size_t n;
    while ((n = fread(buf, 1, sizeof buf, fp)) > 0) data.append(buf, n);
    fclose(fp);
  }
  PetscCheck(!data.empty(), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  *bytes = data.size();
  size_t   pos = 0;
  PetscInt line = 1;
  auto     lines_to = [&](size_t end) {
    for (; pos < end; pos++) line += data[pos] == '\n';
  };
  while (true) {
    while (pos < data.size() && isspace((unsigned char)data[pos])) lines_to(pos + 1);
    if (pos == data.size()) break;
    size_t eol = data.find_first_of("\r\n", pos);
    if (eol == std::string::npos) eol = data.size();
    std::string name = data.substr(pos, eol - pos);
    while (!name.empty() && isspace((unsigned char)name.back())) name.pop_back();
    std::string shown = name.substr(0, 32);
    for (char &c : shown)
      if (!isprint((unsigned char)c)) c = '?';
    PetscCheck(name.size() > 1 && name[0] == '$' && name.compare(0, 4, "$End") != 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": '%s' where a section ($Name) should begin", file, line, shown.c_str());
    const std::string end = "\n$End" + name.substr(1);
    size_t            at  = eol;
    while ((at = data.find(end, at)) != std::string::npos) {
      const size_t after = at + end.size();
      if (after == data.size() || isspace((unsigned char)data[after])) break;
      at = after;
    }
    PetscCheck(at != std::string::npos, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": section %s has no $End%s line (a truncated or malformed .msh file)", file, line, shown.c_str(), shown.c_str() + 1);
    if (name == "$PhysicalNames") {
      /* PETSc copies each name from between its quotes: a line without two of them made it copy
         a negative length (runs/fuzz/findings/gmsh). The section is ASCII in every format. */
      size_t   p     = eol;
      PetscInt ln    = line;
      bool     count = true;
      while (p < at) {
        size_t e = data.find('\n', p + 1);
        if (e == std::string::npos || e > at) e = at;
        const std::string body = data.substr(p + 1, e > p ? e - p - 1 : 0);
        ln++;
        if (body.find_first_not_of(" \t\r") != std::string::npos) {
          const size_t q0 = body.find('"'), q1 = body.rfind('"');
          PetscCheck(count || (q0 != std::string::npos && q1 > q0), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s line %" PetscInt_FMT ": a physical name must be in double quotes", file, ln);
          count = false;
        }
        p = e;
      }
    }
    lines_to(at + end.size());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Whether msim's reader takes the file: its $MeshFormat line (after any $Comments) says ASCII
   ("version 0 data-size") of version 2.2 or 4.1. Reads no further than that line. */
static PetscErrorCode GmshIsASCII(const char file[], bool *ascii)
{
  FILE *fp = fopen(file, "rb");
  char  line[256];

  PetscFunctionBeginUser;
  PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s: cannot open (%s)", file, strerror(errno));
  *ascii = false;
  while (fgets(line, sizeof line, fp))
    if (!strncmp(line, "$MeshFormat", 11)) {
      double v    = 0;
      int    type = -1;
      *ascii      = fgets(line, sizeof line, fp) && sscanf(line, "%lf %d", &v, &type) == 2 && type == 0 && (v == 2.2 || v == 4.1);
      break;
    }
  fclose(fp);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshReadGmsh(const char file[], MSimMesh *m)
{
  DM                 dm = NULL;
  PetscInt           dim, cdim, cs, ce, vs, ve;
  std::string        why;
  Vec                coords;
  PetscSection       csec;
  const PetscScalar *xa;

  PetscFunctionBeginUser;
  size_t bytes, refused = 0;
  bool   ascii;
  PetscCall(GmshIsASCII(file, &ascii));
  if (ascii) { /* msim's reader checks its sections itself, as it reads them */
    PetscCall(MSimMeshReadGmshASCII(file, m));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(GmshCheckSections(file, &bytes));
  /* PETSc 3.18's reader crashes on some malformed files (runs/fuzz/findings/gmsh): guarded. It
     also trusts counts and ids it reads: no one allocation may exceed 64 bytes per byte of the
     file (plus 64 MB), so a 17 KB file cannot ask for gigabytes. */
  int            crash = 0;
  PetscErrorCode ierr  = MSimCaptureError(
    [&]() {
      return MSimCallWithAllocationCap(64 * bytes + (64u << 20), &refused, [&]() {
        PetscErrorCode e = PETSC_SUCCESS;
        crash            = MSimCallGuarded([&]() { e = DMPlexCreateFromFile(PETSC_COMM_SELF, file, "msim", PETSC_FALSE, &dm); });
        return crash ? PETSC_SUCCESS : e; /* the guard inside the capture: its error handler is popped either way */
      });
    },
    why);
  PetscCheck(!crash, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: PETSc's Gmsh reader crashed on it (signal %d): a malformed .msh file", file, crash);
  PetscCheck(!refused, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: PETSc's Gmsh reader asked for %.3g GB for a file of %.3g MB: a malformed .msh file (a count or id out of range)", file, refused / 1e9, bytes / 1e6);
  PetscCheck(!ierr, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: PETSc's Gmsh reader: %s", file, why.c_str());
  m->file      = file;
  m->cell_name = "element";
  PetscCall(DMGetDimension(dm, &dim));
  PetscCall(DMGetCoordinateDim(dm, &cdim));
  if (dim != 2 && dim != 3) {
    PetscCall(DMDestroy(&dm));
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: a %" PetscInt_FMT "-D mesh (msim reads tets or triangles)", file, dim);
  }
  PetscCall(DMPlexGetHeightStratum(dm, 0, &cs, &ce));
  PetscCall(DMPlexGetDepthStratum(dm, 0, &vs, &ve));
  m->nper  = dim == 3 ? 4 : 3;
  m->nv    = ve - vs;
  m->ncell = ce - cs;
  m->x.assign(3 * (size_t)m->nv, 0.0);
  m->vline.assign(m->nv, 0);
  m->cline.assign(m->ncell, 0);
  m->cell.resize((size_t)m->nper * m->ncell);
  PetscCall(DMGetCoordinatesLocal(dm, &coords));
  PetscCall(DMGetCoordinateSection(dm, &csec));
  PetscCall(VecGetArrayRead(coords, &xa));
  for (PetscInt v = vs; v < ve; v++) {
    PetscInt off, dof;
    PetscCall(PetscSectionGetOffset(csec, v, &off));
    PetscCall(PetscSectionGetDof(csec, v, &dof));
    for (PetscInt c = 0; c < PetscMin(dof, 3); c++) m->x[3 * (v - vs) + c] = PetscRealPart(xa[off + c]);
  }
  PetscCall(VecRestoreArrayRead(coords, &xa));
  for (PetscInt c = cs; c < ce; c++) {
    DMPolytopeType  ct;
    const PetscInt *cone;
    PetscInt        n;
    PetscCall(DMPlexGetCellType(dm, c, &ct));
    if (ct != (dim == 3 ? DM_POLYTOPE_TETRAHEDRON : DM_POLYTOPE_TRIANGLE)) {
      PetscCall(DMDestroy(&dm));
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: element %" PetscInt_FMT " of dimension %" PetscInt_FMT " is a %s (msim reads %s)", file, c - cs + 1, dim, DMPolytopeTypes[ct], dim == 3 ? "tets" : "triangles");
    }
    PetscCall(DMPlexGetConeSize(dm, c, &n));
    PetscCall(DMPlexGetCone(dm, c, &cone));
    for (PetscInt k = 0; k < m->nper; k++) m->cell[(size_t)m->nper * (c - cs) + k] = cone[k] - vs;
    if (dim == 3) std::swap(m->cell[4 * (size_t)(c - cs)], m->cell[4 * (size_t)(c - cs) + 1]);
  }
  PetscCall(DMDestroy(&dm));
  PetscFunctionReturn(PETSC_SUCCESS);
}
