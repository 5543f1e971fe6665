/* What a partition into P parts costs, for the scaling model (runs/scaling/study.py), without P
   ranks: builds a scene on one rank from msim's options, partitions its free-vertex graph into each
   P of -parts with METIS k-way (msim's options: seed 7) and with natural blocks, and prints, per
   P, what the busiest part carries under msim's rules: owned springs (a spring belongs to the part
   of its first free end), owned vertices, ghost vertices (the other free ends of its owned and
   halo springs), neighbours it exchanges with, and the edge cut. One CSV line per (P, partition).
   With -pingpong (2 ranks) it times MPI messages of 8 B to 4 MB between two ranks instead: half
   the round trip, best of many. With -near_z Z it prints instead, per P and part of the METIS
   and the natural partitions, the part's free vertices and those with rest z <= Z: which ranks
   own a box's bottom face, the vertices a plane under it touches (runs/contact/scaling.py).
   Usage: msim_partition_model [msim scene options] -parts 2,4,...,1024 [-near_z Z]
          mpirun -n 2 msim_partition_model -pingpong */
#include <msim/system.h>
#include <msim/init.h>
#include <metis.h>
#include <algorithm>
#include <slepcsys.h>

static PetscErrorCode PingPong(void)
{
  PetscMPIInt rank, size;
  std::vector<char> buf(1 << 22);

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCheck(size == 2, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "-pingpong runs on 2 ranks");
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "bytes,half_round_trip_s\n"));
  for (size_t n = 8; n <= buf.size(); n *= 4) {
    const int reps = n < 65536 ? 2000 : 100;
    double    best = 1e30;
    for (int trial = 0; trial < 5; trial++) {
      PetscCallMPI(MPI_Barrier(PETSC_COMM_WORLD));
      double t0 = MPI_Wtime();
      for (int r = 0; r < reps; r++) {
        if (rank == 0) {
          PetscCallMPI(MPI_Send(buf.data(), (int)n, MPI_CHAR, 1, 0, PETSC_COMM_WORLD));
          PetscCallMPI(MPI_Recv(buf.data(), (int)n, MPI_CHAR, 1, 0, PETSC_COMM_WORLD, MPI_STATUS_IGNORE));
        } else {
          PetscCallMPI(MPI_Recv(buf.data(), (int)n, MPI_CHAR, 0, 0, PETSC_COMM_WORLD, MPI_STATUS_IGNORE));
          PetscCallMPI(MPI_Send(buf.data(), (int)n, MPI_CHAR, 0, 0, PETSC_COMM_WORLD));
        }
      }
      best = std::min(best, (MPI_Wtime() - t0) / (2.0 * reps));
    }
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%zu,%.4e\n", n, best));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the busiest part's load for one assignment of free vertices to parts */
static void PartStats(PetscInt P, const std::vector<PetscInt> &part, const std::vector<PetscInt> &fa, const std::vector<PetscInt> &fb, const char *name, PetscInt nv, PetscInt nspring)
{
  std::vector<PetscInt>              owned(P, 0), springs(P, 0), halo(P, 0), ghosts(P, 0), nbrs(P, 0);
  std::vector<std::vector<PetscInt>> ghost(P), nbr(P);
  PetscInt                           cut = 0;
  for (PetscInt p : part) owned[p]++;
  for (size_t s = 0; s < fa.size(); s++) {
    const PetscInt a = fa[s], b = fb[s]; /* free numbers, -1 fixed; a spring with a free end */
    const PetscInt o = a >= 0 ? part[a] : part[b];
    springs[o]++;
    if (a >= 0 && b >= 0 && part[a] != part[b]) {
      cut++;
      const PetscInt q = part[b];
      halo[q]++;
      /* owner o sees b as a ghost; q keeps the halo copy and sees a */
      ghost[o].push_back(b);
      ghost[q].push_back(a);
    }
  }
  for (PetscInt p = 0; p < P; p++) {
    auto &g = ghost[p];
    std::sort(g.begin(), g.end());
    g.erase(std::unique(g.begin(), g.end()), g.end());
    ghosts[p] = (PetscInt)g.size();
    for (PetscInt v : g) nbr[p].push_back(part[v]);
    std::sort(nbr[p].begin(), nbr[p].end());
    nbr[p].erase(std::unique(nbr[p].begin(), nbr[p].end()), nbr[p].end());
    nbrs[p] = (PetscInt)nbr[p].size();
  }
  /* the spring sweep of a part covers its owned and its halo springs; those with a ghost end (its
     cut springs and its halo) wait for the exchange, the others overlap it */
  std::vector<PetscInt> work(P), ghosted(P);
  std::vector<PetscInt> cutown(P, 0);
  for (size_t s = 0; s < fa.size(); s++)
    if (fa[s] >= 0 && fb[s] >= 0 && part[fa[s]] != part[fb[s]]) cutown[part[fa[s]]]++;
  for (PetscInt p = 0; p < P; p++) {
    work[p]    = springs[p] + halo[p];
    ghosted[p] = cutown[p] + halo[p];
  }
  auto   mx  = [](const std::vector<PetscInt> &v) { return *std::max_element(v.begin(), v.end()); };
  double sum = 0, gsum = 0;
  for (PetscInt p = 0; p < P; p++) {
    sum += springs[p];
    gsum += ghosts[p];
  }
  PetscCallAbort(PETSC_COMM_SELF, PetscPrintf(PETSC_COMM_SELF, "%s,%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%.1f,%" PetscInt_FMT ",%.4f\n", name, P, nv, nspring, mx(owned), mx(springs), mx(work), mx(ghosted), mx(ghosts), mx(nbrs), gsum / P, cut, mx(springs) * P / sum));
}

static PetscErrorCode Model(void)
{
  MSimScene              scene;
  PetscInt               parts[64], nparts = 64;
  PetscBool              set;
  std::vector<PetscInt>  fid, fa, fb, xadj, adj;
  PetscReal              nearz = 0; /* -near_z: count each part's vertices at or below it */
  PetscBool              near  = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsGetIntArray(NULL, NULL, "-parts", parts, &nparts, &set));
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-near_z", &nearz, &near));
  PetscCheck(set, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "-parts P1,P2,... is needed");
  PetscCall(MSimSceneCreateFromOptions(PETSC_COMM_WORLD, &scene));
  const MSimSceneData   *data;
  PetscCall(MSimSceneGetData(scene, &data));
  const MSimSceneData &S = *data;
  /* one rank: the directory holds every vertex, and every spring is here */
  PetscInt nfree = 0;
  fid.assign(S.nv, -1);
  for (PetscInt v = 0; v < S.nv; v++)
    if (!S.fixed[v]) fid[v] = nfree++;
  std::vector<PetscInt> deg(nfree + 1, 0);
  for (size_t s = 0; s < S.si.size(); s++) {
    const PetscInt a = fid[S.si[s]], b = fid[S.sj[s]];
    if (a < 0 && b < 0) continue;
    fa.push_back(a);
    fb.push_back(b);
    if (a >= 0 && b >= 0) {
      deg[a + 1]++;
      deg[b + 1]++;
    }
  }
  for (PetscInt v = 0; v < nfree; v++) deg[v + 1] += deg[v];
  adj.resize(deg[nfree]);
  {
    std::vector<PetscInt> fill(deg.begin(), deg.end() - 1);
    for (size_t s = 0; s < fa.size(); s++)
      if (fa[s] >= 0 && fb[s] >= 0) {
        adj[fill[fa[s]]++] = fb[s];
        adj[fill[fb[s]]++] = fa[s];
      }
  }
  if (near) PetscCall(PetscPrintf(PETSC_COMM_WORLD, "partition,parts,part,free_vertices,vertices_z_below\n"));
  else PetscCall(PetscPrintf(PETSC_COMM_WORLD, "partition,parts,vertices,springs,max_owned_vertices,max_owned_springs,max_sweep_springs,max_ghosted_springs,max_ghosts,max_neighbours,mean_ghosts,edge_cut,spring_imbalance\n"));
  for (PetscInt k = 0; k < nparts; k++) {
    const PetscInt     P = parts[k];
    std::vector<PetscInt> part(nfree);
    idx_t              nvtxs = nfree, ncon = 1, np = P, objval;
    std::vector<idx_t> xa(deg.begin(), deg.end()), ad(adj.begin(), adj.end()), p(nfree);
    idx_t              options[METIS_NOPTIONS];
    METIS_SetDefaultOptions(options);
    options[METIS_OPTION_SEED] = 7;
    PetscCheck(METIS_PartGraphKway(&nvtxs, &ncon, xa.data(), ad.data(), NULL, NULL, NULL, &np, NULL, NULL, options, &objval, p.data()) == METIS_OK, PETSC_COMM_SELF, PETSC_ERR_LIB, "METIS failed");
    for (PetscInt v = 0; v < nfree; v++) part[v] = p[v];
    if (near) {
      for (int natural = 0; natural < 2; natural++) {
        std::vector<PetscInt> owned(P, 0), below(P, 0);
        for (PetscInt v = 0; v < S.nv; v++)
          if (fid[v] >= 0) {
            const PetscInt q = natural ? (PetscInt)((long long)fid[v] * P / nfree) : part[fid[v]];
            owned[q]++;
            if (S.x0[3 * v + 2] <= nearz) below[q]++;
          }
        for (PetscInt q = 0; q < P; q++) PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s,%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT ",%" PetscInt_FMT "\n", natural ? "natural" : "metis", P, q, owned[q], below[q]));
      }
      continue;
    }
    PartStats(P, part, fa, fb, "metis", S.nv, S.nspring);
    for (PetscInt v = 0; v < nfree; v++) part[v] = (PetscInt)((long long)v * P / nfree);
    PartStats(P, part, fa, fb, "natural", S.nv, S.nspring);
  }
  PetscCall(MSimSceneDestroy(&scene));
  PetscFunctionReturn(PETSC_SUCCESS);
}

int main(int argc, char **argv)
{
  PetscBool pingpong = PETSC_FALSE;

  PetscCall(SlepcInitialize(&argc, &argv, NULL, NULL));
  PetscCall(MSimInitialize());
  PetscCall(PetscOptionsGetBool(NULL, NULL, "-pingpong", &pingpong, NULL));
  if (pingpong) PetscCall(PingPong());
  else PetscCall(Model());
  PetscCall(MSimFinalize());
  PetscCall(SlepcFinalize());
  return 0;
}
