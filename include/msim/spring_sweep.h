/* The hot loop over many springs, shared by the explicit force, the implicit residual and energy,
   and the projective-dynamics local step. With d = x_i - x_j, l = |d| and c = k (alpha + beta L/l):
   f_i += c d, f_j -= c d, and the spring energy sum k/2 (l - L)^2. Choices of (alpha, beta):
   force -f = grad E: (-1, 1); h^2 grad E: (h^2, -h^2); PD projection h^2 k (L/l) d: (0, h^2).
   Positions and forces are rows of 3 (a block-size-3 Vec's array). With AVX2 four springs go
   through the square root and the division together. */

#pragma once
#include <msim/petsc_compat.h>
#include <vector>

/* f may be NULL (energy only); energy may be NULL (no energy). */
void MSimSpringSweep(PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *energy);

/* The same over springs [s0, s1) whose ends are local slots (msim/system.h): a slot below nown is
   row slot of xown / fown (the Vec arrays), any other is row slot of xloc / floc. With floc NULL
   only the owned ends' rows are updated (a ghost's row is its owner's to compute). */
void MSimSpringSweepSlots(PetscInt s0, PetscInt s1, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, PetscInt nown, const PetscReal *xown, const PetscReal *xloc, PetscReal *fown, PetscReal *floc, PetscReal alpha, PetscReal beta, PetscReal *energy);

/* Spring damping in a sweep: c gains -kd ((v_i - v_j) . d) / l^2, the force along each spring
   that opposes its ends' relative axial velocity (msim::SpringDampingForce); v rows of 3 like x. */
typedef struct {
  const PetscReal *v;
  PetscReal        kd;
} MSimSweepDamping;

/* The damped spring force (alpha = -1, beta = 1, damping kd) over springs [s0, s1) of local slots,
   velocities as positions (vown / vloc); only the owned ends' rows of fown are updated. */
void MSimSpringForceSlotsDamped(PetscInt s0, PetscInt s1, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, PetscInt nown, const PetscReal *xown, const PetscReal *xloc, const PetscReal *vown, const PetscReal *vloc, PetscReal kd, PetscReal *fown);

/* One vertex's x, y, z and a pad, aligned for one 4-wide load and store */
struct alignas(32) MSimRow4 {
  PetscReal v[4];
};

/* Springs between vertices [0, nvert), stored by slices: slice c holds the springs of the four
   vertices 4c .. 4c+3 towards lower-numbered vertices, slot by slot; slot q gives lane l the
   spring from vertex 4c + l to sj[4q + l] with sk, sL. Slots cptr[c] .. cmid[c] are shifted:
   the four other ends are consecutive, sj[4q + l] = sj[4q] + l (a grid's springs of one family),
   so the sweep reads and updates them as one 4-wide run. Slots cmid[c] .. cptr[c+1] are
   gathered: any other ends, a lane with fewer springs padded with sk = 0 and sj = the vertex. */
typedef struct {
  PetscInt               nslice;
  std::vector<PetscInt>  cptr, cmid, sj;
  std::vector<PetscReal> sk, sL;
} MSimSlices;

/* Builds sl from the springs (a[s], b[s], k[s], L[s]) between vertices [0, nvert); rest gets the
   springs of vertices past the last full slice. Springs whose other ends lie more than
   MSIM_SHIFT_SPAN_MAX below go to gathered slots, which bounds the sweep's ring (below). */
#define MSIM_SHIFT_SPAN_MAX 16384
PetscErrorCode MSimSlicesCreate(PetscInt nvert, const std::vector<PetscInt> &a, const std::vector<PetscInt> &b, const std::vector<PetscReal> &k, const std::vector<PetscReal> &L, MSimSlices *sl, std::vector<PetscInt> &rest);

/* The sweep's scratch. Shifted slots work in x, y, z rows (four vertices per 4-wide value): a
   ring of W entries holds the positions of the vertices still to be read and the sums still to
   be added, each group of four converted from the rows of 3 just ahead of its slice and added
   into f as soon as no later slice reaches it (lag groups behind), so it stays in cache. Gathered
   slots sum into rows of 4 (one aligned 4-wide update each), added into f at the end for the
   slices they touch. */
typedef struct {
  PetscInt              W, lag;
  std::vector<MSimRow4> ring;    /* x, y, z; other ends' sums; own sums; velocities: W + 4 values each (4 mirror the start) and padding */
  std::vector<MSimRow4> f4;      /* rows of 4, zero between sweeps */
  std::vector<PetscInt> touched; /* slices whose rows of 4 the gathered slots reach */
} MSimSweepScratch;

/* velocities: room for them in the ring (sweeps with spring damping need it; others do not) */
PetscErrorCode MSimSweepScratchSetUp(const MSimSlices *sl, PetscBool velocities, MSimSweepScratch *w);

/* A row value the sweep starts from instead of f's: m_v .* a (m rows of 3, a per component; the
   weight m g), so that no earlier pass has to write f only for the sweep to read it back. */
typedef struct {
  const PetscReal *m;
  PetscReal        a[3];
} MSimSweepBase;

/* f += the sliced springs' sums (f may be NULL: energy only); with base, f = base + the sums on
   the sliced vertices' rows [0, 4 nslice) instead; with damp (f only; w set up with velocities),
   the damping along each spring too. energy += their energy (may be NULL). */
void MSimSpringSweepSlices(const MSimSlices *sl, MSimSweepScratch *w, const PetscReal *x, PetscReal *f, const MSimSweepBase *base, const MSimSweepDamping *damp, PetscReal alpha, PetscReal beta, PetscReal *energy);
