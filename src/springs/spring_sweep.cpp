/* MSimSpringSweep: batches of four springs in AVX2 registers, the rest one by one. Each vertex row
   is read and updated as a 2-wide (x, y) plus a scalar (z) access, never past its 3 values, so the
   loop needs no padding and consecutive updates of one vertex forward from store to load. */
#include <msim/spring_sweep.h>
#include "simd_rows.h"
#include <cmath>

template <bool F, bool E>
static inline void SweepScalar(PetscInt s0, PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  for (PetscInt s = s0; s < n; s++) {
    const PetscReal *xi = x + 3 * i[s], *xj = x + 3 * j[s];
    const PetscReal  d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
    const PetscReal  l  = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
    if (E) *e2 += k[s] * (l - L[s]) * (l - L[s]);
    if (F) {
      const PetscReal c  = k[s] * (alpha + beta * L[s] / l);
      PetscReal      *fi = f + 3 * i[s], *fj = f + 3 * j[s];
      fi[0] += c * d0;
      fi[1] += c * d1;
      fi[2] += c * d2;
      fj[0] -= c * d0;
      fj[1] -= c * d1;
      fj[2] -= c * d2;
    }
  }
}

#if MSIM_SIMD_ROWS
template <bool F, bool E>
static void Sweep(PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  const __m256d va = _mm256_set1_pd(alpha), vb = _mm256_set1_pd(beta);
  __m256d       ve = _mm256_setzero_pd();
  PetscInt      s  = 0;
  for (; s + 4 <= n; s += 4) {
    const __m256d d0 = _mm256_sub_pd(MSimLoad3(x + 3 * i[s]), MSimLoad3(x + 3 * j[s]));
    const __m256d d1 = _mm256_sub_pd(MSimLoad3(x + 3 * i[s + 1]), MSimLoad3(x + 3 * j[s + 1]));
    const __m256d d2 = _mm256_sub_pd(MSimLoad3(x + 3 * i[s + 2]), MSimLoad3(x + 3 * j[s + 2]));
    const __m256d d3 = _mm256_sub_pd(MSimLoad3(x + 3 * i[s + 3]), MSimLoad3(x + 3 * j[s + 3]));
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
      const __m256d c = _mm256_mul_pd(vk, _mm256_fmadd_pd(vb, _mm256_div_pd(vL, l), va));
      const __m256d f0 = _mm256_mul_pd(_mm256_permute4x64_pd(c, 0x00), d0);
      const __m256d f1 = _mm256_mul_pd(_mm256_permute4x64_pd(c, 0x55), d1);
      const __m256d f2 = _mm256_mul_pd(_mm256_permute4x64_pd(c, 0xAA), d2);
      const __m256d f3 = _mm256_mul_pd(_mm256_permute4x64_pd(c, 0xFF), d3);
      MSimAdd3(f + 3 * i[s], f0);
      MSimSub3(f + 3 * j[s], f0);
      MSimAdd3(f + 3 * i[s + 1], f1);
      MSimSub3(f + 3 * j[s + 1], f1);
      MSimAdd3(f + 3 * i[s + 2], f2);
      MSimSub3(f + 3 * j[s + 2], f2);
      MSimAdd3(f + 3 * i[s + 3], f3);
      MSimSub3(f + 3 * j[s + 3], f3);
    }
  }
  if (E) {
    double lanes[4];
    _mm256_storeu_pd(lanes, ve);
    *e2 += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  }
  SweepScalar<F, E>(s, n, i, j, k, L, x, f, alpha, beta, e2);
}
#else
template <bool F, bool E>
static void Sweep(PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  SweepScalar<F, E>(0, n, i, j, k, L, x, f, alpha, beta, e2);
}
#endif

void MSimSpringSweep(PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  PetscReal e2 = 0;
  if (f && energy) Sweep<true, true>(n, i, j, k, L, x, f, alpha, beta, &e2);
  else if (f) Sweep<true, false>(n, i, j, k, L, x, f, alpha, beta, &e2);
  else if (energy) Sweep<false, true>(n, i, j, k, L, x, f, alpha, beta, &e2);
  if (energy) *energy += 0.5 * e2;
}

void MSimSpringSweepSlots(PetscInt s0, PetscInt s1, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, PetscInt nown, const PetscReal *xown, const PetscReal *xloc, PetscReal *fown, PetscReal *floc, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  PetscReal e2 = 0;
  for (PetscInt s = s0; s < s1; s++) {
    const PetscReal *xi = (i[s] < nown ? xown : xloc) + 3 * i[s], *xj = (j[s] < nown ? xown : xloc) + 3 * j[s];
    const PetscReal  d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
    const PetscReal  l  = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
    e2 += k[s] * (l - L[s]) * (l - L[s]);
    if (fown) {
      const PetscReal c  = k[s] * (alpha + beta * L[s] / l);
      PetscReal      *fi = i[s] < nown ? fown + 3 * i[s] : (floc ? floc + 3 * i[s] : NULL);
      PetscReal      *fj = j[s] < nown ? fown + 3 * j[s] : (floc ? floc + 3 * j[s] : NULL);
      if (fi) fi[0] += c * d0, fi[1] += c * d1, fi[2] += c * d2;
      if (fj) fj[0] -= c * d0, fj[1] -= c * d1, fj[2] -= c * d2;
    }
  }
  if (energy) *energy += 0.5 * e2;
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
