/* A triangle surface as a shell or a cloth: springs on the unique edges (family "edge") and, with
   -msim_springs edge,bending, one across every edge two triangles share, joining the vertices
   opposite it. Masses by area. The file is read on rank 0. */
#include <msim/scene.h>
#include <msim/errors.h>

PetscErrorCode MSimSceneShareHeader(MPI_Comm comm, MSimSceneData *s);

static PetscErrorCode ReadSurface(const char file[], const char format[], PetscReal scale, MSimSceneData *s)
{
  MSimMesh m;

  PetscFunctionBeginUser;
  PetscCall(MSimMeshReadFileAs(file, format, 3, &m));
  MSimMeshScale(&m, scale);
  PetscCall(MSimSceneTakeMesh(&m, s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneGenerate_Mesh(MPI_Comm comm, MSimSceneData *s)
{
  char      file[PETSC_MAX_PATH_LEN] = "", springs[64] = "edge", format[64] = "auto";
  PetscReal scale = 1, kedge, kbend;
  PetscBool set, bending = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim mesh scene (a surface: springs on triangle edges)", NULL);
  PetscCall(MSimSceneMeshFileOptions(PetscOptionsObject, file, sizeof(file), &scale, &set, format, sizeof(format)));
  PetscCall(PetscOptionsString("-msim_springs", "Spring families of a surface: edge, or edge,bending", NULL, springs, springs, sizeof(springs), NULL));
  PetscCall(MSimSceneOptionsFamilyStiffness(s, "edge", "Stiffness of the springs on a surface's edges, N/m", &kedge));
  PetscCall(MSimSceneOptionsFamilyStiffness(s, "bending", "Stiffness of bending springs, N/m", &kbend));
  PetscOptionsEnd();
  if (s->options_only) PetscFunctionReturn(PETSC_SUCCESS);
  {
    PetscBool edge_only, both;
    PetscCall(PetscStrcmp(springs, "edge", &edge_only));
    PetscCall(PetscStrcmp(springs, "edge,bending", &both));
    PetscCheck(edge_only || both, comm, PETSC_ERR_ARG_WRONG, "-msim_springs %s: a surface has the families edge and edge,bending", springs);
    bending = both;
  }
  PetscCheck(set && file[0], comm, PETSC_ERR_ARG_WRONG, "-msim_scene mesh needs -msim_mesh_file F (a surface .off/.obj/.stl, or a Gmsh .msh or Medit .mesh of triangles)");
  PetscCheck(scale > 0 && PetscIsNormalReal(scale), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_mesh_scale must be a positive number (got %g)", (double)scale);
  s->k_cell = kedge;
  s->k_bend = bending ? kbend : 0.0;
  PetscCall(MSimCallOnRankZero(comm, [&]() { return ReadSurface(file, format, scale, s); }));
  PetscCall(MSimSceneShareHeader(comm, s));
  PetscFunctionReturn(PETSC_SUCCESS);
}
