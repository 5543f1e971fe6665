/* Distributes a scene: partition, numbering, spring ownership, scatters, initial state. */
#include <msim/system.h>
#include <msim/partition.h>
#include <algorithm>
#include <map>

static PetscErrorCode MSimSystemReadPhysics(MSimSystem sys, char partition[], size_t len, PetscBool *view_partition)
{
  PetscFunctionBeginUser;
  sys->gravity[0] = sys->gravity[1] = 0.0;
  sys->gravity[2]                   = -9.81;
  sys->wind[0] = sys->wind[1] = sys->wind[2] = 0.0;
  sys->drag = sys->damping = 0.0;
  PetscOptionsBegin(sys->comm, NULL, "msim physics", NULL);
  PetscCall(MSimOptionsVec3("-msim_gravity", "Gravitational acceleration, m/s^2", sys->gravity, NULL));
  PetscCall(MSimOptionsVec3("-msim_wind", "Air velocity, m/s (acts through -msim_drag)", sys->wind, NULL));
  PetscCall(PetscOptionsReal("-msim_drag", "Air drag per vertex, N s/m: f = drag (wind - v)", NULL, sys->drag, &sys->drag, NULL));
  PetscCall(PetscOptionsReal("-msim_damping", "Spring damping along the spring, N s/m", NULL, sys->damping, &sys->damping, NULL));
  PetscCall(PetscOptionsString("-msim_partition", "Distribution of vertices across ranks: metis or natural", NULL, partition, partition, len, NULL));
  PetscCall(PetscOptionsBool("-msim_partition_view", "Print the scene's counts, the edge cut, ghosts per rank and the load balance", NULL, *view_partition, view_partition, NULL));
  PetscOptionsEnd();
  PetscCheck(sys->drag >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_drag must be >= 0 N s/m (got %g)", (double)sys->drag);
  PetscCheck(sys->damping >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_damping must be >= 0 N s/m (got %g)", (double)sys->damping);
  PetscCheck(sys->drag > 0 || (sys->wind[0] == 0 && sys->wind[1] == 0 && sys->wind[2] == 0), sys->comm, PETSC_ERR_ARG_WRONG, "-msim_wind acts through air drag: set -msim_drag > 0");
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemCreate(MPI_Comm comm, MSimScene scene, MSimSystem *out)
{
  MSimSystem           sys = new _n_MSimSystem();
  const MSimSceneData &S   = scene->data;
  char                 partition[32];
  PetscBool            view_partition = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Setup, 0, 0, 0, 0));
  sys->comm = comm;
  PetscCallMPI(MPI_Comm_rank(comm, &sys->rank));
  PetscCallMPI(MPI_Comm_size(comm, &sys->size));
  PetscCall(PetscStrncpy(partition, sys->size > 1 ? "metis" : "natural", sizeof(partition)));
  PetscCall(MSimSystemReadPhysics(sys, partition, sizeof(partition), &view_partition));
  sys->nv           = S.nv;
  sys->scene_name   = S.name;
  sys->cell_size     = S.cell_size;
  sys->ncell_global  = S.cell_size ? (PetscInt)(S.cells.size() / S.cell_size) : 0;
  sys->nspring_total = (PetscInt)S.si.size();
  sys->diameter   = S.diameter;
  for (int c = 0; c < 3; c++) sys->fix_velocity[c] = scene->fix_velocity[c];

  /* free and fixed numbering in input order */
  std::vector<PetscInt> freeid(S.nv, -1), fixid(S.nv, -1);
  PetscInt              nfree = 0, nfix = 0;
  for (PetscInt v = 0; v < S.nv; v++) {
    if (S.fixed[v]) fixid[v] = nfix++;
    else freeid[v] = nfree++;
  }
  PetscCheck(nfree > 0, comm, PETSC_ERR_ARG_WRONG, "every vertex of the %s scene is fixed: nothing to simulate", S.name.c_str());
  sys->nfree = nfree;
  sys->nfix  = nfix;
  sys->total_mass = 0;
  for (PetscInt v = 0; v < S.nv; v++) sys->total_mass += S.mass[v];

  /* graph of free vertices, then partition */
  const PetscInt        ns = (PetscInt)S.si.size();
  std::vector<PetscInt> deg(nfree + 1, 0), xadj, adjncy;
  for (PetscInt s = 0; s < ns; s++) {
    PetscInt a = freeid[S.si[s]], b = freeid[S.sj[s]];
    if (a >= 0 && b >= 0) {
      deg[a]++;
      deg[b]++;
    }
  }
  xadj.assign(nfree + 1, 0);
  for (PetscInt v = 0; v < nfree; v++) xadj[v + 1] = xadj[v] + deg[v];
  adjncy.resize(xadj[nfree]);
  {
    std::vector<PetscInt> fill(xadj.begin(), xadj.end() - 1);
    for (PetscInt s = 0; s < ns; s++) {
      PetscInt a = freeid[S.si[s]], b = freeid[S.sj[s]];
      if (a >= 0 && b >= 0) {
        adjncy[fill[a]++] = b;
        adjncy[fill[b]++] = a;
      }
    }
  }
  std::vector<PetscMPIInt> part;
  PetscCall(MSimPartition(comm, partition, nfree, xadj, adjncy, part));
  xadj.clear(); xadj.shrink_to_fit(); adjncy.clear(); adjncy.shrink_to_fit();

  /* global numbering: by rank, input order within a rank */
  std::vector<PetscInt> count(sys->size + 1, 0), gnum(nfree);
  for (PetscInt f = 0; f < nfree; f++) count[part[f] + 1]++;
  for (PetscMPIInt r = 0; r < sys->size; r++) count[r + 1] += count[r];
  {
    std::vector<PetscInt> next(count.begin(), count.end() - 1);
    for (PetscInt f = 0; f < nfree; f++) gnum[f] = next[part[f]]++;
  }
  sys->rstart = count[sys->rank];
  sys->nown   = count[sys->rank + 1] - count[sys->rank];
  PetscCheck(sys->nown > 0, comm, PETSC_ERR_ARG_WRONG, "rank %d owns no vertex: %" PetscInt_FMT " free vertices on %d ranks; use fewer ranks", sys->rank, nfree, sys->size);

  /* owned springs, ghosts: the other ends of every spring with an owned end (owned or halo) */
  std::map<PetscInt, PetscInt> ghost; /* global block -> slot, filled in sorted order below */
  auto owner = [&](PetscInt s) { PetscInt v = freeid[S.si[s]] >= 0 ? S.si[s] : S.sj[s]; return freeid[v] >= 0 ? part[freeid[v]] : -1; };
  auto mine  = [&](PetscInt v) { return freeid[v] >= 0 && part[freeid[v]] == sys->rank; };
  sys->nspring_global = 0;
  for (PetscInt s = 0; s < ns; s++) {
    if (owner(s) < 0) continue; /* both ends fixed: no effect on the motion */
    sys->nspring_global++;
    if (!mine(S.si[s]) && !mine(S.sj[s])) continue;
    for (PetscInt v : {S.si[s], S.sj[s]})
      if (freeid[v] >= 0 && !mine(v)) ghost[gnum[freeid[v]]] = 0;
  }
  sys->nghost = (PetscInt)ghost.size();
  sys->nloc   = sys->nown + sys->nghost + nfix;
  sys->local_to_global.resize(sys->nown + sys->nghost);
  for (PetscInt k = 0; k < sys->nown; k++) sys->local_to_global[k] = sys->rstart + k;
  {
    PetscInt slot = sys->nown;
    for (auto &g : ghost) {
      g.second                    = slot;
      sys->local_to_global[slot++] = g.first;
    }
  }
  auto slot_of = [&](PetscInt v) -> PetscInt {
    if (freeid[v] < 0) return sys->nown + sys->nghost + fixid[v];
    PetscInt g = gnum[freeid[v]];
    if (g >= sys->rstart && g < sys->rstart + sys->nown) return g - sys->rstart;
    return ghost.at(g);
  };
  {
    /* owned-owned springs into slices (those of vertices past the last full slice into the
       arrays), then the springs with a ghost or fixed end; input order otherwise */
    MSimSprings          &sp = sys->springs;
    std::vector<PetscInt> ia, ja, rest, other;
    std::vector<PetscReal> ka, La;
    for (PetscInt s = 0; s < ns; s++) {
      if (owner(s) != sys->rank) continue;
      const PetscInt a = slot_of(S.si[s]), b = slot_of(S.sj[s]);
      if (a < sys->nown && b < sys->nown) {
        ia.push_back(a);
        ja.push_back(b);
        ka.push_back(S.sk[s]);
        La.push_back(S.sL[s]);
      } else other.push_back(s);
    }
    PetscCall(MSimSlicesCreate(sys->nown, ia, ja, ka, La, &sp.slices, rest));
    for (PetscInt q : rest) {
      sp.i.push_back(ia[q]);
      sp.j.push_back(ja[q]);
      sp.k.push_back(ka[q]);
      sp.L.push_back(La[q]);
    }
    sp.ninner = (PetscInt)sp.i.size();
    for (PetscInt s : other) {
      sp.i.push_back(slot_of(S.si[s]));
      sp.j.push_back(slot_of(S.sj[s]));
      sp.k.push_back(S.sk[s]);
      sp.L.push_back(S.sL[s]);
    }
    sp.n     = (PetscInt)sp.i.size();
    sp.total = (PetscInt)(ia.size() + other.size());
    /* the halo: springs of another rank with an owned end (the other end is then free: it
       decided the owner), stored from the owned end */
    for (PetscInt s = 0; s < ns; s++) {
      const PetscMPIInt o = owner(s);
      if (o < 0 || o == sys->rank || !(mine(S.si[s]) || mine(S.sj[s]))) continue;
      const bool first = mine(S.si[s]);
      sp.hi.push_back(slot_of(first ? S.si[s] : S.sj[s]));
      sp.hj.push_back(slot_of(first ? S.sj[s] : S.si[s]));
      sp.hk.push_back(S.sk[s]);
      sp.hL.push_back(S.sL[s]);
    }
    PetscCall(MSimSweepScratchSetUp(&sp.slices, (PetscBool)(sys->damping > 0), &sys->sweep));
    PetscCall(PetscInfo(NULL, "rank %d: %" PetscInt_FMT " owned vertices, %" PetscInt_FMT " ghosts; %" PetscInt_FMT " owned springs (%" PetscInt_FMT " in %" PetscInt_FMT " slots of 4, %" PetscInt_FMT " with a ghost or fixed end), %" PetscInt_FMT " halo springs\n", sys->rank, sys->nown, sys->nghost, sp.total, (PetscInt)ia.size() - (PetscInt)rest.size(), sp.slices.cptr.back(), sp.n - sp.ninner, (PetscInt)sp.hi.size()));
  }

  /* boundary: every rank keeps all fixed vertices (they are few: corners, an edge, a face) */
  sys->b0.resize(3 * nfix);
  for (PetscInt v = 0; v < S.nv; v++)
    if (fixid[v] >= 0)
      for (int c = 0; c < 3; c++) sys->b0[3 * fixid[v] + c] = scene->prestretch * S.x0[3 * v + c];

  /* Vecs and the ghost scatter */
  PetscCall(MSimSystemCreateVec(sys, &sys->X0));
  PetscCall(VecDuplicate(sys->X0, &sys->V0));
  PetscCall(VecDuplicate(sys->X0, &sys->mass));
  PetscCall(VecSet(sys->V0, 0.0));
  {
    PetscScalar *x, *m;
    PetscCall(VecGetArray(sys->X0, &x));
    PetscCall(VecGetArray(sys->mass, &m));
    for (PetscInt v = 0; v < S.nv; v++) {
      if (freeid[v] < 0) continue;
      PetscInt g = gnum[freeid[v]];
      if (g < sys->rstart || g >= sys->rstart + sys->nown) continue;
      for (int c = 0; c < 3; c++) {
        x[3 * (g - sys->rstart) + c] = scene->prestretch * S.x0[3 * v + c] + scene->perturb * MSimSceneHash(v, c);
        m[3 * (g - sys->rstart) + c] = S.mass[v];
      }
    }
    PetscCall(VecRestoreArray(sys->X0, &x));
    PetscCall(VecRestoreArray(sys->mass, &m));
  }
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, 3 * sys->nloc, &sys->xloc));
  PetscCall(VecSetBlockSize(sys->xloc, 3));
  PetscCall(VecDuplicate(sys->xloc, &sys->floc));
  PetscCall(VecDuplicate(sys->xloc, &sys->vloc));
  {
    IS from, to;
    PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, sys->nown + sys->nghost, sys->local_to_global.data(), PETSC_COPY_VALUES, &from));
    PetscCall(ISCreateStride(PETSC_COMM_SELF, 3 * (sys->nown + sys->nghost), 0, 1, &to));
    PetscCall(VecScatterCreate(sys->X0, from, sys->xloc, to, &sys->g2l));
    PetscCall(ISDestroy(&from));
    PetscCall(ISDestroy(&to));
    PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, sys->nghost, sys->local_to_global.data() + sys->nown, PETSC_COPY_VALUES, &from));
    PetscCall(ISCreateStride(PETSC_COMM_SELF, 3 * sys->nghost, 3 * sys->nown, 1, &to));
    PetscCall(VecScatterCreate(sys->X0, from, sys->xloc, to, &sys->ghosts));
    PetscCall(ISDestroy(&from));
    PetscCall(ISDestroy(&to));
    if (sys->size > 1) {
      PetscCall(MSimGhostExchangeCreate(comm, 3, sys->nown, sys->nghost, sys->local_to_global.data() + sys->nown, count.data(), &sys->xghosts));
      /* an exchange has one operation in flight: the velocities need their own */
      if (sys->damping > 0) PetscCall(MSimGhostExchangeCreate(comm, 3, sys->nown, sys->nghost, sys->local_to_global.data() + sys->nown, count.data(), &sys->vghosts));
    }
  }

  /* output: rank 0 gathers free positions in input order, and keeps the connectivity */
  {
    std::vector<PetscInt> idx;
    if (sys->rank == 0) {
      idx.resize(nfree);
      for (PetscInt f = 0; f < nfree; f++) idx[f] = gnum[f];
      sys->fixed_flag = S.fixed;
      if (S.cell_size) {
        sys->out_cell_size = S.cell_size;
        sys->out_cells     = S.cells;
      } else {
        sys->out_cell_size = 2;
        sys->out_cells.resize(2 * S.si.size());
        for (size_t q = 0; q < S.si.size(); q++) {
          sys->out_cells[2 * q]     = S.si[q];
          sys->out_cells[2 * q + 1] = S.sj[q];
        }
      }
    }
    IS from, to;
    PetscCall(VecCreateSeq(PETSC_COMM_SELF, sys->rank == 0 ? 3 * nfree : 0, &sys->gathered));
    PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, (PetscInt)idx.size(), idx.data(), PETSC_COPY_VALUES, &from));
    PetscCall(ISCreateStride(PETSC_COMM_SELF, 3 * (PetscInt)idx.size(), 0, 1, &to));
    PetscCall(VecScatterCreate(sys->X0, from, sys->gathered, to, &sys->gather));
    PetscCall(ISDestroy(&from));
    PetscCall(ISDestroy(&to));
  }
  if (view_partition) {
    /* springs between free vertices of different ranks: the edge cut the partitioner minimizes */
    PetscInt cut = 0, between_free = 0;
    for (PetscInt s = 0; s < ns; s++) {
      const PetscInt a = freeid[S.si[s]], b = freeid[S.sj[s]];
      if (a < 0 || b < 0) continue;
      between_free++;
      if (part[a] != part[b]) cut++;
    }
    PetscCall(MSimSystemViewPartition(sys, partition, cut, between_free));
  }
  PetscCall(PetscLogEventEnd(MSIM_Setup, 0, 0, 0, 0));
  *out = sys;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemCreateVec(MSimSystem sys, Vec *v)
{
  PetscFunctionBeginUser;
  PetscCall(VecCreate(sys->comm, v));
  PetscCall(VecSetSizes(*v, 3 * sys->nown, 3 * sys->nfree));
  PetscCall(VecSetBlockSize(*v, 3));
  PetscCall(VecSetType(*v, VECSTANDARD));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGetInverseMass(MSimSystem sys, Vec *massinv)
{
  PetscFunctionBeginUser;
  if (!sys->massinv) {
    PetscCall(VecDuplicate(sys->mass, &sys->massinv));
    PetscCall(VecCopy(sys->mass, sys->massinv));
    PetscCall(VecReciprocal(sys->massinv)); /* every free vertex has a positive mass */
  }
  *massinv = sys->massinv;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemDestroy(MSimSystem *sys)
{
  PetscFunctionBeginUser;
  if (!*sys) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(VecDestroy(&(*sys)->X0));
  PetscCall(VecDestroy(&(*sys)->V0));
  PetscCall(VecDestroy(&(*sys)->mass));
  PetscCall(VecDestroy(&(*sys)->massinv));
  PetscCall(VecDestroy(&(*sys)->xloc));
  PetscCall(VecDestroy(&(*sys)->vloc));
  PetscCall(VecDestroy(&(*sys)->floc));
  PetscCall(VecDestroy(&(*sys)->gathered));
  PetscCall(VecScatterDestroy(&(*sys)->g2l));
  PetscCall(VecScatterDestroy(&(*sys)->ghosts));
  PetscCall(MSimGhostExchangeDestroy(&(*sys)->xghosts));
  PetscCall(MSimGhostExchangeDestroy(&(*sys)->vghosts));
  PetscCall(VecScatterDestroy(&(*sys)->gather));
  delete *sys;
  *sys = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
