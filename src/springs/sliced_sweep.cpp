/* The sliced springs (msim/spring_sweep.h): building the slices, the scratch, and the sweep. */
#include <msim/spring_sweep.h>
#include "simd_rows.h"
#include <algorithm>
#include <cmath>

/* Groups of four converted ahead of the slice being swept: a load that overlaps a store still in
   flight cannot take its value from the store and waits for it, so the rows a slice reads were
   written two slices earlier. */
#define MSIM_RING_LEAD 2

/* Slices ahead whose springs, positions and masses are prefetched. The loop's arithmetic keeps the
   out-of-order window too short to cover a miss to memory, and the hardware prefetcher alone does
   not run far enough ahead on its five streams: with N = 512 (50 MB a step, past the L3) the
   force took 1.9 ns per spring without these prefetches and 1.4 with them, and 6 to 16 slices
   did alike. Below MSIM_PREFETCH_MIN_BYTES of springs, positions and masses the data stay in cache
   from one sweep to the next and the prefetches only take load slots: with N = 64 (0.8 MB) they
   made the force 10% slower; with N = 128 (3.1 MB) and 256 (12.5 MB) they neither helped nor hurt. */
#define MSIM_PREFETCH_SLICES    10
#define MSIM_PREFETCH_MIN_BYTES (8 << 20)

/* Values from one ring array to the next: W, 4 mirrored, and 36 more so that the arrays start
   320 bytes apart modulo 4096. Were they 4096-aligned alike (W is a power of two), a load from
   one would wait on recent stores to the others at the same address bits 0-11 (4K aliasing):
   with N = 512 this made the cloth's force 25% slower. */
static inline PetscInt MSimRingStride(PetscInt W)
{
  return W + 4 + 36;
}

