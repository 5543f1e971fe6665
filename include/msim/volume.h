/* The volume term of tet scenes (-msim_volume, off by default): per tet the energy |V0| psi(J),
   J = V / V0, of msim/volume_kernels.hpp, a Teschner volume term plus IPC's log barrier on J, so
   that an implicit step whose line search stays where the barrier is finite (max_step) never
   inverts a tet. The system holds the tets (sys->tets): every tet computed once, by the owner of
   its free vertex of least global number, which has slots for all 4 vertices (the others are
   joined to that one by the tet's edge springs: ghosts or fixed slots like any spring end; a tet
   whose edge is no spring gets its ghost all the same). Forces on ghost slots go to their owners
   with one reverse scatter; the Hessian's blocks do not: each rank adds its own rows, taking
   those of other ranks' tets from a halo copy of them. The explicit force, the energies, the Gershgorin bound, the spectrum's
   K and the implicit term 'volume' (src/implicit/terms/volume.cpp) all call these.
   With kv = 0 (-msim_volume_stiffness 0: the inversion barrier alone) the term is zero on every
   tet above J = jhat, and the energy, gradient and Hessian passes skip the tets that the safe
   radii of the last reference (kept by a gradient pass for max_step) prove above jhat: the same
   sums as a pass over every tet, at the cost of one pass over the slots and the few tets near
   the barrier. */
#pragma once
#include <msim/system.h>

/* After the distribution: kv's and kappa's defaults (the start state's check, every tet positive
   under the barrier, is MSimSystemVolumeCheckStart's, on the state a run or the spectrum starts
   from). Collective. */
PetscErrorCode MSimSystemVolumeSetUp(MSimSystem sys, PetscReal kv_default);
/* F += w grad E (w = -1: the force) on owned rows, and *e += this rank's E (w not applied; e may
   be NULL; F may be NULL). X at time t (fixed slots from b(t)). Collective when F is given. With
   clamp, J is taken >= jhat/100 in the barrier (the explicit force: finite where a step inverted
   a tet); without, an inverted tet gives *e = +inf. */
PetscErrorCode MSimSystemVolumeGradient(MSimSystem sys, PetscReal t, Vec X, PetscReal w, Vec F, PetscReal *e, PetscBool clamp);
/* J += w D^2 E (12 x 12 blocks, PSD-projected with psd), ADD_VALUES, then assembled */
PetscErrorCode MSimSystemVolumeHessian(MSimSystem sys, PetscReal t, Vec X, PetscReal w, PetscBool psd, Mat J);
/* the largest alpha <= *alpha with every tet's signed volume positive along X - a Y for a in
   [0, alpha / 0.8] (with the barrier; nothing without). Collective. With barrier not NULL, also
   whether any tet may come below J = jhat along X - a Y, a in [0, *alpha / 0.8] (or the step was
   cut): where not, the term is Teschner's quadratic all along the step. Tets that no vertex
   motion of the step can bring to jhat (safe radii kept by the last gradient pass with F and
   without clamp) are skipped. */
PetscErrorCode MSimSystemVolumeMaxStep(MSimSystem sys, PetscReal t, Vec X, Vec Y, PetscReal *alpha, PetscBool *barrier);
/* ksum's free slots += each vertex's sum over its tets of ||D^2 E_ij|| at rest (Gershgorin) */
PetscErrorCode MSimSystemVolumeRowSums(MSimSystem sys, PetscScalar *floc);
/* Moving handles (-msim_fix_velocity): the tets inverted or flat (J <= 0) at X with the handles
   at tx, summed over ranks, and the worst one's centroid (handles at t) and fraction a of the handles' move from
   t to tx at which it flattens (+inf where none). Collective. */
PetscErrorCode MSimSystemVolumeHandleStart(MSimSystem sys, PetscReal t, PetscReal tx, Vec X, PetscInt *ninv, PetscReal *a, PetscReal where[3]);
/* inverted tets (J <= 0) at X, summed over ranks */
PetscErrorCode MSimSystemVolumeCountInverted(MSimSystem sys, PetscReal t, Vec X, PetscInt *n);
/* with the inversion barrier, a one-line refusal where a tet is inverted or flat at X, the state a
   run or the spectrum starts from (restart: the checkpoint's state as a message names it; NULL:
   the scene's start). Collective. */
PetscErrorCode MSimSystemVolumeCheckStart(MSimSystem sys, PetscReal t, Vec X, const char *restart);
