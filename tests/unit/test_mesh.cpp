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
   - masses by density add up to rho V;
   - hexahedra and prisms split into tets (a Gmsh file written here: a sheared grid whose nodes are
     listed in a shuffled order, so the split's rule on node ids meets every case): every tet
     positive, their volumes add up to det(A) times the grid's, every triangle face is shared by
     two tets or lies on the grid's boundary (a conforming split: neighbouring cells cut their
     common quadrangle alike), and the boundary triangles' area adds up to the sheared box's. */
#include "harness.h"
#include <msim/scene.h>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <random>
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
    const MSimSceneData *data;
    PetscCall(MSimSceneGetData(scene, &data));
    PetscInt held = (PetscInt)data->cells.size();
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &held, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
    CHECK(held == 0 && data->ncell == 6 * nx * ny * nz, "a box nothing draws holds %" PetscInt_FMT " cell corners and counts %" PetscInt_FMT " tets", held, data->ncell);
  }
  PetscCall(MSimSceneDestroy(&scene));
  PetscCall(PetscOptionsInsertString(NULL, "-msim_scene_keep_cells"));
  PetscCall(MSimSceneCreateFromOptions(PETSC_COMM_WORLD, &scene));
  const MSimSceneData  *data;
  PetscCall(MSimSceneGetData(scene, &data));
  const MSimSceneData   &s = *data;
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
  const MSimSceneData *da, *db;
  PetscCall(MSimSceneGetData(scene[0], &da));
  PetscCall(MSimSceneGetData(scene[1], &db));
  const MSimSceneData &a = *da, &b = *db;
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
  PetscInt nv, nfree_sys;
  PetscCall(MSimSystemGetSizes(s.sys, &nv, &nfree_sys, NULL));
  if (s.rank == 0) {
    PetscInt bad = 0, nfree = 0;
    for (PetscInt v = 0; v < nv; v++) {
      const PetscReal want = fixed[v] ? 0.0 : 1.0;
      nfree += fixed[v] ? 0 : 1;
      for (int c = 0; c < 3; c++) bad += all[3 * v + c] != want;
    }
    CHECK(bad == 0 && nfree == nfree_sys, "%s: %" PetscInt_FMT " gathered entries not 1 at free (0 at fixed) vertices", kScenes[which][0], bad);
  }
  CHECK(sum == 3.0 * nfree_sys, "%s: owned rows add up to %g, not 3 x %" PetscInt_FMT, kScenes[which][0], (double)sum, nfree_sys);
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
  {
    Vec M;
    PetscCall(MSimSystemGetMass(s.sys, &M));
    PetscCall(VecSum(M, &mass));
  }
  const PetscReal want = 3 * E * eps * eps * kVolume[which];
  CHECK(PetscAbsReal(energy - want) <= 1e-11 * want, "%s: spring energy %.15g under dilation, want 3 E eps^2 V = %.15g", kScenes[which][0], (double)energy, (double)want);
  CHECK(PetscAbsReal(mass / 3 - rho * kVolume[which]) <= 1e-12 * rho * kVolume[which], "%s: masses add up to %.15g, want rho V = %.15g", kScenes[which][0], (double)(mass / 3), (double)(rho * kVolume[which]));
  NOTE("%s: spring energy %.12g, 3 E eps^2 V %.12g (relative difference %.1e)\n", kScenes[which][0], (double)energy, (double)want, (double)((energy - want) / want));
  PetscCall(TestSimDestroy(&s));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A grid of n[0] x n[1] x n[2] cells on the unit box, mapped by x -> A x, as a Gmsh 2.2 file of
   hexahedra (prisms: each cell's xy square cut in two, the diagonal alternating), nodes listed in
   a shuffled order under shuffled tags; then the split checked as the comment at the top says. */
static PetscErrorCode TestSplit(bool prisms)
{
  const int       n[3] = {3, 4, 2};
  const PetscReal A[3][3] = {{1.0, 0.3, 0.0}, {0.0, 0.8, 0.2}, {0.1, 0.0, 1.5}};
  const PetscReal detA = A[0][0] * (A[1][1] * A[2][2] - A[1][2] * A[2][1]) - A[0][1] * (A[1][0] * A[2][2] - A[1][2] * A[2][0]) + A[0][2] * (A[1][0] * A[2][1] - A[1][1] * A[2][0]);
  auto            node = [&](int i, int j, int k) { return (i * (n[1] + 1) + j) * (n[2] + 1) + k; };
  const int       nn = (n[0] + 1) * (n[1] + 1) * (n[2] + 1);
  std::vector<int> order(nn), tag(nn);
  std::mt19937     rng(prisms ? 7 : 3);
  PetscMPIInt      rank;
  char             path[PETSC_MAX_PATH_LEN];

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  for (int v = 0; v < nn; v++) order[v] = tag[v] = v;
  std::shuffle(order.begin(), order.end(), rng); /* order[q]: the grid node written q-th */
  std::shuffle(tag.begin(), tag.end(), rng);
  PetscCall(PetscSNPrintf(path, sizeof path, "/tmp/msim_test_split_%d_%d.msh", (int)getpid(), (int)rank));
  FILE *f = fopen(path, "w");
  PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
  fprintf(f, "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n%d\n", nn);
  for (int q = 0; q < nn; q++) {
    const int v = order[q], i = v / ((n[1] + 1) * (n[2] + 1)), j = (v / (n[2] + 1)) % (n[1] + 1), k = v % (n[2] + 1);
    const PetscReal p[3] = {(PetscReal)i / n[0], (PetscReal)j / n[1], (PetscReal)k / n[2]};
    fprintf(f, "%d %.17g %.17g %.17g\n", tag[v] + 1, A[0][0] * p[0] + A[0][1] * p[1] + A[0][2] * p[2], A[1][0] * p[0] + A[1][1] * p[1] + A[1][2] * p[2], A[2][0] * p[0] + A[2][1] * p[1] + A[2][2] * p[2]);
  }
  std::vector<std::vector<int>> cells;
  for (int i = 0; i < n[0]; i++)
    for (int j = 0; j < n[1]; j++)
      for (int k = 0; k < n[2]; k++) {
        const int c[8] = {node(i, j, k), node(i + 1, j, k), node(i + 1, j + 1, k), node(i, j + 1, k), node(i, j, k + 1), node(i + 1, j, k + 1), node(i + 1, j + 1, k + 1), node(i, j + 1, k + 1)};
        if (!prisms) cells.push_back({5, c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]});
        else if ((i + j) % 2) {
          cells.push_back({6, c[0], c[1], c[2], c[4], c[5], c[6]});
          cells.push_back({6, c[0], c[2], c[3], c[4], c[6], c[7]});
        } else {
          cells.push_back({6, c[0], c[1], c[3], c[4], c[5], c[7]});
          cells.push_back({6, c[1], c[2], c[3], c[5], c[6], c[7]});
        }
      }
  fprintf(f, "$EndNodes\n$Elements\n%zu\n", cells.size());
  for (size_t e = 0; e < cells.size(); e++) {
    fprintf(f, "%zu %d 2 1 1", e + 1, cells[e][0]);
    for (size_t q = 1; q < cells[e].size(); q++) fprintf(f, " %d", tag[cells[e][q]] + 1);
    fprintf(f, "\n");
  }
  fprintf(f, "$EndElements\n");
  fclose(f);

  MSimMesh m;
  PetscCall(MSimMeshReadFile(path, 4, &m));
  PetscCall(MSimMeshCheck(&m)); /* every tet positive, none flat */
  unlink(path);
  PetscReal                                vol = 0, area = 0;
  std::map<std::array<PetscInt, 3>, int> faces;
  for (PetscInt t = 0; t < m.ncell; t++) {
    const PetscInt *c = &m.cell[4 * t];
    vol += MSimTetVolume(&m.x[3 * c[0]], &m.x[3 * c[1]], &m.x[3 * c[2]], &m.x[3 * c[3]]);
    for (int o = 0; o < 4; o++) {
      std::array<PetscInt, 3> tri = {c[(o + 1) % 4], c[(o + 2) % 4], c[(o + 3) % 4]};
      std::sort(tri.begin(), tri.end());
      faces[tri]++;
    }
  }
  /* a face seen once must lie on the boundary: its corners on one face of the unit box (in the
     grid's coordinates, found back from the file's order) */
  std::vector<std::array<int, 3>> ijk(nn);
  for (int q = 0; q < nn; q++) {
    const int v = order[q];
    ijk[q]      = {v / ((n[1] + 1) * (n[2] + 1)), (v / (n[2] + 1)) % (n[1] + 1), v % (n[2] + 1)};
  }
  PetscInt over = 0, inner = 0;
  for (const auto &fc : faces) {
    over += fc.second > 2;
    if (fc.second != 1) continue;
    bool on = false;
    for (int d = 0; d < 3; d++)
      for (int side : {0, n[d]}) {
        bool all = true;
        for (PetscInt v : fc.first) all = all && ijk[MSimMeshFileId(&m, v)][d] == side;
        on = on || all;
      }
    inner += !on;
    area += MSimTriangleArea(&m.x[3 * fc.first[0]], &m.x[3 * fc.first[1]], &m.x[3 * fc.first[2]]);
  }
  /* the sheared box's surface: |A e_a x A e_b| for each pair of axes, twice */
  PetscReal want_area = 0;
  for (int a = 0; a < 3; a++) {
    const int       b = (a + 1) % 3;
    const PetscReal u[3] = {A[0][a], A[1][a], A[2][a]}, w[3] = {A[0][b], A[1][b], A[2][b]};
    const PetscReal cr[3] = {u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]};
    want_area += 2 * std::sqrt(cr[0] * cr[0] + cr[1] * cr[1] + cr[2] * cr[2]);
  }
  const char *what = prisms ? "prisms" : "hexahedra";
  const int   per  = prisms ? 2 * 3 : 6; /* tets per grid cell */
  CHECK(m.ncell == per * n[0] * n[1] * n[2], "%s: %" PetscInt_FMT " tets, want %d", what, m.ncell, per * n[0] * n[1] * n[2]);
  CHECK(m.nv == nn && m.file_id.empty(), "%s: every node kept (%" PetscInt_FMT " of %d)", what, m.nv, nn);
  CHECK(PetscAbsReal(vol - detA) < 1e-13, "%s: tets add up to %.15g, want det(A) = %.15g", what, (double)vol, (double)detA);
  CHECK(over == 0 && inner == 0, "%s: %" PetscInt_FMT " faces in more than two tets, %" PetscInt_FMT " inside the grid in only one (a non-conforming split)", what, over, inner);
  CHECK(PetscAbsReal(area - want_area) < 1e-12, "%s: boundary triangles add up to %.15g, want %.15g", what, (double)area, (double)want_area);
  NOTE("%s split: %" PetscInt_FMT " tets, volume %.15g (det A %.15g), boundary area %.15g (%.15g)\n", what, m.ncell, (double)vol, (double)detA, (double)area, (double)want_area);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Main(void)
{
  PetscFunctionBeginUser;
  PetscCall(TestSplit(false));
  PetscCall(TestSplit(true));
  PetscCall(TestBoxGeometry());
  PetscCall(TestBoxDirect());
  for (int k = 0; k < 3; k++) {
    PetscCall(TestOwnership(k));
    PetscCall(TestDilation(k));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(Main)
