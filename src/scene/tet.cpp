/* Tetrahedral solid from a file: a closed surface (.off, .obj, .stl) tetrahedralized by TetGen, a
   TetGen .node/.ele pair, a Gmsh .msh (hexahedra and prisms split into tets) or a Medit .mesh.
   Read, checked and meshed on rank 0, which holds the vertices and tets until the scene spreads
   them; springs come from the unique tet edges. */
#include <msim/scene.h>
#include <msim/errors.h>

PetscErrorCode MSimSceneMeshFileOptions(PetscOptionItems *PetscOptionsObject, char file[], size_t len, PetscReal *scale, PetscBool *set, char format[], size_t flen)
{
  PetscFunctionList readers;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsString("-msim_mesh_file", "Mesh file: .off .obj .stl (surfaces), TetGen .node/.ele, Gmsh .msh, Medit .mesh", NULL, file, file, len, set));
  PetscCall(MSimMeshReaderList(&readers));
  PetscCall(PetscOptionsFList("-msim_mesh_format", "Mesh file format (auto: by the file's extension)", NULL, readers, format, format, flen, NULL));
  PetscCall(MSimOptionsReal("-msim_mesh_scale", "Multiply the mesh's coordinates by this (e.g. 0.001 for a file in mm), before TetGen", NULL, *scale, scale, NULL));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneTakeMesh(MSimMesh *m, MSimSceneData *s)
{
  PetscFunctionBeginUser;
  /* the notes only once the mesh passed its checks, so a refused file prints its error alone */
  PetscCall(MSimMeshCheck(m));
  PetscCall(MSimMeshPrintNotes(m));
  s->nv = m->nv;
  s->vid.resize(m->nv);
  for (PetscInt v = 0; v < m->nv; v++) s->vid[v] = v;
  s->vx.swap(m->x);
  /* the file's ids, where they differ from the input ids (vertices were dropped) */
  s->nv_file = m->file_id.empty() ? 0 : m->nv_file;
  s->vfile.swap(m->file_id);
  s->cell_size = m->nper;
  s->cells.swap(m->cell);
  s->source = m->file;
  *m        = MSimMesh();
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Rank 0's nv, nv_file and source, for every rank */
PetscErrorCode MSimSceneShareHeader(MPI_Comm comm, MSimSceneData *s)
{
  int len = (int)s->source.size();

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Bcast(&s->nv, 1, MPIU_INT, 0, comm));
  PetscCallMPI(MPI_Bcast(&s->nv_file, 1, MPIU_INT, 0, comm));
  PetscCallMPI(MPI_Bcast(&s->cell_size, 1, MPI_INT, 0, comm));
  PetscCallMPI(MPI_Bcast(&len, 1, MPI_INT, 0, comm));
  s->source.resize(len);
  PetscCallMPI(MPI_Bcast(&s->source[0], len, MPI_CHAR, 0, comm));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode ReadTets(const char file[], const char format[], const char switches[], PetscReal scale, MSimSceneData *s)
{
  MSimMesh m;

  PetscFunctionBeginUser;
  PetscCall(MSimMeshReadFileAs(file, format, 4, &m));
  MSimMeshScale(&m, scale);
  if (m.nper == 3) {
    MSimMesh tets;
    PetscCall(MSimMeshCheck(&m));
    PetscCall(MSimMeshCheckClosed(&m));
    PetscCall(MSimMeshTetrahedralize(&m, switches, &tets));
    m = std::move(tets);
  }
  PetscCall(MSimSceneTakeMesh(&m, s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneGenerate_Tet(MPI_Comm comm, MSimSceneData *s)
{
  char      file[PETSC_MAX_PATH_LEN] = "", switches[256] = "pq1.414Y", format[64] = "auto";
  PetscReal scale = 1;
  PetscBool set;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim tet scene (a solid: springs on tet edges)", NULL);
  PetscCall(MSimSceneMeshFileOptions(PetscOptionsObject, file, sizeof(file), &scale, &set, format, sizeof(format)));
  /* the switches go to TetGen as given (plus z and Q): a volume bound is TetGen's, and with Y,
     msim's default for fewer vertices, TetGen cannot meet it next to the surface (-help says how
     far it misses) */
  PetscCall(PetscOptionsString("-msim_tetgen_switches", "TetGen switches for a surface (p: keep the surface, q1.414: radius-edge ratio bound, Y: no new vertices on the surface, a0.1: tet volume bound). With Y the bound holds away from the surface only: TetGen leaves a tet whose refinement would split a surface triangle, so tets at and near the surface keep the size of its triangles (the bunny at pq1.414Ya0.001: up to 42 times the bound). Without Y every tet meets it but a few that TetGen's final smoothing moves past it (pq1.414a0.01: up to 1.04 times; O0 turns the smoothing off)", NULL, switches, switches, sizeof(switches), NULL));
  PetscOptionsEnd();
  if (s->options_only) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCheck(set && file[0], comm, PETSC_ERR_ARG_WRONG, "-msim_scene tet needs -msim_mesh_file F (a closed surface .off/.obj/.stl, TetGen .node/.ele, Gmsh .msh, or Medit .mesh)");
  PetscCheck(scale > 0 && PetscIsNormalReal(scale), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_mesh_scale must be a positive number (got %g)", (double)scale);
  s->k_cell = s->stiffness;
  /* s->young: -msim_young, read by the scene (msim/scene.h) */
  PetscCall(MSimCallOnRankZero(comm, [&]() { return ReadTets(file, format, switches, scale, s); }));
  PetscCall(MSimSceneShareHeader(comm, s));
  PetscFunctionReturn(PETSC_SUCCESS);
}
