/* Structured tet box: nx x ny x nz cubes (cells of -msim_box_size / n), each cut into 6 tets along
   its main diagonal (the Kuhn, or Freudenthal, subdivision: tet (0, e_a, e_a + e_b, e_a + e_b +
   e_c) for each order a, b, c of the axes), which fit face to face across cubes. Vertex (i, j, k)
   has id i + (nx + 1) (j + (ny + 1) k). Each rank makes its block of vertices, the tets of the
   cubes whose first corner is in it, and (unless -msim_refine needs the tets alone) the springs
   from its vertices and their masses directly: a tet edge runs from a vertex along one of the 7
   directions with components 0 and 1, and which of them are edges, and how many tets share
   each, follows from the 6 paths of the subdivision in the cubes around it. No exchange, no edge
   search: the same springs and masses as the edges of the tets give (-msim_box_springs cells
   takes that way, for tests), at a fraction of the setup. */
#include <msim/scene.h>
#include <algorithm>
#include <cmath>

/* the 6 orders of the axes; odd permutations give a negative determinant: their tets are listed
   with two vertices swapped so that every tet has positive volume */
static const int kPerm[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1}, {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};

/* Tets of one cube with corners a and b (cube-local corners as bit masks: bit d set = +1 along
   axis d): tet p runs 0 -> e_a -> e_a + e_b -> e_a + e_b + e_c and holds a corner iff it is one
   of those four. */
static int TetsWith(int a, int b)
{
  int n = 0;
  for (int p = 0; p < 6; p++) {
    int path[4] = {0, 1 << kPerm[p][0], (1 << kPerm[p][0]) | (1 << kPerm[p][1]), 7}, ha = 0, hb = 0;
    for (int q = 0; q < 4; q++) {
      ha |= path[q] == a;
      hb |= path[q] == b;
    }
    n += ha && hb;
  }
  return n;
}

/* This rank's springs and measure shares: for vertex v and direction d, the cubes that hold both
   v and v + d, and the tets of each that hold both */
static void BoxSprings(MSimSceneData *s, const PetscInt n[3], const PetscReal size[3], PetscInt first, PetscInt last, PetscReal k, PetscReal young)
{
  const PetscInt  nx = n[0] + 1, ny = n[1] + 1;
  const PetscReal vt = size[0] * size[1] * size[2] / (6.0 * n[0] * n[1] * n[2]);
  /* the 7 directions by ascending id offset: the order of the springs the edges of tets give */
  const int dirs[7] = {1, 2, 3, 4, 5, 6, 7};
  int       order[7];
  for (int q = 0; q < 7; q++) order[q] = dirs[q];
  std::sort(order, order + 7, [&](int a, int b) { return (a & 1) + nx * ((a >> 1) & 1) + nx * ny * (a >> 2) < (b & 1) + nx * ((b >> 1) & 1) + nx * ny * (b >> 2); });
  auto pos = [&](PetscInt i, PetscInt j, PetscInt l, PetscReal *p) {
    p[0] = size[0] * i / n[0];
    p[1] = size[1] * j / n[1];
    p[2] = size[2] * l / n[2];
  };
  int tets_with[8][8]; /* TetsWith, once: the loop below asks it 60 times per vertex */
  for (int a = 0; a < 8; a++)
    for (int b = 0; b < 8; b++) tets_with[a][b] = TetsWith(a, b);
  s->share.assign(last - first, 0.0);
  for (auto *v : {&s->si, &s->sj}) v->reserve(7 * (size_t)(last - first));
  for (auto *v : {&s->sk, &s->sL}) v->reserve(7 * (size_t)(last - first));
  /* a vertex with all 8 cubes around it has the same tets around it and along each direction as
     every other such vertex: counted once (the boundary's are counted cube by cube) */
  int inner_around = 0, inner_tets[7] = {0, 0, 0, 0, 0, 0, 0};
  for (int m = 0; m < 8; m++) inner_around += tets_with[m][m];
  for (int q = 0; q < 7; q++)
    for (int m = 0; m < 8; m++)
      if (!(m & order[q])) inner_tets[q] += tets_with[m][m | order[q]];
  for (PetscInt v = first; v < last; v++) {
    const PetscInt c[3]  = {v % nx, (v / nx) % ny, v / (nx * ny)};
    const bool     inner = c[0] >= 1 && c[0] < n[0] && c[1] >= 1 && c[1] < n[1] && c[2] >= 1 && c[2] < n[2];
    /* tets around v: over the cubes that hold it, at cube-local corner m */
    int around = inner ? inner_around : 0;
    for (int m = 0; m < 8 && !inner; m++) {
      bool in = true;
      for (int d = 0; d < 3; d++) in = in && c[d] - ((m >> d) & 1) >= 0 && c[d] - ((m >> d) & 1) < n[d];
      if (in) around += tets_with[m][m];
    }
    s->share[v - first] = around * vt / 4.0;
    for (int q = 0; q < 7; q++) {
      const int dm = order[q];
      PetscInt  e[3];
      bool      ok = true;
      for (int d = 0; d < 3; d++) {
        e[d] = c[d] + ((dm >> d) & 1);
        ok   = ok && e[d] <= n[d];
      }
      if (!ok) continue;
      int tets = inner ? inner_tets[q] : 0;
      for (int m = 0; m < 8 && !inner; m++) { /* the cube whose local corner m is v */
        if (m & dm) continue;                  /* v + d must stay in the cube */
        bool in = true;
        for (int d = 0; d < 3; d++) in = in && c[d] - ((m >> d) & 1) >= 0 && c[d] - ((m >> d) & 1) < n[d];
        if (in) tets += tets_with[m][m | dm];
      }
      if (!tets) continue; /* the other diagonals: no tet has them */
      PetscReal a[3], b[3];
      pos(c[0], c[1], c[2], a);
      pos(e[0], e[1], e[2], b);
      const PetscReal L = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
      s->si.push_back(v);
      s->sj.push_back(e[0] + nx * (e[1] + ny * e[2]));
      s->sL.push_back(L);
      s->sk.push_back(young > 0 ? young * tets * vt / (L * L) : k);
    }
  }
  s->measure      = size[0] * size[1] * size[2];
  s->springs_made = PETSC_TRUE;
}

