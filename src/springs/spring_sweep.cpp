/* MSimSpringSweep and MSimSpringSweepSlots: batches of four springs in AVX2 registers, the rest one
   by one. Each vertex row is read and updated as a 2-wide (x, y) plus a scalar (z) access, never
   past its 3 values, so the loop needs no padding and consecutive updates of one vertex forward
   from store to load. */
#include <msim/spring_sweep.h>
#include "simd_rows.h"
#include <cmath>

/* Where a sweep finds each end's position and adds its force: in one array (x, f), or in the local
   slots of msim/system.h (owned rows in the Vec arrays, the others in the local vectors; with floc
   NULL a ghost's or fixed vertex's row gets nothing: its owner computes it). */
struct MSimRowsPlain {
  static constexpr bool skips = false;
  const PetscReal      *x;
  PetscReal            *f;
  const PetscReal      *X(PetscInt v) const { return x + 3 * v; }
  PetscReal            *F(PetscInt v) const { return f + 3 * v; }
};

struct MSimRowsSlots {
  static constexpr bool skips = true;
  PetscInt              nown;
  const PetscReal      *xown, *xloc;
  PetscReal            *fown, *floc;
  const PetscReal      *X(PetscInt v) const { return (v < nown ? xown : xloc) + 3 * v; }
  PetscReal            *F(PetscInt v) const { return v < nown ? fown + 3 * v : (floc ? floc + 3 * v : NULL); }
};

template <bool F, bool E, class R>
static inline void SweepScalar(PetscInt s0, PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const R &rows, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  for (PetscInt s = s0; s < n; s++) {
    const PetscReal *xi = rows.X(i[s]), *xj = rows.X(j[s]);
    const PetscReal  d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
    const PetscReal  l  = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
    if (E) *e2 += k[s] * (l - L[s]) * (l - L[s]);
    if (F) {
      const PetscReal c  = k[s] * (alpha + beta * L[s] / l);
      PetscReal      *fi = rows.F(i[s]), *fj = rows.F(j[s]);
      if (!R::skips || fi) fi[0] += c * d0, fi[1] += c * d1, fi[2] += c * d2;
      if (!R::skips || fj) fj[0] -= c * d0, fj[1] -= c * d1, fj[2] -= c * d2;
    }
  }
}

#if MSIM_SIMD_ROWS
template <bool F, bool E, class R>
static void Sweep(PetscInt s0, PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const R &rows, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  const __m256d va = _mm256_set1_pd(alpha), vb = _mm256_set1_pd(beta);
  __m256d       ve = _mm256_setzero_pd();
  PetscInt      s  = s0;
  for (; s + 4 <= n; s += 4) {
    const __m256d d0 = _mm256_sub_pd(MSimLoad3(rows.X(i[s])), MSimLoad3(rows.X(j[s])));
    const __m256d d1 = _mm256_sub_pd(MSimLoad3(rows.X(i[s + 1])), MSimLoad3(rows.X(j[s + 1])));
    const __m256d d2 = _mm256_sub_pd(MSimLoad3(rows.X(i[s + 2])), MSimLoad3(rows.X(j[s + 2])));
    const __m256d d3 = _mm256_sub_pd(MSimLoad3(rows.X(i[s + 3])), MSimLoad3(rows.X(j[s + 3])));
    /* |d_q|^2 of the four springs in the four lanes */
    const __m256d t01 = _mm256_hadd_pd(_mm256_mul_pd(d0, d0), _mm256_mul_pd(d1, d1));
    const __m256d t23 = _mm256_hadd_pd(_mm256_mul_pd(d2, d2), _mm256_mul_pd(d3, d3));
    const __m256d l2  = _mm256_add_pd(_mm256_permute2f128_pd(t01, t23, 0x20), _mm256_permute2f128_pd(t01, t23, 0x31));
    const __m256d l   = _mm256_sqrt_pd(l2);
    const __m256d vk = _mm256_loadu_pd(k + s), vL = _mm256_loadu_pd(L + s);
    if (E) {
      const __m256d e = _mm256_sub_pd(l, vL);
      ve              = _mm256_fmadd_pd(_mm256_mul_pd(vk, e), e, ve);
    }
    if (F) {
      const __m256d c     = _mm256_mul_pd(vk, _mm256_fmadd_pd(vb, _mm256_div_pd(vL, l), va));
      const __m256d fq[4] = {_mm256_mul_pd(_mm256_permute4x64_pd(c, 0x00), d0), _mm256_mul_pd(_mm256_permute4x64_pd(c, 0x55), d1), _mm256_mul_pd(_mm256_permute4x64_pd(c, 0xAA), d2), _mm256_mul_pd(_mm256_permute4x64_pd(c, 0xFF), d3)};
      for (int q = 0; q < 4; q++) {
        PetscReal *fi = rows.F(i[s + q]), *fj = rows.F(j[s + q]);
        if (!R::skips || fi) MSimAdd3(fi, fq[q]);
        if (!R::skips || fj) MSimSub3(fj, fq[q]);
      }
    }
  }
  if (E) {
    double lanes[4];
    _mm256_storeu_pd(lanes, ve);
    *e2 += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  }
  SweepScalar<F, E>(s, n, i, j, k, L, rows, alpha, beta, e2);
}
#else
template <bool F, bool E, class R>
static void Sweep(PetscInt s0, PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const R &rows, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  SweepScalar<F, E>(s0, n, i, j, k, L, rows, alpha, beta, e2);
}
#endif

