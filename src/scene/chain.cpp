/* Chain: N vertices on the +x axis from the origin, rest spacing L/(N-1), springs between
   neighbours. -msim_fix corners holds both ends (a rope between two hooks, and the fixed-fixed chain
   of the eigenfrequency tests); edge holds vertex 0 only (a hanging rope). Each rank makes its
   block of vertices and the springs that start there. */
#include <msim/scene.h>

PetscErrorCode MSimSceneGenerate_Chain(MPI_Comm comm, MSimSceneData *s)
{
  PetscInt    N = 10;
  PetscReal   length = 1.0;
  PetscMPIInt rank, size;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim chain scene", NULL);
  PetscCall(MSimOptionsInt("-msim_chain_n", "Vertices of the chain", NULL, N, &N, NULL));
  PetscCall(MSimOptionsReal("-msim_chain_length", "Rest length of the chain, m", NULL, length, &length, NULL));
  PetscOptionsEnd();
  if (s->options_only) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCheck(N >= 2, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_chain_n must be >= 2 (got %" PetscInt_FMT ")", N);
  PetscCheck(length > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_chain_length must be > 0 m (got %g)", (double)length);
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  MSimBlockLayout block;
  block.Set(N, size);
  s->nv = N;
  for (PetscInt i = block.Start(rank); i < block.Start(rank) + block.Count(rank); i++) {
    s->vid.push_back(i);
    s->vx.insert(s->vx.end(), {i * length / (N - 1), 0.0, 0.0});
    if (i + 1 < N) {
      s->si.push_back(i);
      s->sj.push_back(i + 1);
      s->sk.push_back(s->stiffness);
      s->sL.push_back(length / (N - 1));
    }
  }
  s->corners = {0, N - 1};
  s->edge    = {0};
  PetscFunctionReturn(PETSC_SUCCESS);
}
