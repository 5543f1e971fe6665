/* Springs layer: the distributed spring system. State Vecs (block size 3) hold only the free
   vertices, each rank a contiguous block; fixed vertices live in a boundary vector b(t) =
   b0 + t v_fix known to every rank (the references' K and b). Each rank owns the springs whose
   first free endpoint it owns, and gathers the ghost positions it needs with one exchange
   (msim/ghost_exchange.h). The springs across a rank boundary are also computed by the rank of
   their other end (the halo springs), so that the undamped sweeps add forces only into owned
   rows: nothing travels back. */
#pragma once
#include <msim/scene.h>
#include <vector>

/* The body, with the springs' and the volume term's storage, is private (msim/private/systemimpl.h). */
typedef struct _n_MSimSystem *MSimSystem;

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
/* The initial state X0, V0 (the system's own Vecs: copy them, do not change or destroy them). */
PetscErrorCode MSimSystemGetInitialState(MSimSystem sys, Vec *X0, Vec *V0);
/* Vertices of the scene (fixed included), free vertices and this rank's owned free vertices;
   each may be NULL. */
PetscErrorCode MSimSystemGetSizes(MSimSystem sys, PetscInt *nv, PetscInt *nfree, PetscInt *nown);
/* The lumped mass per dof (block size 3; the system's own Vec). */
PetscErrorCode MSimSystemGetMass(MSimSystem sys, Vec *mass);

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
