/* The system's body and its spring storage, for the springs layer and the code under src/ that
   sweeps the springs or reads the layout (PETSc's include/petsc/private pattern). Users, the app
   and tests see the handle and the functions of msim/system.h. */
#pragma once
#include <msim/system.h>
#include <msim/spring_sweep.h>
#include <msim/ghost_exchange.h>
#include <msim/exchange.h>
#include <vector>
#include <cstdint>
#include <string>

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
   spring's ends). The halo tets are not owned: another rank's tets with an owned vertex, whose
   Hessian blocks this rank adds to its own rows (src/springs/volume.cpp says why). */
typedef struct {
  std::vector<PetscInt>  slot;      /* 4 local slots per tet */
  std::vector<PetscReal> V0, iV0;   /* rest volume (> 0: the slots are ordered so) and 1 / V0 */
  std::vector<PetscInt>  hslot;     /* the halo tets: 4 local slots each, ordered as slot's, ... */
  std::vector<PetscReal> hV0;       /* ... and rest volume */
  PetscInt               ntet = 0;  /* tets of the scene in the term (every rank knows it) */
  PetscReal              kv = 0, kappa = 0, jhat = 0; /* msim/volume_kernels.hpp's TetMaterial */
  PetscBool              pd_bound = PETSC_TRUE; /* -msim_volume_pd_bound: PD's step length from the barrier's pd_gap */
  Vec                    yloc = NULL; /* a direction's local slots, for max_step */
  /* max_step's shortcut (src/springs/volume.cpp): the last implicit gradient pass's positions
     (3 per local slot) and each tet's g and L there (msim::TetWithinSafeRadius); m2: work */
  std::vector<PetscReal> xref, gl, m2;
  bool                   refresh = true; /* the next implicit gradient pass takes a new reference */
  /* barrier alone (kv = 0): the energy, gradient and Hessian passes skip the tets the reference
     proves above jhat (zero there); noskip: every tet computed (the unit test's comparison) */
  bool                   noskip = false;
  /* the skip's slot filter (src/springs/volume.cpp's ActiveTets): per local slot the least safe
     radius^2 of its tets above jhat at the reference, the tets at or below it there (inside), the
     slots' tets (CSR: s2t[s2t_ptr[s] .. s2t_ptr[s+1]]), and work (a bit per tet met, the tets
     not proven safe) */
  std::vector<PetscReal> r2slot;
  std::vector<PetscInt>  inside, s2t_ptr, s2t, active;
  std::vector<uint64_t>  mark;
} MSimTets;

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
  MSimSelfContactOptions self_contact; /* the scene's -msim_self_contact block */
  std::vector<PetscInt>  self_tris;    /* a mesh's surface triangles around this rank's block of
                                          input ids, 3 input ids each (self-contact on) */
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
  /* the cells drawn (a mesh's tets or triangles, otherwise the springs as lines), input ids: a
     block of the scene's order (MSimSceneDrawnCells), the same series at any rank count */
  int                   out_cell_size; /* vertices per cell: 4, 3 or 2 */
  std::vector<PetscInt> out_cells;
  /* what frames show besides positions, kept only when something draws (the scene's drawn) */
  std::vector<PetscReal> out_cell_V0;  /* rest volume of each tet of out_cells (tet scenes) */
  std::vector<PetscInt>  out_springs;  /* a mesh's springs as input-id pairs, a block of the
                                          scene's order (for grids and chains out_cells are the
                                          springs) */
  std::vector<PetscReal> out_spring_L; /* rest length of each spring drawn: of out_springs, or of
                                          out_cells' lines where those are the springs */
  std::vector<PetscInt>  nat_file_id;  /* each block vertex's id in the input file (-1: made by
                                          msim, TetGen or refinement); empty: the input id */
  PetscInt              ncell_global;  /* a mesh's tets or triangles (0 for grids and chains) */
  int                   cell_size;     /* 4 tets, 3 triangles, 0 none */
  PetscInt              nspring_total; /* every spring of the scene, those between fixed vertices too */
  std::string           scene_name;
  std::string           scene_identity; /* the options that defined the scene (MSimSceneData::identity) */
  PetscBool             scene_view;     /* the scene's -msim_scene_view: the contact object prints its obstacles */
};
