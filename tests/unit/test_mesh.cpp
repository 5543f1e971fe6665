/* Tet scenes through the library, at any rank count:
   - the box's springs and masses made from its structure equal those of its tets' edges;
   - the Kuhn box: every tet has positive volume and they add up to lx ly lz; its springs are the
     unique edges: (nx+1)(ny+1)(nz+1) vertices, 3 axis families, 3 face-diagonal families and one
     body diagonal per cube, counted here;
   - every free vertex is owned by exactly one rank: a Vec of ones in the owned rows gathered to
     input order is 1 at every free vertex and sums to the free count;
   - springs from Young's modulus: under the uniform dilation x -> (1 + eps) x the springs store
     sum_e k_e (eps L_e)^2 / 2 = E eps^2 sum_e V_e / 2 = 3 E eps^2 V (every tet has 6 edges, V_e
     sums the volumes of the tets around edge e), for the box, the 5-tet cube and the Gmsh beam;
   - masses by density add up to rho V. */
#include "harness.h"
#include <msim/scene.h>
#include <vector>

static const char *kScenes[][2] = {
  {"box", "-msim_scene box -msim_box_n 3,4,5 -msim_box_size 1,2,3"},
  {"cube5", "-msim_scene tet -msim_mesh_file " MSIM_SOURCE_DIR "/tests/data/meshes/cube5.node"},
  {"beam", "-msim_scene tet -msim_mesh_file " MSIM_SOURCE_DIR "/examples/meshes/beam.msh"},
};
static const PetscReal kVolume[] = {6.0, 1.0, 0.4 * 0.1 * 0.1};

static PetscErrorCode TestBoxGeometry(void)
{
  MSimScene scene;
  PetscReal vol = 0, vmin = PETSC_MAX_REAL;
  const int nx = 3, ny = 4, nz = 5;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsClear(NULL));
  PetscCall(PetscOptionsInsertString(NULL, kScenes[0][1]));
  /* nothing draws or refines this box: it counts its tets and stores none */
  PetscCall(MSimSceneCreateFromOptions(PETSC_COMM_WORLD, &scene));
  {
    PetscInt held = (PetscInt)scene->data.cells.size();
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &held, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
    CHECK(held == 0 && scene->data.ncell == 6 * nx * ny * nz, "a box nothing draws holds %" PetscInt_FMT " cell corners and counts %" PetscInt_FMT " tets", held, scene->data.ncell);
  }
  PetscCall(MSimSceneDestroy(&scene));
  PetscCall(PetscOptionsInsertString(NULL, "-msim_scene_keep_cells"));
  PetscCall(MSimSceneCreateFromOptions(PETSC_COMM_WORLD, &scene));
  const MSimSceneData  &s = scene->data;
  std::vector<PetscReal> x;
  /* each rank's tets, with their corners' positions from the directory */
  PetscCall(MSimSceneFetchPositions(PETSC_COMM_WORLD, &s, s.cells, x));
  for (size_t t = 0; t < s.cells.size() / 4; t++) {
    PetscReal v = MSimTetVolume(&x[12 * t], &x[12 * t + 3], &x[12 * t + 6], &x[12 * t + 9]);
    vol += v;
    vmin = PetscMin(vmin, v);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &vol, 1, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &vmin, 1, MPIU_REAL, MPIU_MIN, PETSC_COMM_WORLD));
  const PetscInt edges = nx * (ny + 1) * (nz + 1) + (nx + 1) * ny * (nz + 1) + (nx + 1) * (ny + 1) * nz /* axes */
                       + nx * ny * (nz + 1) + (nx + 1) * ny * nz + nx * (ny + 1) * nz /* one diagonal per face */
                       + nx * ny * nz;                                                 /* one body diagonal per cube */
  CHECK(s.nv == (nx + 1) * (ny + 1) * (nz + 1), "box vertices %" PetscInt_FMT, s.nv);
  CHECK(s.ncell == 6 * nx * ny * nz, "box tets %" PetscInt_FMT, s.ncell);
  CHECK(s.nspring == edges, "box springs %" PetscInt_FMT ", want %" PetscInt_FMT, s.nspring, edges);
  CHECK(vmin > 0, "every box tet has positive volume (least %g)", (double)vmin);
  CHECK(PetscAbsReal(vol - 6.0) < 1e-13, "box tets add up to %.15g, not 6", (double)vol);
  NOTE("box 3 x 4 x 5: %" PetscInt_FMT " vertices, %" PetscInt_FMT " tets, %" PetscInt_FMT " springs, volume %.15g\n", s.nv, s.ncell, s.nspring, (double)vol);
  PetscCall(MSimSceneDestroy(&scene));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The box's springs and masses made from its structure equal those the edges of its tets give */
