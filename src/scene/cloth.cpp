/* Cloth grid: N x N vertices in the z = 0 plane, vertex (i, j) has id j N + i. Spring families:
   structural (i,j)-(i+1,j) and (i,j)-(i,j+1), shear (i,j)-(i+1,j+1) and (i+1,j)-(i,j+1), bending
   (i,j)-(i+2,j) and (i,j)-(i,j+2). -msim_fix corners holds the two corners of the edge j = N - 1,
   edge holds that whole edge, so under gravity (-z) the cloth swings down like a curtain. Each rank
   makes the vertices of its block of ids and the springs that start at them. */
#include <msim/scene.h>

PetscErrorCode MSimSceneGenerate_Cloth(MPI_Comm comm, MSimSceneData *s)
{
  PetscInt    N = 20;
  PetscReal   size = 1.0, kst, ksh, kbe; /* the families' stiffness: the scene's unless overridden */
  char        springs[256] = "structural,shear,bending";
  PetscBool   structural = PETSC_FALSE, shear = PETSC_FALSE, bending = PETSC_FALSE;
  PetscMPIInt rank, nranks;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim cloth scene", NULL);
  PetscCall(MSimOptionsInt("-msim_cloth_n", "Vertices per side of the cloth", NULL, N, &N, NULL));
  PetscCall(MSimOptionsReal("-msim_cloth_size", "Side length of the cloth, m", NULL, size, &size, NULL));
  PetscCall(PetscOptionsString("-msim_springs", "Spring families: any of structural,shear,bending", NULL, springs, springs, sizeof(springs), NULL));
  PetscCall(MSimSceneOptionsFamilyStiffness(s, "structural", "Stiffness of structural springs, N/m", &kst));
  PetscCall(MSimSceneOptionsFamilyStiffness(s, "shear", "Stiffness of shear springs, N/m", &ksh));
  PetscCall(MSimSceneOptionsFamilyStiffness(s, "bending", "Stiffness of bending springs, N/m", &kbe));
  PetscOptionsEnd();
  if (s->options_only) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCheck(N >= 2, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_cloth_n must be >= 2 (got %" PetscInt_FMT ")", N);
  PetscCheck(N <= 20000, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_cloth_n %" PetscInt_FMT " is too large for this build's %d-bit indices (at most 20000)", N, (int)(8 * sizeof(PetscInt)));
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
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &nranks));
  const PetscReal dx = size / (N - 1);
  MSimBlockLayout block;
  block.Set(N * N, nranks);
  const PetscInt first = block.Start(rank), last = first + block.Count(rank);
  s->nv = N * N;
  for (PetscInt v = first; v < last; v++) {
    s->vid.push_back(v);
    s->vx.insert(s->vx.end(), {(v % N) * dx, (v / N) * dx, 0.0});
  }
  auto id  = [N](PetscInt i, PetscInt j) { return j * N + i; };
  auto add = [&](PetscInt a, PetscInt b, PetscReal k, PetscReal L) {
    s->si.push_back(a);
    s->sj.push_back(b);
    s->sk.push_back(k);
    s->sL.push_back(L);
  };
  /* the springs of cell (i, j) start at vertex (i, j) */
  for (PetscInt v = first; v < last; v++) {
    const PetscInt i = v % N, j = v / N;
    if (structural) {
      if (i + 1 < N) add(id(i, j), id(i + 1, j), kst, dx);
      if (j + 1 < N) add(id(i, j), id(i, j + 1), kst, dx);
    }
    if (shear && i + 1 < N && j + 1 < N) {
      add(id(i, j), id(i + 1, j + 1), ksh, PETSC_SQRT2 * dx);
      add(id(i + 1, j), id(i, j + 1), ksh, PETSC_SQRT2 * dx);
    }
    if (bending) {
      if (i + 2 < N) add(id(i, j), id(i + 2, j), kbe, 2 * dx);
      if (j + 2 < N) add(id(i, j), id(i, j + 2), kbe, 2 * dx);
    }
  }
  s->corners = {id(0, N - 1), id(N - 1, N - 1)};
  for (PetscInt i = 0; i < N; i++) s->edge.push_back(id(i, N - 1));
  PetscFunctionReturn(PETSC_SUCCESS);
}
