/* Cloth grid: N x N vertices in the z = 0 plane, vertex (i, j) has id j N + i. Spring families as
   DESIGN.md defines them; -msim_fix corners holds the two corners of the edge j = N - 1, edge holds
   that whole edge, so under gravity (-z) the cloth swings down like a curtain. */
#include <msim/scene.h>

PetscErrorCode MSimSceneGenerate_Cloth(MPI_Comm comm, MSimSceneData *s)
{
  PetscInt  N = 20;
  PetscReal size = 1.0, kst, ksh, kbe;
  char      springs[256] = "structural,shear,bending";
  PetscBool structural = PETSC_FALSE, shear = PETSC_FALSE, bending = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim cloth scene", NULL);
  PetscCall(PetscOptionsInt("-msim_cloth_n", "Vertices per side of the cloth", NULL, N, &N, NULL));
  PetscCall(PetscOptionsReal("-msim_cloth_size", "Side length of the cloth, m", NULL, size, &size, NULL));
  PetscCall(PetscOptionsString("-msim_springs", "Spring families: any of structural,shear,bending", NULL, springs, springs, sizeof(springs), NULL));
  kst = ksh = kbe = 1000.0;
  PetscCall(MSimSceneGetStiffness("structural", &kst));
  PetscCall(MSimSceneGetStiffness("shear", &ksh));
  PetscCall(MSimSceneGetStiffness("bending", &kbe));
  PetscCall(PetscOptionsReal("-msim_stiffness_structural", "Stiffness of structural springs, N/m", NULL, kst, &kst, NULL));
  PetscCall(PetscOptionsReal("-msim_stiffness_shear", "Stiffness of shear springs, N/m", NULL, ksh, &ksh, NULL));
  PetscCall(PetscOptionsReal("-msim_stiffness_bending", "Stiffness of bending springs, N/m", NULL, kbe, &kbe, NULL));
  PetscOptionsEnd();
  PetscCheck(N >= 2, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_cloth_n must be >= 2 (got %" PetscInt_FMT ")", N);
  PetscCheck(size > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_cloth_size must be > 0 m (got %g)", (double)size);
  {
    char *tok, *save = NULL;
    for (tok = strtok_r(springs, ",", &save); tok; tok = strtok_r(NULL, ",", &save)) {
      PetscBool a, b, c;
      PetscCall(PetscStrcmp(tok, "structural", &a));
      PetscCall(PetscStrcmp(tok, "shear", &b));
      PetscCall(PetscStrcmp(tok, "bending", &c));
      PetscCheck(a || b || c, comm, PETSC_ERR_ARG_WRONG, "-msim_springs: unknown family '%s' (use structural, shear, bending)", tok);
      structural = (PetscBool)(structural || a);
      shear      = (PetscBool)(shear || b);
      bending    = (PetscBool)(bending || c);
    }
  }

  const PetscReal dx = size / (N - 1);
  s->nv              = N * N;
  s->x0.resize(3 * s->nv);
  for (PetscInt j = 0; j < N; j++)
    for (PetscInt i = 0; i < N; i++) {
      s->x0[3 * (j * N + i) + 0] = i * dx;
      s->x0[3 * (j * N + i) + 1] = j * dx;
      s->x0[3 * (j * N + i) + 2] = 0.0;
    }
  auto id = [N](PetscInt i, PetscInt j) { return j * N + i; };
  if (structural)
    for (PetscInt j = 0; j < N; j++)
      for (PetscInt i = 0; i < N; i++) {
        if (i + 1 < N) MSimSceneAddSpring(s, id(i, j), id(i + 1, j), kst);
        if (j + 1 < N) MSimSceneAddSpring(s, id(i, j), id(i, j + 1), kst);
      }
  if (shear)
    for (PetscInt j = 0; j + 1 < N; j++)
      for (PetscInt i = 0; i + 1 < N; i++) {
        MSimSceneAddSpring(s, id(i, j), id(i + 1, j + 1), ksh);
        MSimSceneAddSpring(s, id(i + 1, j), id(i, j + 1), ksh);
      }
  if (bending)
    for (PetscInt j = 0; j < N; j++)
      for (PetscInt i = 0; i < N; i++) {
        if (i + 2 < N) MSimSceneAddSpring(s, id(i, j), id(i + 2, j), kbe);
        if (j + 2 < N) MSimSceneAddSpring(s, id(i, j), id(i, j + 2), kbe);
      }
  s->corners = {id(0, N - 1), id(N - 1, N - 1)};
  for (PetscInt i = 0; i < N; i++) s->edge.push_back(id(i, N - 1));
  PetscFunctionReturn(PETSC_SUCCESS);
}
