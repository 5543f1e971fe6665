/* Chain: N vertices on the +x axis from the origin, rest spacing L/(N-1), springs between
   neighbours. -msim_fix corners holds both ends (a rope between two hooks, and the fixed-fixed chain
   of the eigenfrequency tests); edge holds vertex 0 only (a hanging rope). */
#include <msim/scene.h>

PetscErrorCode MSimSceneGenerate_Chain(MPI_Comm comm, MSimSceneData *s)
{
  PetscInt  N = 10;
  PetscReal length = 1.0, k = 1000.0;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim chain scene", NULL);
  PetscCall(PetscOptionsInt("-msim_chain_n", "Vertices of the chain", NULL, N, &N, NULL));
  PetscCall(PetscOptionsReal("-msim_chain_length", "Rest length of the chain, m", NULL, length, &length, NULL));
  PetscOptionsEnd();
  PetscCheck(N >= 2, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_chain_n must be >= 2 (got %" PetscInt_FMT ")", N);
  PetscCheck(length > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_chain_length must be > 0 m (got %g)", (double)length);
  PetscCall(MSimSceneGetStiffness(NULL, &k));
  s->nv = N;
  s->x0.assign(3 * N, 0.0);
  for (PetscInt i = 0; i < N; i++) s->x0[3 * i] = i * length / (N - 1);
  for (PetscInt i = 0; i + 1 < N; i++) MSimSceneAddSpring(s, i, i + 1, k);
  s->corners = {0, N - 1};
  s->edge    = {0};
  PetscFunctionReturn(PETSC_SUCCESS);
}
