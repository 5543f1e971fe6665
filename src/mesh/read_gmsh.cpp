/* Gmsh .msh through PETSc's reader (DMPlexCreateFromFile: versions 2.2, 4.0 and 4.1, ASCII or
   binary), on one process. msim keeps the cells of the mesh's dimension (tets of a volume mesh,
   triangles of a surface mesh) and the vertices in the order PETSc numbers them, which is the
   order of the file's nodes. PETSc stores a tet with the opposite orientation to Gmsh's: msim swaps
   its first two vertices back. The reader gives no line numbers: faults name the element. */
#include <msim/mesh.h>
#include <petscdmplex.h>
#include <cerrno>
#include <cstring>

PetscErrorCode MSimCaptureError(const std::function<PetscErrorCode(void)> &fn, std::string &message);

PetscErrorCode MSimMeshReadGmsh(const char file[], MSimMesh *m)
{
  DM                 dm = NULL;
  PetscInt           dim, cdim, cs, ce, vs, ve;
  std::string        why;
  Vec                coords;
  PetscSection       csec;
  const PetscScalar *xa;

  PetscFunctionBeginUser;
  {
    FILE *fp = fopen(file, "rb");
    PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s: cannot open (%s)", file, strerror(errno));
    fseek(fp, 0, SEEK_END);
    long size = ftell(fp);
    fclose(fp);
    PetscCheck(size > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty file", file);
  }
  /* PETSc 3.18's reader crashes on some malformed files (runs/fuzz/open/gmsh): guarded */
  int            crash = 0;
  PetscErrorCode ierr  = MSimCaptureError(
    [&]() {
      PetscErrorCode e = PETSC_SUCCESS;
      crash            = MSimCallGuarded([&]() { e = DMPlexCreateFromFile(PETSC_COMM_SELF, file, "msim", PETSC_FALSE, &dm); });
      return crash ? PETSC_SUCCESS : e; /* the guard inside the capture: its error handler is popped either way */
    },
    why);
  PetscCheck(!crash, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: PETSc's Gmsh reader crashed on it (signal %d): a malformed .msh file", file, crash);
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