PetscErrorCode MSimSceneGenerate_Box(MPI_Comm comm, MSimSceneData *s)
{
  PetscInt    n[4] = {4, 4, 4, 0}, nn = 4, nl = 4; /* one more than needed: PETSc drops values past nn, nl silently */
  PetscReal   size[4] = {1, 1, 1, 0};
  PetscBool   nset, lset;
  PetscMPIInt rank, nranks;
  PetscInt    way = 0;
  const char *ways[] = {"direct", "cells"};

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim box scene (a tet box)", NULL);
  PetscCall(MSimOptionsIntArray("-msim_box_n", "Cubes along x, y, z", NULL, n, &nn, &nset));
  PetscCall(MSimOptionsRealArray("-msim_box_size", "Side lengths along x, y, z, m", NULL, size, &nl, &lset));
  PetscCall(PetscOptionsEList("-msim_box_springs", "How the box gets its springs and masses: direct (from its structure) or cells (the edges of its tets, as a mesh)", NULL, ways, 2, ways[0], &way, NULL));
  PetscOptionsEnd();
  if (s->options_only) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCheck(!nset || nn == 3, comm, PETSC_ERR_ARG_WRONG, "-msim_box_n needs three comma-separated integers nx,ny,nz (got %" PetscInt_FMT "%s)", nn, nn > 3 ? " or more" : "");
  PetscCheck(!lset || nl == 3, comm, PETSC_ERR_ARG_WRONG, "-msim_box_size needs three comma-separated numbers lx,ly,lz (got %" PetscInt_FMT "%s)", nl, nl > 3 ? " or more" : "");
  for (int d = 0; d < 3; d++) {
    PetscCheck(n[d] >= 1 && n[d] <= 100000, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_box_n: %c count %" PetscInt_FMT " is not in [1, 100000]", "xyz"[d], n[d]);
    PetscCheck(size[d] > 0 && PetscIsNormalReal(size[d]), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_box_size: %c side must be > 0 m (got %g)", "xyz"[d], (double)size[d]);
  }
  PetscCheck((double)(n[0] + 1) * (n[1] + 1) * (n[2] + 1) < PETSC_MAX_INT / 4 && 6.0 * n[0] * n[1] * n[2] < PETSC_MAX_INT / 4, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_box_n %" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ": too many tets for this build's %d-bit indices", n[0], n[1], n[2], (int)(8 * sizeof(PetscInt)));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &nranks));

  const PetscInt nx = n[0] + 1, ny = n[1] + 1, nz = n[2] + 1;
  auto           id = [&](PetscInt i, PetscInt j, PetscInt l) { return i + nx * (j + ny * l); };
  MSimBlockLayout block;
  block.Set(nx * ny * nz, nranks);
  const PetscInt first = block.Start(rank), last = first + block.Count(rank);
  s->nv        = nx * ny * nz;
  s->cell_size = 4;
  s->vid.reserve(last - first);
  s->vx.reserve(3 * (size_t)(last - first));
  /* springs made directly and cells neither refined nor drawn: counted, not stored (a fifth of
     a large box's setup memory) */
  const PetscBool store = (PetscBool)(s->cells_wanted || way != 0);
  if (store) s->cells.reserve(24 * (size_t)(last - first));
  s->k_cell    = s->stiffness;
  s->source    = "box";
  for (PetscInt v = first; v < last; v++) {
    const PetscInt i = v % nx, j = (v / nx) % ny, l = v / (nx * ny);
    s->vid.push_back(v);
    s->vx.insert(s->vx.end(), {size[0] * i / n[0], size[1] * j / n[1], size[2] * l / n[2]});
    if (i == n[0] || j == n[1] || l == n[2]) continue; /* no cube starts here */
    if (!store) {
      s->cells_not_stored += 6;
      continue;
    }
    for (int p = 0; p < 6; p++) {
      PetscInt c[3] = {i, j, l}, t[4];
      t[0]          = id(c[0], c[1], c[2]);
      for (int q = 0; q < 3; q++) {
        c[kPerm[p][q]]++;
        t[q + 1] = id(c[0], c[1], c[2]);
      }
      if (p >= 3) std::swap(t[1], t[2]);
      s->cells.insert(s->cells.end(), t, t + 4);
    }
  }
  if (way == 0) BoxSprings(s, n, size, first, last, s->stiffness, s->young); /* s->young: -msim_young, read by the scene */
  PetscFunctionReturn(PETSC_SUCCESS);
}