PetscErrorCode MSimSlicesCreate(PetscInt nvert, const std::vector<PetscInt> &a, const std::vector<PetscInt> &b, const std::vector<PetscReal> &k, const std::vector<PetscReal> &L, MSimSlices *sl, std::vector<PetscInt> &rest)
{
  PetscFunctionBeginUser;
  sl->nslice = nvert / 4;
  sl->cptr.assign(1, 0);
  sl->cmid.clear();
  sl->sj.clear();
  sl->sk.clear();
  sl->sL.clear();
  rest.clear();
  /* the springs of each vertex of a full slice whose higher end it is, in input order: one array
     with offsets (a vector per vertex cost a heap block each, 6 x 10^5 of them on a 4 M-spring box) */
  const PetscInt        nlane = 4 * sl->nslice;
  std::vector<PetscInt> ptr(nlane + 1, 0), lanes;
  for (PetscInt s = 0; s < (PetscInt)a.size(); s++) {
    const PetscInt hi = PetscMax(a[s], b[s]);
    PetscCheck(a[s] != b[s] && a[s] >= 0 && b[s] >= 0 && hi < nvert, PETSC_COMM_SELF, PETSC_ERR_PLIB, "spring %" PetscInt_FMT " joins %" PetscInt_FMT " and %" PetscInt_FMT " of %" PetscInt_FMT " vertices", s, a[s], b[s], nvert);
    if (hi < nlane) ptr[hi + 1]++;
    else rest.push_back(s);
  }
  for (PetscInt v = 0; v < nlane; v++) ptr[v + 1] += ptr[v];
  lanes.resize(ptr[nlane]);
  {
    std::vector<PetscInt> next(ptr.begin(), ptr.end() - 1);
    for (PetscInt s = 0; s < (PetscInt)a.size(); s++) {
      const PetscInt hi = PetscMax(a[s], b[s]);
      if (hi < nlane) lanes[next[hi]++] = s;
    }
  }
  /* room for every spring and some padding: growing by doubling would touch (fault in) up to
     twice the memory, the dearest part of setup */
  for (auto *v : {&sl->sk, &sl->sL}) v->reserve(a.size() + a.size() / 4 + 16);
  sl->sj.reserve(a.size() + a.size() / 4 + 16);
  auto other = [&](PetscInt s, PetscInt v) { return a[s] == v ? b[s] : a[s]; };
  auto put   = [&](PetscInt j, PetscReal kk, PetscReal LL) {
    sl->sj.push_back(j);
    sl->sk.push_back(kk);
    sl->sL.push_back(LL);
  };
  for (PetscInt c = 0; c < sl->nslice; c++) {
    PetscInt *lane[4];
    size_t    n[4];
    PetscInt  slots = 0;
    for (PetscInt l = 0; l < 4; l++) {
      lane[l] = lanes.data() + ptr[4 * c + l];
      n[l]    = (size_t)(ptr[4 * c + l + 1] - ptr[4 * c + l]);
    }
    /* shifted slots: an offset every lane has (the first spring with it in each lane) */
    for (size_t q0 = 0; q0 < n[0]; q0++) {
      const PetscInt off = other(lane[0][q0], 4 * c) - 4 * c;
      PetscInt       pick[4];
      PetscBool      all = (PetscBool)(-off <= MSIM_SHIFT_SPAN_MAX && k[lane[0][q0]] != 0);
      pick[0]            = (PetscInt)q0;
      for (PetscInt l = 1; l < 4 && all; l++) {
        const PetscInt v = 4 * c + l;
        pick[l]          = -1;
        for (size_t q = 0; q < n[l] && pick[l] < 0; q++)
          if (lane[l][q] >= 0 && other(lane[l][q], v) - v == off && k[lane[l][q]] != 0) pick[l] = (PetscInt)q; /* -1: taken by an earlier slot */
        all = (PetscBool)(pick[l] >= 0);
      }
      if (!all) continue;
      for (PetscInt l = 0; l < 4; l++) {
        const PetscInt s = lane[l][pick[l]];
        put(4 * c + l + off, k[s], L[s]);
        lane[l][pick[l]] = -1; /* taken */
      }
      slots++;
    }
    sl->cmid.push_back(sl->cptr.back() + slots);
    /* gathered slots: the rest of each lane in input order */
    for (PetscInt l = 0; l < 4; l++) n[l] = (size_t)(std::remove(lane[l], lane[l] + n[l], (PetscInt)-1) - lane[l]);
    size_t gathered = 0;
    for (PetscInt l = 0; l < 4; l++) gathered = PetscMax(gathered, n[l]);
    for (size_t q = 0; q < gathered; q++)
      for (PetscInt l = 0; l < 4; l++) {
        const PetscInt v = 4 * c + l;
        if (q < n[l]) put(other(lane[l][q], v), k[lane[l][q]], L[lane[l][q]]);
        else put(v, 0.0, 0.0); /* padding: the vertex itself, k = 0 */
      }
    sl->cptr.push_back(sl->cptr.back() + slots + (PetscInt)gathered);
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSweepScratchSetUp(const MSimSlices *sl, PetscBool velocities, MSimSweepScratch *w)
{
  PetscInt          span = 0;
  std::vector<char> reach(sl->nslice, 0);

  PetscFunctionBeginUser;
  for (PetscInt c = 0; c < sl->nslice; c++) {
    for (PetscInt q = sl->cptr[c]; q < sl->cmid[c]; q++) span = PetscMax(span, 4 * c - sl->sj[4 * q]);
    for (PetscInt q = sl->cmid[c]; q < sl->cptr[c + 1]; q++) {
      reach[c] = 1;
      for (PetscInt l = 0; l < 4; l++) reach[sl->sj[4 * q + l] / 4] = 1;
    }
  }
  /* group g's sums are complete once slice g + lag is done; the ring must hold every group from
     the lowest a slice reaches up to the ones converted ahead */
  w->lag = (span + 3) / 4;
  w->W   = 4;
  while (w->W <= 4 * (w->lag + MSIM_RING_LEAD + 1)) w->W *= 2;
  w->touched.clear();
  for (PetscInt c = 0; c < sl->nslice; c++)
    if (reach[c]) w->touched.push_back(c);
  /* only what the sweep uses: the scalar fallback needs no scratch, shifted slots alone no rows of 4 */
  w->ring.clear();
  w->f4.clear();
#if MSIM_SIMD_ROWS
  w->ring.assign((velocities ? 12 : 9) * MSimRingStride(w->W) / 4, MSimRow4{{0, 0, 0, 0}});
  if (!w->touched.empty()) w->f4.assign(4 * sl->nslice, MSimRow4{{0, 0, 0, 0}});
#endif
  PetscFunctionReturn(PETSC_SUCCESS);
}

#if MSIM_SIMD_ROWS
/* The first lines of slice c's streams into L1, a fixed count each: as many as a slice of six
   slots uses (a cloth's: 192 B of k and of L, 96 B of other ends, positions and masses), so that
   the prefetches of consecutive slices cover each stream whole; larger slices leave the rest to
   the hardware prefetcher. Prefetching every line exactly once instead, by loops whose trips vary
   from slice to slice, measured slower (1.8 ns per spring at N = 512 against 1.4).
   Inlined early on purpose: a call GCC 12 does not inline at once is found free of side effects
   (prefetches have none it counts) and deleted, prefetches and all. */
__attribute__((always_inline)) static inline void MSimPrefetchSlice(const MSimSlices *sl, PetscInt c, const PetscReal *x, const MSimSweepBase *base)
{
  const PetscInt q  = 4 * sl->cptr[c];
  const char    *pk = (const char *)(sl->sk.data() + q), *pL = (const char *)(sl->sL.data() + q), *pj = (const char *)(sl->sj.data() + q);
  const char    *px = (const char *)(x + 12 * c), *pm = base ? (const char *)(base->m + 12 * c) : px;
  for (int o = 0; o < 192; o += 64) _mm_prefetch(pk + o, _MM_HINT_T0), _mm_prefetch(pL + o, _MM_HINT_T0);
  for (int o = 0; o < 128; o += 64) _mm_prefetch(pj + o, _MM_HINT_T0), _mm_prefetch(px + o, _MM_HINT_T0), _mm_prefetch(pm + o, _MM_HINT_T0);
}

/* c = k (alpha + beta L/l) of four springs; with damping (D), also + g s / l^2 (g = -kd, s the
   relative velocity along d), 1/l from one division instead of L/l */
template <bool D>
__attribute__((always_inline)) static inline __m256d MSimSpringCoefficient(__m256d k, __m256d L, __m256d l, __m256d va, __m256d vb, __m256d g, __m256d s)
{
  if (!D) return _mm256_mul_pd(k, _mm256_fmadd_pd(vb, _mm256_div_pd(L, l), va));
  const __m256d ri = _mm256_div_pd(_mm256_set1_pd(1.0), l);
  return _mm256_fmadd_pd(_mm256_mul_pd(g, s), _mm256_mul_pd(ri, ri), _mm256_mul_pd(k, _mm256_fmadd_pd(vb, _mm256_mul_pd(L, ri), va)));
}

/* D: with spring damping (damp->v, damp->kd; F only): c gains -kd ((v_i - v_j) . d) / l^2, with
   1/l from one division instead of L/l */
template <bool F, bool E, bool D>
static void SweepSlices(const MSimSlices *sl, MSimSweepScratch *w, const PetscReal *x, PetscReal *f, const MSimSweepBase *base, const MSimSweepDamping *damp, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  const PetscInt  nslice = sl->nslice, W = w->W, mask = W - 1, m = MSimRingStride(W);
  const PetscInt *cptr = sl->cptr.data(), *cmid = sl->cmid.data(), *sj = sl->sj.data();
  const double   *sk = sl->sk.data(), *sL = sl->sL.data();
  double *const   X = w->ring[0].v, *const Y = X + m, *const Z = Y + m, *const FX = Z + m, *const FY = FX + m, *const FZ = FY + m;
  double *const   GX = FZ + m, *const GY = GX + m, *const GZ = GY + m;
  double *const   VX = D ? GZ + m : NULL, *const VY = D ? VX + m : NULL, *const VZ = D ? VY + m : NULL; /* velocities: a ring set up with them */
  const double   *v  = D ? damp->v : NULL;
  const __m256d   vg = _mm256_set1_pd(D ? -damp->kd : 0.0);
  double *const   f4   = w->f4.empty() ? NULL : w->f4[0].v; /* used only by gathered slots */
  const __m256d   va   = _mm256_set1_pd(alpha), vb = _mm256_set1_pd(beta), zero = _mm256_setzero_pd();
  __m256d         ve   = zero;
  /* the base's a repeated along four rows of 3: (a0 a1 a2 a0 | a1 a2 a0 a1 | a2 a0 a1 a2) */
  __m256d a3[3] = {zero, zero, zero};
  if (base) a3[0] = _mm256_setr_pd(base->a[0], base->a[1], base->a[2], base->a[0]), a3[1] = _mm256_setr_pd(base->a[1], base->a[2], base->a[0], base->a[1]), a3[2] = _mm256_setr_pd(base->a[2], base->a[0], base->a[1], base->a[2]);

  /* group g's rows of 3 into the ring; position 0 also into the mirror past the end, so a run of
     four that starts in the last three entries reads on into it */
  auto convert = [&](PetscInt g) {
    const PetscInt r = (4 * g) & mask;
    __m256d        gx, gy, gz;
    MSimRowsToXYZ(x + 12 * g, &gx, &gy, &gz);
    _mm256_store_pd(X + r, gx), _mm256_store_pd(Y + r, gy), _mm256_store_pd(Z + r, gz);
    if (r == 0) _mm256_store_pd(X + W, gx), _mm256_store_pd(Y + W, gy), _mm256_store_pd(Z + W, gz);
    if (D) {
      MSimRowsToXYZ(v + 12 * g, &gx, &gy, &gz);
      _mm256_store_pd(VX + r, gx), _mm256_store_pd(VY + r, gy), _mm256_store_pd(VZ + r, gz);
      if (r == 0) _mm256_store_pd(VX + W, gx), _mm256_store_pd(VY + W, gy), _mm256_store_pd(VZ + W, gz);
    }
  };
  /* group g's complete sums into f: its own (G), its other ends' (F, with what runs wrote into the
     mirror); F back to zero */
  auto fold = [&](PetscInt g) {
    const PetscInt r  = (4 * g) & mask;
    __m256d        gx = _mm256_add_pd(_mm256_load_pd(FX + r), _mm256_load_pd(GX + r));
    __m256d        gy = _mm256_add_pd(_mm256_load_pd(FY + r), _mm256_load_pd(GY + r));
    __m256d        gz = _mm256_add_pd(_mm256_load_pd(FZ + r), _mm256_load_pd(GZ + r));
    if (r == 0) {
      gx = _mm256_add_pd(gx, _mm256_load_pd(FX + W)), gy = _mm256_add_pd(gy, _mm256_load_pd(FY + W)), gz = _mm256_add_pd(gz, _mm256_load_pd(FZ + W));
      _mm256_store_pd(FX + W, zero), _mm256_store_pd(FY + W, zero), _mm256_store_pd(FZ + W, zero);
    }
    if (base) {
      __m256d rows[3];
      MSimXYZToRows(gx, gy, gz, rows);
      for (int k = 0; k < 3; k++) _mm256_storeu_pd(f + 12 * g + 4 * k, _mm256_fmadd_pd(_mm256_loadu_pd(base->m + 12 * g + 4 * k), a3[k], rows[k]));
    } else MSimAddXYZToRows(f + 12 * g, gx, gy, gz);
    _mm256_store_pd(FX + r, zero), _mm256_store_pd(FY + r, zero), _mm256_store_pd(FZ + r, zero);
  };

  /* springs (other end, k, L: 20 B) and vertices (position, mass, force: 72 B) */
  const bool prefetch = 20.0 * 4 * cptr[nslice] + 72.0 * 4 * nslice > MSIM_PREFETCH_MIN_BYTES;

  for (PetscInt g = 0; g < PetscMin(MSIM_RING_LEAD, nslice); g++) convert(g);
  for (PetscInt c = 0; c < nslice; c++) {
    const PetscInt r = (4 * c) & mask;
    if (c + MSIM_RING_LEAD < nslice) convert(c + MSIM_RING_LEAD);
    if (prefetch && c + MSIM_PREFETCH_SLICES < nslice) MSimPrefetchSlice(sl, c + MSIM_PREFETCH_SLICES, x, base);
    /* shifted slots: the four other ends are one run of the ring */
    const __m256d vx = _mm256_load_pd(X + r), vy = _mm256_load_pd(Y + r), vz = _mm256_load_pd(Z + r);
    const __m256d ux = D ? _mm256_load_pd(VX + r) : zero, uy = D ? _mm256_load_pd(VY + r) : zero, uz = D ? _mm256_load_pd(VZ + r) : zero;
    __m256d       ax = zero, ay = zero, az = zero;
    for (PetscInt q = cptr[c]; q < cmid[c]; q++) {
      const PetscInt j  = sj[4 * q] & mask;
      const __m256d  dx = _mm256_sub_pd(vx, _mm256_loadu_pd(X + j)), dy = _mm256_sub_pd(vy, _mm256_loadu_pd(Y + j)), dz = _mm256_sub_pd(vz, _mm256_loadu_pd(Z + j));
      const __m256d  l  = _mm256_sqrt_pd(_mm256_fmadd_pd(dz, dz, _mm256_fmadd_pd(dy, dy, _mm256_mul_pd(dx, dx))));
      const __m256d  vk = _mm256_loadu_pd(sk + 4 * q), vL = _mm256_loadu_pd(sL + 4 * q);
      if (E) {
        const __m256d e = _mm256_sub_pd(l, vL);
        ve              = _mm256_fmadd_pd(_mm256_mul_pd(vk, e), e, ve);
      }
      if (F) {
        __m256d sv = zero;
        if (D) {
          const __m256d ex = _mm256_sub_pd(ux, _mm256_loadu_pd(VX + j)), ey = _mm256_sub_pd(uy, _mm256_loadu_pd(VY + j)), ez = _mm256_sub_pd(uz, _mm256_loadu_pd(VZ + j));
          sv               = _mm256_fmadd_pd(ez, dz, _mm256_fmadd_pd(ey, dy, _mm256_mul_pd(ex, dx)));
        }
        const __m256d cc = MSimSpringCoefficient<D>(vk, vL, l, va, vb, vg, sv);
        const __m256d fx = _mm256_mul_pd(cc, dx), fy = _mm256_mul_pd(cc, dy), fz = _mm256_mul_pd(cc, dz);
        ax = _mm256_add_pd(ax, fx), ay = _mm256_add_pd(ay, fy), az = _mm256_add_pd(az, fz);
        _mm256_storeu_pd(FX + j, _mm256_sub_pd(_mm256_loadu_pd(FX + j), fx));
        _mm256_storeu_pd(FY + j, _mm256_sub_pd(_mm256_loadu_pd(FY + j), fy));
        _mm256_storeu_pd(FZ + j, _mm256_sub_pd(_mm256_loadu_pd(FZ + j), fz));
      }
    }
    /* the own sums have arrays of their own: an update of F here would read values the runs of
       this slice (offsets -1 to -3) have just stored in part, which no store can forward */
    if (F) _mm256_store_pd(GX + r, ax), _mm256_store_pd(GY + r, ay), _mm256_store_pd(GZ + r, az);
    /* gathered slots: the vertices as rows of 3 in the lanes, sums in rows of 4 */
    if (cmid[c] < cptr[c + 1]) {
      const double *xv = x + 12 * c;
      const __m256d x0 = MSimLoad3(xv), x1 = MSimLoad3(xv + 3), x2 = MSimLoad3(xv + 6), x3 = MSimLoad3(xv + 9);
      const double *uv = D ? v + 12 * c : NULL;
      const __m256d u0 = D ? MSimLoad3(uv) : zero, u1 = D ? MSimLoad3(uv + 3) : zero, u2 = D ? MSimLoad3(uv + 6) : zero, u3 = D ? MSimLoad3(uv + 9) : zero;
      __m256d       a0 = zero, a1 = zero, a2 = zero, a3 = zero;
      for (PetscInt q = cmid[c]; q < cptr[c + 1]; q++) {
        const PetscInt *J   = sj + 4 * q;
        const __m256d   d0  = _mm256_sub_pd(x0, MSimLoad3(x + 3 * J[0]));
        const __m256d   d1  = _mm256_sub_pd(x1, MSimLoad3(x + 3 * J[1]));
        const __m256d   d2  = _mm256_sub_pd(x2, MSimLoad3(x + 3 * J[2]));
        const __m256d   d3  = _mm256_sub_pd(x3, MSimLoad3(x + 3 * J[3]));
        const __m256d   t01 = _mm256_hadd_pd(_mm256_mul_pd(d0, d0), _mm256_mul_pd(d1, d1));
        const __m256d   t23 = _mm256_hadd_pd(_mm256_mul_pd(d2, d2), _mm256_mul_pd(d3, d3));
        const __m256d   l   = _mm256_sqrt_pd(_mm256_add_pd(_mm256_permute2f128_pd(t01, t23, 0x20), _mm256_permute2f128_pd(t01, t23, 0x31)));
        const __m256d   vk = _mm256_loadu_pd(sk + 4 * q), vL = _mm256_loadu_pd(sL + 4 * q);
        if (E) {
          const __m256d e = _mm256_sub_pd(l, vL); /* 0 in padded lanes: l = L = 0 */
          ve              = _mm256_fmadd_pd(_mm256_mul_pd(vk, e), e, ve);
        }
        if (F) {
          /* padded lanes (k = 0, l = 0) give 0/0: masked to zero */
          __m256d sv = zero;
          if (D) {
            /* (v_i - v_j) . d of the four springs in the four lanes, as |d|^2 above */
            const __m256d s01 = _mm256_hadd_pd(_mm256_mul_pd(_mm256_sub_pd(u0, MSimLoad3(v + 3 * J[0])), d0), _mm256_mul_pd(_mm256_sub_pd(u1, MSimLoad3(v + 3 * J[1])), d1));
            const __m256d s23 = _mm256_hadd_pd(_mm256_mul_pd(_mm256_sub_pd(u2, MSimLoad3(v + 3 * J[2])), d2), _mm256_mul_pd(_mm256_sub_pd(u3, MSimLoad3(v + 3 * J[3])), d3));
            sv                = _mm256_add_pd(_mm256_permute2f128_pd(s01, s23, 0x20), _mm256_permute2f128_pd(s01, s23, 0x31));
          }
          const __m256d c4 = _mm256_and_pd(MSimSpringCoefficient<D>(vk, vL, l, va, vb, vg, sv), _mm256_cmp_pd(vk, zero, _CMP_NEQ_OQ));
          const __m256d f0 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0x00), d0);
          const __m256d f1 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0x55), d1);
          const __m256d f2 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0xAA), d2);
          const __m256d f3 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0xFF), d3);
          a0 = _mm256_add_pd(a0, f0), a1 = _mm256_add_pd(a1, f1), a2 = _mm256_add_pd(a2, f2), a3 = _mm256_add_pd(a3, f3);
          double *p;
          p = f4 + 4 * J[0], _mm256_store_pd(p, _mm256_sub_pd(_mm256_load_pd(p), f0));
          p = f4 + 4 * J[1], _mm256_store_pd(p, _mm256_sub_pd(_mm256_load_pd(p), f1));
          p = f4 + 4 * J[2], _mm256_store_pd(p, _mm256_sub_pd(_mm256_load_pd(p), f2));
          p = f4 + 4 * J[3], _mm256_store_pd(p, _mm256_sub_pd(_mm256_load_pd(p), f3));
        }
      }
      if (F) {
        double *p = f4 + 16 * c;
        _mm256_store_pd(p, _mm256_add_pd(_mm256_load_pd(p), a0));
        _mm256_store_pd(p + 4, _mm256_add_pd(_mm256_load_pd(p + 4), a1));
        _mm256_store_pd(p + 8, _mm256_add_pd(_mm256_load_pd(p + 8), a2));
        _mm256_store_pd(p + 12, _mm256_add_pd(_mm256_load_pd(p + 12), a3));
      }
    }
    if (F && c >= w->lag) fold(c - w->lag);
  }
  if (F) {
    for (PetscInt g = PetscMax(0, nslice - w->lag); g < nslice; g++) fold(g);
    for (PetscInt g : w->touched)
      for (PetscInt v = 4 * g; v < 4 * g + 4; v++) {
        double *p = f4 + 4 * v;
        MSimAdd3(f + 3 * v, _mm256_load_pd(p));
        _mm256_store_pd(p, zero);
      }
  }
  if (E) {
    double lanes[4];
    _mm256_storeu_pd(lanes, ve);
    *e2 += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  }
}
#else
/* without AVX2: lane by lane, straight into f (the scratch is unused) */
template <bool F, bool E, bool D>
static void SweepSlices(const MSimSlices *sl, MSimSweepScratch *, const PetscReal *x, PetscReal *f, const MSimSweepBase *base, const MSimSweepDamping *damp, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  if (F && base)
    for (PetscInt i = 0; i < 12 * sl->nslice; i++) f[i] = base->m[i] * base->a[i % 3];
  for (PetscInt c = 0; c < sl->nslice; c++)
    for (PetscInt q = sl->cptr[c]; q < sl->cptr[c + 1]; q++)
      for (PetscInt lane = 0; lane < 4; lane++) {
        const PetscInt   v = 4 * c + lane, j = sl->sj[4 * q + lane];
        const PetscReal  k = sl->sk[4 * q + lane], L = sl->sL[4 * q + lane];
        const PetscReal *xi = x + 3 * v, *xj = x + 3 * j;
        const PetscReal  d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
        if (k == 0) continue;
        const PetscReal l = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
        if (E) *e2 += k * (l - L) * (l - L);
        if (F) {
          PetscReal cc = k * (alpha + beta * L / l);
          if (D) {
            const PetscReal *vi = damp->v + 3 * v, *vj = damp->v + 3 * j;
            cc -= damp->kd * ((vi[0] - vj[0]) * d0 + (vi[1] - vj[1]) * d1 + (vi[2] - vj[2]) * d2) / (l * l);
          }
          f[3 * v] += cc * d0, f[3 * v + 1] += cc * d1, f[3 * v + 2] += cc * d2;
          f[3 * j] -= cc * d0, f[3 * j + 1] -= cc * d1, f[3 * j + 2] -= cc * d2;
        }
      }
}
#endif

void MSimSpringSweepSlices(const MSimSlices *sl, MSimSweepScratch *w, const PetscReal *x, PetscReal *f, const MSimSweepBase *base, const MSimSweepDamping *damp, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  PetscReal e2 = 0;
  if (f && damp && energy) SweepSlices<true, true, true>(sl, w, x, f, base, damp, alpha, beta, &e2);
  else if (f && damp) SweepSlices<true, false, true>(sl, w, x, f, base, damp, alpha, beta, &e2);
  else if (f && energy) SweepSlices<true, true, false>(sl, w, x, f, base, NULL, alpha, beta, &e2);
  else if (f) SweepSlices<true, false, false>(sl, w, x, f, base, NULL, alpha, beta, &e2);
  else if (energy) SweepSlices<false, true, false>(sl, w, x, f, base, NULL, alpha, beta, &e2);
  if (energy) *energy += 0.5 * e2;
}
