/* Structured tet box: nx x ny x nz cubes (cells of -msim_box_size / n), each cut into 6 tets along
   its main diagonal (the Kuhn, or Freudenthal, subdivision: tet (0, e_a, e_a + e_b, e_a + e_b +
   e_c) for each order a, b, c of the axes), which fit face to face across cubes. Vertex (i, j, k)
   has id i + (nx + 1) (j + (ny + 1) k). Built on every rank: no file, no broadcast. */
#include <msim/scene.h>
#include <algorithm>

PetscErrorCode MSimSceneGenerate_Box(MPI_Comm comm, MSimSceneData *s)
{
  PetscInt  n[3] = {4, 4, 4}, nn = 3, nl = 3;
  PetscReal size[3] = {1, 1, 1}, young = 0, k = 1000;
  PetscBool nset, lset;
  MSimMesh  m;

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

  const PetscInt nx = n[0] + 1, ny = n[1] + 1, nz = n[2] + 1;
  auto           id = [&](PetscInt i, PetscInt j, PetscInt l) { return i + nx * (j + ny * l); };
  m.file      = "box";
  m.nper      = 4;
  m.cell_name = "tet";
  m.nv        = nx * ny * nz;
  m.x.resize(3 * (size_t)m.nv);
  for (PetscInt l = 0; l < nz; l++)
    for (PetscInt j = 0; j < ny; j++)
      for (PetscInt i = 0; i < nx; i++) {
        PetscReal *p = &m.x[3 * (size_t)id(i, j, l)];
        p[0]         = size[0] * i / n[0];
        p[1]         = size[1] * j / n[1];
        p[2]         = size[2] * l / n[2];
      }
  /* the 6 orders of the axes; odd permutations give a negative determinant: their tets are listed
     with two vertices swapped so that every tet has positive volume */
  const int perm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
  m.ncell              = 6 * n[0] * n[1] * n[2];
  m.cell.reserve(4 * (size_t)m.ncell);
  for (PetscInt l = 0; l < n[2]; l++)
    for (PetscInt j = 0; j < n[1]; j++)
      for (PetscInt i = 0; i < n[0]; i++)
        for (int p = 0; p < 6; p++) {
          PetscInt c[3] = {i, j, l}, v[4];
          v[0]          = id(c[0], c[1], c[2]);
          for (int q = 0; q < 3; q++) {
            c[perm[p][q]]++;
            v[q + 1] = id(c[0], c[1], c[2]);
          }
          if (p >= 3) std::swap(v[1], v[2]);
          m.cell.insert(m.cell.end(), v, v + 4);
        }
  PetscCall(MSimSceneFromTets(&m, k, young, s));
  s->source = "box";
  PetscFunctionReturn(PETSC_SUCCESS);
}
