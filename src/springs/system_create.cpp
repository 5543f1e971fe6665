/* Builds each rank's part of the system from what MSimSystemDistribute left it: local slots
   (owned, ghost, fixed), the owned springs by slices, the halo, Vecs, scatters, the initial state,
   and the natural-order Vec that output goes through. */
#include "system_distribute.h"
#include <msim/partition.h>
#include <msim/log.h>
#include <msim/options.h>
#include <msim/volume.h>
#include <msim/private/systemimpl.h>
#include <msim/private/sceneimpl.h>
#include <msim/private/selfcontactimpl.h>
#include <msim/destroy.h>
#include <algorithm>
#include <memory>

static PetscErrorCode MSimSystemReadPhysics(MSimSystem sys, PetscBool *view_partition, PetscInt *order)
{
  static const char *const volume_options[] = {"-msim_volume_stiffness", "-msim_volume_kappa", "-msim_volume_jhat", "-msim_volume_pd_bound"};
  PetscBool                volume_set[4];

  PetscFunctionBeginUser;
  sys->gravity[0] = sys->gravity[1] = 0.0;
  sys->gravity[2]                   = -9.81;
  sys->wind[0] = sys->wind[1] = sys->wind[2] = 0.0;
  sys->drag = sys->damping = 0.0;
  PetscOptionsBegin(sys->comm, NULL, "msim physics", NULL);
  PetscCall(MSimOptionsVec3("-msim_gravity", "Gravitational acceleration, m/s^2", sys->gravity, NULL));
  PetscCall(MSimOptionsVec3("-msim_wind", "Air velocity, m/s (acts through -msim_drag)", sys->wind, NULL));
  PetscCall(MSimOptionsReal("-msim_drag", "Air drag per vertex, N s/m: f = drag (wind - v)", NULL, sys->drag, &sys->drag, NULL));
  PetscCall(MSimOptionsReal("-msim_damping", "Spring damping along the spring, N s/m", NULL, sys->damping, &sys->damping, NULL));
  /* the volume term's material (msim/volume.h); -1: its default, set once the springs are known */
  sys->tets.kv    = -1;
  sys->tets.kappa = -1;
  sys->tets.jhat  = 0.2;
  PetscCall(MSimOptionsReal("-msim_volume_stiffness", "Tet scenes: volume stiffness kv of -msim_volume, Pa (default: a tenth of the springs' Young's modulus; 0: the inversion barrier alone, whose passes skip the tets that cannot reach it)", NULL, sys->tets.kv, &sys->tets.kv, &volume_set[0]));
  PetscCall(MSimOptionsReal("-msim_volume_kappa", "Tet scenes: stiffness of -msim_volume's inversion barrier, Pa (default: kv, or a tenth of the springs' Young's modulus where kv is 0; 0: no barrier)", NULL, sys->tets.kappa, &sys->tets.kappa, &volume_set[1]));
  PetscCall(MSimOptionsReal("-msim_volume_jhat", "Tet scenes: the inversion barrier acts on tets compressed below this fraction of their rest volume", NULL, sys->tets.jhat, &sys->tets.jhat, &volume_set[2]));
  PetscCall(PetscOptionsBool("-msim_volume_pd_bound", "Tet scenes, PD with the inversion barrier alone: take the global step's length from a bound on Phi that needs only the barrier's change (no pass over the springs); 0: halve until Phi, evaluated in full, does not rise", NULL, sys->tets.pd_bound, &sys->tets.pd_bound, &volume_set[3]));
  PetscCall(PetscOptionsBool("-msim_partition_view", "Print the scene's counts, the edge cut, ghosts per rank and the load balance", NULL, *view_partition, view_partition, NULL));
  {
    const char *orders[] = {"auto", "input", "morton"};
    PetscCall(PetscOptionsEList("-msim_vertex_order", "Order of each rank's vertices: input, morton (a Z-order curve through space), auto (morton for tet and mesh scenes, input for grids, chains and boxes)", NULL, orders, 3, orders[0], order, NULL));
  }
  PetscOptionsEnd();
  PetscCheck(sys->drag >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_drag must be >= 0 N s/m (got %g)", (double)sys->drag);
  PetscCall(MSimOptionsRefuseWithout(sys->comm, "-msim_volume", 4, volume_options, volume_set));
  PetscCheck(sys->tets.kv >= 0 || sys->tets.kv == -1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_volume_stiffness must be >= 0 Pa, or -1 for its default (got %g)", (double)sys->tets.kv);
  PetscCheck(sys->tets.kappa >= 0 || sys->tets.kappa == -1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_volume_kappa must be >= 0 Pa, or -1 for its default (got %g)", (double)sys->tets.kappa);
  PetscCheck(sys->tets.jhat > 0 && sys->tets.jhat < 1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_volume_jhat must be in (0, 1) (got %g)", (double)sys->tets.jhat);
  PetscCheck(sys->damping >= 0, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_damping must be >= 0 N s/m (got %g)", (double)sys->damping);
  PetscCheck(sys->drag > 0 || (sys->wind[0] == 0 && sys->wind[1] == 0 && sys->wind[2] == 0), sys->comm, PETSC_ERR_ARG_WRONG, "-msim_wind acts through air drag: set -msim_drag > 0");
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the partitioner, destroyed whichever way SystemBuild returns */
struct PartitionerDestroyer {
  void operator()(MSimPartitioner p) const { (void)MSimPartitionerDestroy(&p); }
};

static PetscErrorCode SystemBuild(MPI_Comm comm, MSimScene scene, MSimSystem sys)
{
  MSimSceneData       &S = scene->data;
  MSimPartitioner      partitioner;
  PetscBool            view_partition = PETSC_FALSE;
  PetscInt             order          = 0;
  MSimLocalPart        L;

  PetscFunctionBeginUser;
  /* the whole setup, reading and distribution included, in -log_view's Setup stage */
  PetscCall(PetscLogStagePush(MSIM_StageSetup));
  PetscCall(PetscLogEventBegin(MSIM_Setup, 0, 0, 0, 0));
  sys->comm = comm;
  PetscCallMPI(MPI_Comm_rank(comm, &sys->rank));
  PetscCallMPI(MPI_Comm_size(comm, &sys->size));
  PetscCall(MSimSystemReadPhysics(sys, &view_partition, &order));
  PetscCall(MSimPartitionerCreate(comm, &partitioner));
  std::unique_ptr<_n_MSimPartitioner, PartitionerDestroyer> partitioner_owner(partitioner);
  PetscCall(MSimPartitionerSetFromOptions(partitioner));
  sys->nv            = S.nv;
  sys->scene_name    = S.name;
  sys->scene_identity = S.identity;
  sys->scene_view     = scene->view;
  sys->diameter      = S.diameter;
  sys->cell_size     = S.cell_size;
  sys->ncell_global  = S.ncell;
  sys->nspring_total = S.nspring;
  sys->dir           = S.dir;
  for (int c = 0; c < 3; c++) sys->fix_velocity[c] = scene->fix_velocity[c];
  {
    PetscReal m = 0;
    for (PetscReal mv : S.mass) m += mv;
    PetscCallMPI(MPI_Allreduce(&m, &sys->total_mass, 1, MPIU_REAL, MPIU_SUM, comm));
  }

  /* grids, chains and boxes come in an order whose regular offsets the sliced sweep exploits; a
     mesh file's order is whatever its maker chose, a refined mesh's is poor (MortonOrder) */
  const PetscBool morton = (PetscBool)(order == 2 || (order == 0 && (S.name == "tet" || S.name == "mesh")));
  /* the cells output draws: a mesh's cells, or the springs as lines (taken now: the
     distribution consumes the scene's springs), each rank a block of the scene's order, so that
     every series holds them in the same order at any rank count; none (and the scene's topology
     freed with the scene) when no option writes a series or modes */
  const PetscBool drawn = scene->drawn;
  sys->out_cell_size = S.cell_size ? S.cell_size : 2;
  if (drawn) {
    /* the springs as input-id pairs: a grid's or chain's cells, a mesh's second piece */
    PetscCall(MSimSceneDrawnSprings(comm, &S, S.cell_size ? sys->out_springs : sys->out_cells, sys->out_spring_L));
    if (S.cell_size) PetscCall(MSimSceneDrawnCells(comm, &S, sys->out_cells));
    sys->nat_file_id = S.file_id;
  }
  if (drawn && S.cell_size == 4) {
    /* each tet's rest volume, so frames can show V/V0; signed, so an inverted tet reads < 0
       whatever the file's orientation */
    const size_t           ntet = sys->out_cells.size() / 4;
    std::vector<PetscReal> x;
    PetscCall(MSimSceneFetchPositions(comm, &S, sys->out_cells, x));
    sys->out_cell_V0.resize(ntet);
    for (size_t c = 0; c < ntet; c++) sys->out_cell_V0[c] = MSimTetVolume(&x[12 * c], &x[12 * c + 3], &x[12 * c + 6], &x[12 * c + 9]);
  }
  sys->self_contact = S.self_contact;
  if (S.self_contact.on && S.cell_size) PetscCall(MSimSelfSurfaceTriangles(comm, S, sys->self_tris));
  PetscCall(MSimSystemDistribute(comm, S, partitioner, morton, L));
  sys->nfree          = L.nfree;
  sys->nfix_global    = L.nfix_global;
  sys->nown           = L.nown;
  sys->rstart         = L.rstart;
  sys->nspring_global = L.nspring_moving;

  /* local slots: owned [0, nown), ghosts (the other free ends of owned and halo springs and the
     free vertices of the tets and halo tets, by global number), then the fixed ends of owned
     springs and of the tets (by input id) */
  std::vector<PetscInt>        ghosts;
  const std::vector<PetscInt> &fixed    = L.fixed_vid;
  auto                         is_owned = [&](PetscInt g) { return g >= sys->rstart && g < sys->rstart + sys->nown; };
  for (const auto *list : {&L.owned, &L.halo})
    for (const MSimRoutedSpring &r : *list) {
      if (r.ga >= 0 && !is_owned(r.ga)) ghosts.push_back(r.ga);
      if (r.gb >= 0 && !is_owned(r.gb)) ghosts.push_back(r.gb);
    }
  for (const MSimRoutedTet &r : L.tets)
    for (int q = 0; q < 4; q++)
      if (r.g[q] >= 0 && !is_owned(r.g[q])) ghosts.push_back(r.g[q]);
  std::sort(ghosts.begin(), ghosts.end());
  ghosts.erase(std::unique(ghosts.begin(), ghosts.end()), ghosts.end());
  sys->nghost = (PetscInt)ghosts.size();
  sys->nfix   = (PetscInt)fixed.size();
  sys->nloc   = sys->nown + sys->nghost + sys->nfix;
  sys->local_to_global.resize(sys->nown + sys->nghost);
  for (PetscInt k = 0; k < sys->nown; k++) sys->local_to_global[k] = sys->rstart + k;
  std::copy(ghosts.begin(), ghosts.end(), sys->local_to_global.begin() + sys->nown);
  auto slot = [&](PetscInt g, PetscInt vid) -> PetscInt {
    if (g < 0) return sys->nown + sys->nghost + (PetscInt)(std::lower_bound(fixed.begin(), fixed.end(), vid) - fixed.begin());
    if (is_owned(g)) return g - sys->rstart;
    return sys->nown + (PetscInt)(std::lower_bound(ghosts.begin(), ghosts.end(), g) - ghosts.begin());
  };
  sys->tets.ntet = L.ntet;
  sys->tets.slot.resize(4 * L.ntet_own);
  sys->tets.V0.resize(L.ntet_own);
  sys->tets.iV0.resize(L.ntet_own);
  sys->tets.hslot.resize(4 * (L.tets.size() - L.ntet_own));
  sys->tets.hV0.resize(L.tets.size() - L.ntet_own);
  for (size_t c = 0; c < L.tets.size(); c++) {
    const bool own = c < (size_t)L.ntet_own;
    PetscInt  *sl  = own ? &sys->tets.slot[4 * c] : &sys->tets.hslot[4 * (c - L.ntet_own)];
    for (int q = 0; q < 4; q++) sl[q] = slot(L.tets[c].g[q], L.tets[c].v[q]);
    if (L.tets[c].V0 < 0) std::swap(sl[1], sl[2]); /* every tet positive at rest, whatever the file's orientation */
    (own ? sys->tets.V0[c] : sys->tets.hV0[c - L.ntet_own]) = PetscAbsReal(L.tets[c].V0);
    if (own) sys->tets.iV0[c] = 1.0 / sys->tets.V0[c];
  }
  std::vector<MSimRoutedTet>().swap(L.tets);
  sys->b0.resize(3 * sys->nfix);
  for (PetscInt f = 0; f < 3 * sys->nfix; f++) sys->b0[f] = scene->prestretch * L.fixed_x0[f];
  {
    /* owned-owned springs into slices (those of vertices past the last full slice into the
       arrays), then the springs with a ghost or fixed end; by input ids otherwise */
    MSimSprings           &sp = sys->springs;
    std::vector<PetscInt>  ia, ja, rest, oi, oj;
    std::vector<PetscReal> ka, La, ok, oL;
    /* reserved whole: growing by doubling would touch (fault in) up to twice the memory, the
       dearest part of setup; the routed springs are freed before the slices are built */
    for (auto *v : {&ia, &ja}) v->reserve(L.owned.size());
    for (auto *v : {&ka, &La}) v->reserve(L.owned.size());
    for (const MSimRoutedSpring &r : L.owned) {
      const PetscInt a = slot(r.ga, r.va), b = slot(r.gb, r.vb);
      const bool     inner = a < sys->nown && b < sys->nown;
      (inner ? ia : oi).push_back(a);
      (inner ? ja : oj).push_back(b);
      (inner ? ka : ok).push_back(r.k);
      (inner ? La : oL).push_back(r.L);
    }
    L.owned.clear();
    L.owned.shrink_to_fit();
    PetscCall(MSimSlicesCreate(sys->nown, ia, ja, ka, La, &sp.slices, rest));
    for (auto *v : {&sp.i, &sp.j}) v->reserve(rest.size() + oi.size());
    for (auto *v : {&sp.k, &sp.L}) v->reserve(rest.size() + oi.size());
    for (PetscInt q : rest) {
      sp.i.push_back(ia[q]);
      sp.j.push_back(ja[q]);
      sp.k.push_back(ka[q]);
      sp.L.push_back(La[q]);
    }
    sp.ninner = (PetscInt)sp.i.size();
    sp.i.insert(sp.i.end(), oi.begin(), oi.end());
    sp.j.insert(sp.j.end(), oj.begin(), oj.end());
    sp.k.insert(sp.k.end(), ok.begin(), ok.end());
    sp.L.insert(sp.L.end(), oL.begin(), oL.end());
    sp.n     = (PetscInt)sp.i.size();
    sp.total = (PetscInt)(ia.size() + oi.size());
    /* the halo: springs of another rank with an owned end (the other end is then free: it
       decided the owner), stored from the owned end */
    for (const MSimRoutedSpring &r : L.halo) {
      const bool first = is_owned(r.ga);
      sp.hi.push_back(slot(first ? r.ga : r.gb, first ? r.va : r.vb));
      sp.hj.push_back(slot(first ? r.gb : r.ga, first ? r.vb : r.va));
      sp.hk.push_back(r.k);
      sp.hL.push_back(r.L);
    }
    L.halo.clear();
    L.halo.shrink_to_fit();
    PetscCall(MSimSweepScratchSetUp(&sp.slices, (PetscBool)(sys->damping > 0), &sys->sweep));
    PetscCall(PetscInfo(NULL, "rank %d: %" PetscInt_FMT " owned vertices, %" PetscInt_FMT " ghosts, %" PetscInt_FMT " fixed; %" PetscInt_FMT " owned springs (%" PetscInt_FMT " in %" PetscInt_FMT " slots of 4, %" PetscInt_FMT " with a ghost or fixed end), %" PetscInt_FMT " halo springs\n", sys->rank, sys->nown, sys->nghost, sys->nfix, sp.total, (PetscInt)ia.size() - (PetscInt)rest.size(), sp.slices.cptr.back(), sp.n - sp.ninner, (PetscInt)sp.hi.size()));
  }

  /* Vecs and the ghost scatter */
  PetscCall(MSimSystemCreateVec(sys, &sys->X0));
  PetscCall(VecDuplicate(sys->X0, &sys->V0));
  PetscCall(VecDuplicate(sys->X0, &sys->mass));
  PetscCall(VecSet(sys->V0, 0.0));
  {
    PetscScalar *x, *m;
    PetscCall(VecGetArray(sys->X0, &x));
    PetscCall(VecGetArray(sys->mass, &m));
    for (PetscInt k = 0; k < sys->nown; k++)
      for (int c = 0; c < 3; c++) {
        x[3 * k + c] = scene->prestretch * L.own_x0[3 * k + c] + scene->perturb * MSimSceneHash(L.own_vid[k], c);
        m[3 * k + c] = L.own_mass[k];
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
    PetscCall(MSimDestroy(&from, &to));
    PetscCall(ISCreateBlock(PETSC_COMM_SELF, 3, sys->nghost, sys->local_to_global.data() + sys->nown, PETSC_COPY_VALUES, &from));
    PetscCall(ISCreateStride(PETSC_COMM_SELF, 3 * sys->nghost, 3 * sys->nown, 1, &to));
    PetscCall(VecScatterCreate(sys->X0, from, sys->xloc, to, &sys->ghosts));
    PetscCall(MSimDestroy(&from, &to));
    if (sys->size > 1) {
      PetscCall(MSimGhostExchangeCreate(comm, 3, sys->nown, sys->nghost, sys->local_to_global.data() + sys->nown, L.ranges.data(), &sys->xghosts));
      /* an exchange has one operation in flight: the velocities need their own */
      if (sys->damping > 0) PetscCall(MSimGhostExchangeCreate(comm, 3, sys->nown, sys->nghost, sys->local_to_global.data() + sys->nown, L.ranges.data(), &sys->vghosts));
    }
  }

  PetscCall(MSimSystemVolumeSetUp(sys, L.modulus));

  /* natural order: the fixed vertices of this rank's block now, the Vec and its scatter on first
     use (MSimSystemNaturalSetUp): a run that writes nothing never builds them */
  {
    const PetscInt count = S.dir.Count(sys->rank);
    sys->nat_fixed_flag  = S.fixed;
    for (PetscInt v = 0; v < count; v++)
      if (L.dir_gnum[v] < 0) {
        sys->nat_fixed.push_back(v);
        for (int c = 0; c < 3; c++) sys->nat_b0.push_back(scene->prestretch * S.x0[3 * v + c]);
      }
    sys->nat_gnum = std::move(L.dir_gnum);
  }
  if (view_partition) {
    const char *type;
    PetscCall(MSimPartitionerGetType(partitioner, &type));
    PetscCall(MSimSystemViewPartition(sys, type, L.cut, L.between_free));
  }
  PetscCall(PetscLogEventEnd(MSIM_Setup, 0, 0, 0, 0));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemCreate(MPI_Comm comm, MSimScene scene, MSimSystem *out)
{
  MSimSystem sys = new _n_MSimSystem();

  PetscFunctionBeginUser;
  *out = NULL;
  /* a refused scene frees what was built of it: a caller that goes on (a fuzzer, a library user
     trying another scene) keeps no part of it */
  PetscErrorCode ierr = SystemBuild(comm, scene, sys);
  if (ierr) {
    PetscCall(MSimSystemDestroy(&sys));
    PetscCall(ierr);
  }
  *out = sys;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemNaturalSetUp(MSimSystem sys)
{
  std::vector<PetscInt> from, to;
  IS                    isf, ist;

  PetscFunctionBeginUser;
  if (sys->natural) PetscFunctionReturn(PETSC_SUCCESS);
  const PetscInt count = sys->dir.Count(sys->rank), start = sys->dir.Start(sys->rank);
  PetscCall(VecCreateMPI(sys->comm, 3 * count, 3 * sys->nv, &sys->natural));
  PetscCall(VecSetBlockSize(sys->natural, 3));
  PetscCall(PetscObjectSetName((PetscObject)sys->natural, "positions"));
  for (PetscInt v = 0; v < count; v++)
    if (sys->nat_gnum[v] >= 0) {
      from.push_back(sys->nat_gnum[v]);
      to.push_back(start + v);
    }
  PetscCall(ISCreateBlock(sys->comm, 3, (PetscInt)from.size(), from.data(), PETSC_COPY_VALUES, &isf));
  PetscCall(ISCreateBlock(sys->comm, 3, (PetscInt)to.size(), to.data(), PETSC_COPY_VALUES, &ist));
  PetscCall(VecScatterCreate(sys->X0, isf, sys->natural, ist, &sys->to_natural));
  PetscCall(MSimDestroy(&isf, &ist));
  std::vector<PetscInt>().swap(sys->nat_gnum);
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

PetscErrorCode MSimSystemGetInitialState(MSimSystem sys, Vec *X0, Vec *V0)
{
  PetscFunctionBeginUser;
  if (X0) *X0 = sys->X0;
  if (V0) *V0 = sys->V0;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGetSizes(MSimSystem sys, PetscInt *nv, PetscInt *nfree, PetscInt *nown)
{
  PetscFunctionBeginUser;
  if (nv) *nv = sys->nv;
  if (nfree) *nfree = sys->nfree;
  if (nown) *nown = sys->nown;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSystemGetMass(MSimSystem sys, Vec *mass)
{
  PetscFunctionBeginUser;
  *mass = sys->mass;
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
  PetscCall(MSimDestroy(&(*sys)->X0, &(*sys)->V0, &(*sys)->mass, &(*sys)->massinv, &(*sys)->xloc, &(*sys)->vloc, &(*sys)->floc, &(*sys)->tets.yloc, &(*sys)->natural, &(*sys)->g2l, &(*sys)->ghosts, &(*sys)->to_natural));
  PetscCall(MSimGhostExchangeDestroy(&(*sys)->xghosts));
  PetscCall(MSimGhostExchangeDestroy(&(*sys)->vghosts));
  delete *sys;
  *sys = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
