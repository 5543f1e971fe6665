/* Structured tet box: nx x ny x nz cubes (cells of -msim_box_size / n), each cut into 6 tets along
   its main diagonal (the Kuhn, or Freudenthal, subdivision: tet (0, e_a, e_a + e_b, e_a + e_b +
   e_c) for each order a, b, c of the axes), which fit face to face across cubes. Vertex (i, j, k)
   has id i + (nx + 1) (j + (ny + 1) k). Each rank makes its block of vertices and the tets of the
   cubes whose first corner is in it: no file, no rank holds the whole box. */
#include <msim/scene.h>
#include <algorithm>

PetscErrorCode MSimSceneGenerate_Box(MPI_Comm comm, MSimSceneData *s)
{
  PetscInt    n[3] = {4, 4, 4}, nn = 3, nl = 3;
  PetscReal   size[3] = {1, 1, 1}, young = 0, k = 1000;
  PetscBool   nset, lset;
  PetscMPIInt rank, nranks;

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim box scene (a tet box)", NULL);
  PetscCall(PetscOptionsIntArray("-msim_box_n", "Cubes along x, y, z", NULL, n, &nn, &nset));
  PetscCall(PetscOptionsRealArray("-msim_box_size", "Side lengths along x, y, z, m", NULL, size, &nl, &lset));
  PetscCall(PetscOptionsReal("-msim_young", "Young's modulus, Pa: each spring's stiffness E V_e / L^2 (V_e: volume of the tets around the edge) instead of -msim_stiffness", NULL, young, &young, NULL));
  PetscOptionsEnd();
  if (s->options_only) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCheck(!nset || nn == 3, comm, PETSC_ERR_ARG_WRONG, "-msim_box_n needs three comma-separated integers nx,ny,nz (got %" PetscInt_FMT ")", nn);
  PetscCheck(!lset || nl == 3, comm, PETSC_ERR_ARG_WRONG, "-msim_box_size needs three comma-separated numbers lx,ly,lz (got %" PetscInt_FMT ")", nl);
  for (int d = 0; d < 3; d++) {
    PetscCheck(n[d] >= 1 && n[d] <= 100000, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_box_n: %c count %" PetscInt_FMT " is not in [1, 100000]", "xyz"[d], n[d]);
    PetscCheck(size[d] > 0 && PetscIsNormalReal(size[d]), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_box_size: %c side must be > 0 m (got %g)", "xyz"[d], (double)size[d]);
  }
  PetscCheck((double)(n[0] + 1) * (n[1] + 1) * (n[2] + 1) < PETSC_MAX_INT / 4 && 6.0 * n[0] * n[1] * n[2] < PETSC_MAX_INT / 4, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_box_n %" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ": too many tets for this build's %d-bit indices", n[0], n[1], n[2], (int)(8 * sizeof(PetscInt)));
  PetscCheck(young >= 0 && !PetscIsInfOrNanReal(young), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_young must be > 0 Pa (got %g)", (double)young);
  PetscCall(MSimSceneGetStiffness(NULL, &k));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &nranks));

  const PetscInt nx = n[0] + 1, ny = n[1] + 1, nz = n[2] + 1;
  auto           id = [&](PetscInt i, PetscInt j, PetscInt l) { return i + nx * (j + ny * l); };
  MSimBlockLayout block;
  block.Set(nx * ny * nz, nranks);
  const PetscInt first = block.Start(rank), last = first + block.Count(rank);
  s->nv        = nx * ny * nz;
  s->cell_size = 4;
  s->k_cell    = k;
  s->young     = young;
  s->source    = "box";
  /* the 6 orders of the axes; odd permutations give a negative determinant: their tets are listed
     with two vertices swapped so that every tet has positive volume */
  const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  for (PetscInt v = first; v < last; v++) {
    const PetscInt i = v % nx, j = (v / nx) % ny, l = v / (nx * ny);
    s->vid.push_back(v);
    s->vx.insert(s->vx.end(), {size[0] * i / n[0], size[1] * j / n[1], size[2] * l / n[2]});
    if (i == n[0] || j == n[1] || l == n[2]) continue; /* no cube starts here */
    for (int p = 0; p < 6; p++) {
      PetscInt c[3] = {i, j, l}, t[4];
      t[0]          = id(c[0], c[1], c[2]);
      for (int q = 0; q < 3; q++) {
        c[perm[p][q]]++;
        t[q + 1] = id(c[0], c[1], c[2]);
      }
      if (p >= 3) std::swap(t[1], t[2]);
      s->cells.insert(s->cells.end(), t, t + 4);
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