static PetscErrorCode TestBoxDirect(void)
{
  MSimScene scene[2];
  PetscInt  bad = 0;
  PetscReal worst = 0;

  PetscFunctionBeginUser;
  for (int w = 0; w < 2; w++) {
    PetscCall(PetscOptionsClear(NULL));
    PetscCall(PetscOptionsInsertString(NULL, "-msim_scene box -msim_box_n 3,4,5 -msim_box_size 1,2,3 -msim_young 2e5 -msim_density 700"));
    PetscCall(PetscOptionsSetValue(NULL, "-msim_box_springs", w ? "cells" : "direct"));
    PetscCall(MSimSceneCreateFromOptions(PETSC_COMM_WORLD, &scene[w]));
  }
  const MSimSceneData &a = scene[0]->data, &b = scene[1]->data;
  /* both hold each spring where its lower vertex has its directory, in the order of its ends */
  bad += a.si != b.si || a.sj != b.sj || a.mass.size() != b.mass.size();
  for (size_t q = 0; !bad && q < a.sk.size(); q++) worst = PetscMax(worst, PetscMax(PetscAbsReal(a.sk[q] - b.sk[q]) / b.sk[q], PetscAbsReal(a.sL[q] - b.sL[q]) / b.sL[q]));
  for (size_t v = 0; !bad && v < a.mass.size(); v++) worst = PetscMax(worst, PetscAbsReal(a.mass[v] - b.mass[v]) / b.mass[v]);
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &worst, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  CHECK(!bad, "the box's direct springs are not the edges of its tets on %" PetscInt_FMT " ranks", bad);
  CHECK(worst < 1e-12, "the box's direct stiffnesses, rest lengths or masses differ from the tets' by %g", (double)worst);
  NOTE("box springs made directly and from the tets' edges: %" PetscInt_FMT " springs, largest relative difference %.1e\n", a.nspring, (double)worst);
  PetscCall(MSimSceneDestroy(&scene[0]));
  PetscCall(MSimSceneDestroy(&scene[1]));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestOwnership(int which)
{
  TestSim                s;
  char                   opts[1024];
  std::vector<PetscReal> all;
  PetscReal              sum;
  Vec                    ones;

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(opts, sizeof(opts), "%s -msim_fix_plane z_max", kScenes[which][1]));
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(VecDuplicate(s.X, &ones));
  PetscCall(VecSet(ones, 1.0));
  PetscCall(VecSum(ones, &sum));
  PetscCall(MSimSystemGatherVector(s.sys, ones, all));
  std::vector<char>     fixed;
  std::vector<PetscInt> cells;
  PetscCall(MSimSystemGatherTopology(s.sys, fixed, cells));
  if (s.sys->rank == 0) {
    PetscInt bad = 0, nfree = 0;
    for (PetscInt v = 0; v < s.sys->nv; v++) {
      const PetscReal want = fixed[v] ? 0.0 : 1.0;
      nfree += fixed[v] ? 0 : 1;
      for (int c = 0; c < 3; c++) bad += all[3 * v + c] != want;
    }
    CHECK(bad == 0 && nfree == s.sys->nfree, "%s: %" PetscInt_FMT " gathered entries not 1 at free (0 at fixed) vertices", kScenes[which][0], bad);
  }
  CHECK(sum == 3.0 * s.sys->nfree, "%s: owned rows add up to %g, not 3 x %" PetscInt_FMT, kScenes[which][0], (double)sum, s.sys->nfree);
  PetscCall(VecDestroy(&ones));
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode TestDilation(int which)
{
  TestSim         s;
  char            opts[1024];
  PetscReal       energy, mass;
  const PetscReal E = 2.5e5, eps = 1e-3, rho = 1200;

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(opts, sizeof(opts), "%s -msim_young %g -msim_density %g -msim_prestretch %.17g -msim_fix none -msim_gravity 0,0,0", kScenes[which][1], (double)E, (double)rho, 1 + eps));
  PetscCall(TestSimCreate(opts, &s));
  PetscCall(MSimSystemSpringEnergy(s.sys, 0.0, s.X, &energy));
  PetscCall(VecSum(s.sys->mass, &mass));
  const PetscReal want = 3 * E * eps * eps * kVolume[which];
  CHECK(PetscAbsReal(energy - want) <= 1e-11 * want, "%s: spring energy %.15g under dilation, want 3 E eps^2 V = %.15g", kScenes[which][0], (double)energy, (double)want);
  CHECK(PetscAbsReal(mass / 3 - rho * kVolume[which]) <= 1e-12 * rho * kVolume[which], "%s: masses add up to %.15g, want rho V = %.15g", kScenes[which][0], (double)(mass / 3), (double)(rho * kVolume[which]));
  NOTE("%s: spring energy %.12g, 3 E eps^2 V %.12g (relative difference %.1e)\n", kScenes[which][0], (double)energy, (double)want, (double)((energy - want) / want));
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Main(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestBoxGeometry());
  PetscCall(TestBoxDirect());
  for (int k = 0; k < 3; k++) {
    PetscCall(TestOwnership(k));
    PetscCall(TestDilation(k));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(Main)
