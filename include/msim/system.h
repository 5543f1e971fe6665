/* Springs layer: the distributed spring system. State Vecs (block size 3) hold only the free
   vertices, each rank a contiguous block; fixed vertices live in a boundary vector b(t) =
   b0 + t v_fix known to every rank (the references' K and b). Each rank owns the springs whose
   first free endpoint it owns, and gathers the ghost positions it needs with one exchange
   (msim/ghost_exchange.h). The springs across a rank boundary are also computed by the rank of
   their other end (the halo springs), so that the undamped sweeps add forces only into owned
   rows: nothing travels back. */
#pragma once
#include <msim/scene.h>
#include <msim/spring_sweep.h>
#include <msim/ghost_exchange.h>
#include <msim/exchange.h>
#include <vector>

/* Owned springs. Endpoints are local vertex slots: [0, nown) owned (also the rows of the rank's
   block of a global Vec), [nown, nown+nghost) ghosts, then fixed vertices. Springs with both ends
   owned are stored by slices for the hot loop (msim/spring_sweep.h); the remaining ones are plain
   arrays: first the owned-owned ones of vertices past the last full slice (ninner of them), then
   those with a ghost or fixed end. The halo springs are not owned: each joins an owned vertex (hi)
   to a ghost (hj) and belongs to the ghost's rank; a sweep that counts them adds their force to
   hi's row only and leaves their energy to the owner. Ghosts are the other ends of owned and halo
   springs alike. */
typedef struct {
  MSimSlices             slices;
  std::vector<PetscInt>  i, j;
  std::vector<PetscReal> k, L;
  PetscInt               n, ninner; /* entries of i, j, k, L; the owned-owned ones among them */
  PetscInt               total;     /* owned springs in all */
  std::vector<PetscInt>  hi, hj;    /* halo springs: owned slot, ghost slot */
  std::vector<PetscReal> hk, hL;
} MSimSprings;

/* Calls f(i, j, k, L) for every owned spring (slots as above). */
template <class F>
static inline void MSimSpringsForEach(const MSimSprings &sp, F &&f)
{
  const MSimSlices &sl = sp.slices;
  for (PetscInt c = 0; c < sl.nslice; c++)
    for (PetscInt q = sl.cptr[c]; q < sl.cptr[c + 1]; q++)
      for (PetscInt l = 0; l < 4; l++)
        if (sl.sj[4 * q + l] != 4 * c + l) f(4 * c + l, sl.sj[4 * q + l], sl.sk[4 * q + l], sl.sL[4 * q + l]);
  for (PetscInt s = 0; s < sp.n; s++) f(sp.i[s], sp.j[s], sp.k[s], sp.L[s]);
}

/* The tets of the volume term (msim/volume.h): each computed by one rank, the owner of its free
   vertex of least global number, where all 4 vertices have slots (owned, ghost or fixed, as a
   spring's ends) */
typedef struct {
  std::vector<PetscInt>  slot;      /* 4 local slots per tet */
  std::vector<PetscReal> V0, iV0;   /* rest volume (> 0: the slots are ordered so) and 1 / V0 */
  PetscInt               ntet = 0;  /* tets of the scene in the term (every rank knows it) */
  PetscReal              kv = 0, kappa = 0, jhat = 0; /* msim/volume_kernels.hpp's TetMaterial */
  Vec                    yloc = NULL; /* a direction's local slots, for max_step */
} MSimTets;