template <class R>
static void SweepRows(PetscInt s0, PetscInt s1, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const R &rows, bool force, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  PetscReal e2 = 0;
  if (force && energy) Sweep<true, true>(s0, s1, i, j, k, L, rows, alpha, beta, &e2);
  else if (force) Sweep<true, false>(s0, s1, i, j, k, L, rows, alpha, beta, &e2);
  else if (energy) Sweep<false, true>(s0, s1, i, j, k, L, rows, alpha, beta, &e2);
  if (energy) *energy += 0.5 * e2;
}

void MSimSpringSweep(PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  SweepRows(0, n, i, j, k, L, MSimRowsPlain{x, f}, f != NULL, alpha, beta, energy);
}

void MSimSpringSweepSlots(PetscInt s0, PetscInt s1, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, PetscInt nown, const PetscReal *xown, const PetscReal *xloc, PetscReal *fown, PetscReal *floc, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  SweepRows(s0, s1, i, j, k, L, MSimRowsSlots{nown, xown, xloc, fown, floc}, fown != NULL, alpha, beta, energy);
}

void MSimSpringForceSlotsDamped(PetscInt s0, PetscInt s1, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, PetscInt nown, const PetscReal *xown, const PetscReal *xloc, const PetscReal *vown, const PetscReal *vloc, PetscReal kd, PetscReal *fown)
{
  for (PetscInt s = s0; s < s1; s++) {
    const PetscInt   a = i[s], b = j[s];
    const PetscReal *xi = (a < nown ? xown : xloc) + 3 * a, *xj = (b < nown ? xown : xloc) + 3 * b;
    const PetscReal *vi = (a < nown ? vown : vloc) + 3 * a, *vj = (b < nown ? vown : vloc) + 3 * b;
    const PetscReal  d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
    const PetscReal  l2 = d0 * d0 + d1 * d1 + d2 * d2, l = std::sqrt(l2);
    const PetscReal  c  = k[s] * (L[s] / l - 1.0) - kd * ((vi[0] - vj[0]) * d0 + (vi[1] - vj[1]) * d1 + (vi[2] - vj[2]) * d2) / l2;
    if (a < nown) fown[3 * a] += c * d0, fown[3 * a + 1] += c * d1, fown[3 * a + 2] += c * d2;
    if (b < nown) fown[3 * b] -= c * d0, fown[3 * b + 1] -= c * d1, fown[3 * b + 2] -= c * d2;
  }
}