typedef struct _n_MSimSystem *MSimSystem;
struct _n_MSimSystem {
  MPI_Comm    comm;
  PetscMPIInt rank, size;
  PetscInt    nv;                   /* input vertices, fixed included */
  PetscInt    nfree, nown, rstart;  /* free vertices: global, owned, first owned (blocks) */
  PetscInt    nghost, nfix, nloc;   /* local slots: nloc = nown + nghost + nfix, nfix the fixed
                                       vertices this rank's springs touch */
  PetscInt    nfix_global;          /* fixed vertices of the scene */
  PetscInt    nspring_global;       /* springs with a free end */
  MSimSprings springs;              /* owned springs */
  MSimTets    tets;                 /* the volume term's tets (none: ntet 0) */
  std::vector<PetscInt>   local_to_global; /* global block of each owned/ghost slot */
  std::vector<PetscReal>  b0;       /* 3 nfix: the local fixed slots' positions at t = 0 */
  PetscReal   fix_velocity[3];
  PetscReal   gravity[3], wind[3], drag, damping;
  PetscReal   total_mass, diameter;
  Vec         mass;                 /* per dof (block size 3), global layout */
  Vec         massinv;              /* 1 / mass: made on first use (MSimSystemGetInverseMass) */
  Vec         xloc, vloc, floc;     /* local slots, 3 nloc */
  MSimSweepScratch      sweep;      /* the sliced sweep's scratch */
  VecScatter  g2l;                  /* global free -> owned+ghost slots */
  VecScatter  ghosts;               /* global free -> ghost slots only (GhostsAdd's reverse scatter) */
  MSimGhostExchange xghosts;        /* the hot loops' forward exchange of ghost positions (ranks > 1) */
  MSimGhostExchange vghosts;        /* the same for velocities (spring damping only) */
  Vec         X0, V0;               /* initial state */
  /* Output in input vertex order ("natural" order): a Vec of 3 nv entries in the scene's directory
     layout (rank r holds the input ids of its block), filled from the free Vecs by a scatter and
     with b(t) at the fixed vertices of each block. Output, spectra and -msim_view_final go
     through it; nothing is gathered whole unless a serial .vtu series asks for it. */
  MSimBlockLayout       dir;
  Vec                   natural;       /* 3 nv, block size 3; made on first use (MSimSystemNaturalSetUp) */
  VecScatter            to_natural;    /* free global -> natural; likewise */
  std::vector<PetscInt> nat_gnum;      /* the block's global free numbers (-1: fixed), until then */
  std::vector<PetscInt> nat_fixed;     /* the fixed vertices of this rank's block (local index) ... */
  std::vector<PetscReal> nat_b0;       /* ... and their positions at t = 0 */
  std::vector<char>     nat_fixed_flag; /* every vertex of the block */
  /* the cells drawn (a mesh's tets or triangles held here, otherwise the springs held here as
     lines), input ids */
  int                   out_cell_size; /* vertices per cell: 4, 3 or 2 */
  std::vector<PetscInt> out_cells;
  /* what frames show besides positions, kept only when something draws (MSimSceneCellsDrawn) */
  std::vector<PetscReal> out_cell_V0;  /* rest volume of each tet of out_cells (tet scenes) */
  std::vector<PetscInt>  out_springs;  /* a mesh's springs held here as input-id pairs (for grids
                                          and chains out_cells are the springs) */
  std::vector<PetscReal> out_spring_L; /* rest length of each spring drawn: of out_springs, or of
                                          out_cells' lines where those are the springs */
  std::vector<PetscInt>  nat_file_id;  /* each block vertex's id in the input file (-1: made by
                                          msim, TetGen or refinement); empty: the input id */
  PetscInt              ncell_global;  /* a mesh's tets or triangles (0 for grids and chains) */
  int                   cell_size;     /* 4 tets, 3 triangles, 0 none */
  PetscInt              nspring_total; /* every spring of the scene, those between fixed vertices too */
  std::string           scene_name;
  std::string           scene_identity; /* the options that defined the scene (MSimSceneData::identity) */
};

/* Collective. Reads the physics options (-msim_gravity, wind, drag, damping; the partitioner reads
   -msim_partition).
   Takes the scene's springs (its spring lists are empty afterwards: one system per scene; at scale
   they are the largest part of setup's memory). */
PetscErrorCode MSimSystemCreate(MPI_Comm comm, MSimScene scene, MSimSystem *sys);
PetscErrorCode MSimSystemDestroy(MSimSystem *sys);
/* -msim_partition_view: the scene's counts, the edge cut (springs between free vertices of two
   ranks), each rank's owned and ghost vertices and springs, and the load balance. Collective. */
PetscErrorCode MSimSystemViewPartition(MSimSystem sys, const char partition[], PetscInt cut, PetscInt between_free);
PetscErrorCode MSimSystemCreateVec(MSimSystem sys, Vec *v);

/* Local slots from global X at time t (fixed slots from b(t)); the returned array is sys->xloc's. */
PetscErrorCode MSimSystemGlobalToLocal(MSimSystem sys, PetscReal t, Vec X, Vec xloc);
PetscErrorCode MSimSystemVelocityToLocal(MSimSystem sys, Vec V, Vec vloc);
/* F += sum of local slot contributions (ghost parts go to their owners) */
PetscErrorCode MSimSystemLocalToGlobalAdd(MSimSystem sys, Vec floc, Vec F);
/* The hot loops' exchange: ghost positions of X into xloc's ghost slots (begin/end, so the owned
   springs run in between) and b(t) into its fixed slots; the owned rows stay in X. GhostsAdd adds
   the ghost slots of floc to their owners' rows of F (for sweeps that do not use the halo). */
PetscErrorCode MSimSystemGhostsBegin(MSimSystem sys, Vec X, Vec xloc);
PetscErrorCode MSimSystemGhostsEnd(MSimSystem sys, PetscReal t, Vec X, Vec xloc);
PetscErrorCode MSimSystemGhostsAdd(MSimSystem sys, Vec floc, Vec F);
/* The same for velocities (spring damping; may be in flight with the positions' exchange): ghost
   velocities into vloc's ghost slots, the handles' velocity into its fixed slots. */
PetscErrorCode MSimSystemVelocityGhostsBegin(MSimSystem sys, Vec V, Vec vloc);
PetscErrorCode MSimSystemVelocityGhostsEnd(MSimSystem sys, Vec V, Vec vloc);
PetscErrorCode MSimSystemBoundary(MSimSystem sys, PetscReal t, PetscReal *b); /* fills 3 nfix */

/* F = f_springs(x) + f_damping(x, v) + m g + drag (wind - v). V may be NULL when damping and drag
   are zero. */
PetscErrorCode MSimSystemComputeForce(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec F);
/* a = M^-1 F (pointwise) */
PetscErrorCode MSimSystemAcceleration(MSimSystem sys, PetscReal t, Vec X, Vec V, Vec A);
/* Spring energy + gravity potential of the free vertices; kinetic energy of V (may be NULL). */
PetscErrorCode MSimSystemComputeEnergy(MSimSystem sys, PetscReal t, Vec X, Vec V, PetscReal *kinetic, PetscReal *potential);
/* F += the sweep of msim/spring_sweep.h over every owned spring (c = k (alpha + beta L/l) along
   each spring), in place in F's array (F may be NULL); with energy, the spring energy summed over
   ranks. The hot loop of the explicit force, the implicit residual and the energies. */
PetscErrorCode MSimSystemSpringSweep(MSimSystem sys, PetscReal t, Vec X, Vec F, PetscReal alpha, PetscReal beta, PetscReal *energy);
/* Sum of spring energies only (for the incremental potential). */
PetscErrorCode MSimSystemSpringEnergy(MSimSystem sys, PetscReal t, Vec X, PetscReal *E);

/* Makes sys->natural and sys->to_natural if not yet made. Collective. */
PetscErrorCode MSimSystemNaturalSetUp(MSimSystem sys);
/* Positions of all nv vertices in input order into sys->natural (b(t) at fixed vertices), or a
   displacement-like Vec (zero at fixed vertices). Collective. */
PetscErrorCode MSimSystemNaturalPositions(MSimSystem sys, PetscReal t, Vec X);
PetscErrorCode MSimSystemNaturalVector(MSimSystem sys, Vec X);
/* The same gathered whole on rank 0 (3 nv; empty elsewhere), for small outputs. Collective. */
PetscErrorCode MSimSystemGatherPositions(MSimSystem sys, PetscReal t, Vec X, std::vector<PetscReal> &all);
PetscErrorCode MSimSystemGatherVector(MSimSystem sys, Vec X, std::vector<PetscReal> &all);
/* Every vertex's fixed flag and the cells drawn, on rank 0 (empty elsewhere), for small outputs. */
PetscErrorCode MSimSystemGatherTopology(MSimSystem sys, std::vector<char> &fixed, std::vector<PetscInt> &cells);
/* Velocities of all nv vertices in input order into sys->natural (the handles' velocity at fixed
   vertices); the same gathered whole on rank 0. Collective. */
PetscErrorCode MSimSystemNaturalVelocities(MSimSystem sys, Vec V);
PetscErrorCode MSimSystemGatherVelocities(MSimSystem sys, Vec V, std::vector<PetscReal> &all);
/* Everything else a serial series draws, on rank 0 (empty elsewhere), in input order: each
   vertex's file id, the tets' rest volumes, a mesh's springs and the rest lengths of the springs
   drawn. Collective. */
PetscErrorCode MSimSystemGatherFrameTopology(MSimSystem sys, std::vector<PetscInt> &file_id, std::vector<PetscReal> &cell_V0, std::vector<PetscInt> &springs, std::vector<PetscReal> &spring_L);
/* This rank's block of file ids (the input ids where the scene has none). */
PetscErrorCode MSimSystemBlockFileIds(MSimSystem sys, std::vector<PetscInt> &ids);

/* Matrix over free vertices, block size 3, AIJ (works with every factorization and PC), with the
   spring graph's nonzero pattern preallocated once. */
PetscErrorCode MSimSystemCreateMatrix(MSimSystem sys, Mat *A);
/* Nonzero blocks per owned row of the free-vertex graph, diagonal included (preallocation). */
PetscErrorCode MSimSystemGraphPreallocation(MSimSystem sys, std::vector<PetscInt> &dnz, std::vector<PetscInt> &onz);
/* A = mass M + diagonal I + stiffness K(X) + damping kd sum_s n_s n_s^T, in one pass over the
   springs. X at time t (fixed ends from b(t)); the spring axes n_s at Xn at time tn, the start of
   the step (Xn NULL: no damping blocks); psd: project each spring block to PSD. */
typedef struct _n_MSimMatrixCoefficients {
  PetscReal t;
  Vec       X;
  PetscReal mass, diagonal, stiffness;
  PetscBool psd;
  PetscReal tn;
  Vec       Xn;
  PetscReal damping;
} MSimMatrixCoefficients;
PetscErrorCode MSimSystemAssembleMatrix(MSimSystem sys, const MSimMatrixCoefficients *c, Mat A);
/* 1 / mass per dof, made on the first call (the explicit integrators' accelerations use it: a
   product vectorizes, where PETSc's VecPointwiseDivide tests every divisor and does not) */
PetscErrorCode MSimSystemGetInverseMass(MSimSystem sys, Vec *massinv);
/* Lumped mass as a diagonal Mat. */
PetscErrorCode MSimSystemCreateMassMatrix(MSimSystem sys, Mat *M);
/* Gershgorin bound on omega_max^2 of (K, M): max_i (2/m_i) sum_j k_ij, over free vertices. */
PetscErrorCode MSimSystemGershgorin(MSimSystem sys, PetscReal *omega2);
