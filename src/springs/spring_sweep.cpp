/* MSimSpringSweep: batches of four springs in AVX2 registers, the rest one by one. Each vertex row
   is read and updated as a 2-wide (x, y) plus a scalar (z) access, never past its 3 values, so the
   loop needs no padding and consecutive updates of one vertex forward from store to load. */
#include <msim/spring_sweep.h>
#include <cmath>
#if defined(__AVX2__) && defined(__FMA__)
  #include <immintrin.h>
#endif

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

#if defined(__AVX2__) && defined(__FMA__)
static inline __m256d Load3(const double *p)
{
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p)), _mm_load_sd(p + 2), 1);
}

static inline void Add3(double *p, __m256d v)
{
  _mm_storeu_pd(p, _mm_add_pd(_mm_loadu_pd(p), _mm256_castpd256_pd128(v)));
  p[2] += _mm_cvtsd_f64(_mm256_extractf128_pd(v, 1));
}

static inline void Sub3(double *p, __m256d v)
{
  _mm_storeu_pd(p, _mm_sub_pd(_mm_loadu_pd(p), _mm256_castpd256_pd128(v)));
  p[2] -= _mm_cvtsd_f64(_mm256_extractf128_pd(v, 1));
}

template <bool F, bool E>
static void Sweep(PetscInt n, const PetscInt *i, const PetscInt *j, const PetscReal *k, const PetscReal *L, const PetscReal *x, PetscReal *f, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  const __m256d va = _mm256_set1_pd(alpha), vb = _mm256_set1_pd(beta);
  __m256d       ve = _mm256_setzero_pd();
  PetscInt      s  = 0;
  for (; s + 4 <= n; s += 4) {
    const __m256d d0 = _mm256_sub_pd(Load3(x + 3 * i[s]), Load3(x + 3 * j[s]));
    const __m256d d1 = _mm256_sub_pd(Load3(x + 3 * i[s + 1]), Load3(x + 3 * j[s + 1]));
    const __m256d d2 = _mm256_sub_pd(Load3(x + 3 * i[s + 2]), Load3(x + 3 * j[s + 2]));
    const __m256d d3 = _mm256_sub_pd(Load3(x + 3 * i[s + 3]), Load3(x + 3 * j[s + 3]));
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
      Add3(f + 3 * i[s], f0);
      Sub3(f + 3 * j[s], f0);
      Add3(f + 3 * i[s + 1], f1);
      Sub3(f + 3 * j[s + 1], f1);
      Add3(f + 3 * i[s + 2], f2);
      Sub3(f + 3 * j[s + 2], f2);
      Add3(f + 3 * i[s + 3], f3);
      Sub3(f + 3 * j[s + 3], f3);
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

#if defined(__AVX2__) && defined(__FMA__)
template <bool F, bool E>
static void SweepSlices(PetscInt nslice, const PetscInt *cptr, const PetscInt *sj, const PetscReal *sk, const PetscReal *sL, const PetscReal *x, PetscReal *f4, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  const __m256d va = _mm256_set1_pd(alpha), vb = _mm256_set1_pd(beta), zero = _mm256_setzero_pd();
  __m256d       ve = zero;
  for (PetscInt c = 0; c < nslice; c++) {
    const double *xv = x + 12 * c;
    const __m256d x0 = Load3(xv), x1 = Load3(xv + 3), x2 = Load3(xv + 6), x3 = Load3(xv + 9);
    __m256d       a0 = zero, a1 = zero, a2 = zero, a3 = zero;
    for (PetscInt q = cptr[c]; q < cptr[c + 1]; q++) {
      const PetscInt *J  = sj + 4 * q;
      const __m256d   d0 = _mm256_sub_pd(x0, Load3(x + 3 * J[0]));
      const __m256d   d1 = _mm256_sub_pd(x1, Load3(x + 3 * J[1]));
      const __m256d   d2 = _mm256_sub_pd(x2, Load3(x + 3 * J[2]));
      const __m256d   d3 = _mm256_sub_pd(x3, Load3(x + 3 * J[3]));
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
        const __m256d c4 = _mm256_and_pd(_mm256_mul_pd(vk, _mm256_fmadd_pd(vb, _mm256_div_pd(vL, l), va)), _mm256_cmp_pd(vk, zero, _CMP_NEQ_OQ));
        const __m256d f0 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0x00), d0);
        const __m256d f1 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0x55), d1);
        const __m256d f2 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0xAA), d2);
        const __m256d f3 = _mm256_mul_pd(_mm256_permute4x64_pd(c4, 0xFF), d3);
        a0 = _mm256_add_pd(a0, f0);
        a1 = _mm256_add_pd(a1, f1);
        a2 = _mm256_add_pd(a2, f2);
        a3 = _mm256_add_pd(a3, f3);
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
  if (E) {
    double lanes[4];
    _mm256_storeu_pd(lanes, ve);
    *e2 += (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]);
  }
}
#else
template <bool F, bool E>
static void SweepSlices(PetscInt nslice, const PetscInt *cptr, const PetscInt *sj, const PetscReal *sk, const PetscReal *sL, const PetscReal *x, PetscReal *f4, PetscReal alpha, PetscReal beta, PetscReal *e2)
{
  for (PetscInt c = 0; c < nslice; c++)
    for (PetscInt q = cptr[c]; q < cptr[c + 1]; q++)
      for (PetscInt lane = 0; lane < 4; lane++) {
        const PetscInt   v = 4 * c + lane, j = sj[4 * q + lane];
        const PetscReal  k = sk[4 * q + lane], L = sL[4 * q + lane];
        const PetscReal *xi = x + 3 * v, *xj = x + 3 * j;
        const PetscReal  d0 = xi[0] - xj[0], d1 = xi[1] - xj[1], d2 = xi[2] - xj[2];
        const PetscReal  l  = std::sqrt(d0 * d0 + d1 * d1 + d2 * d2);
        if (k == 0) continue;
        if (E) *e2 += k * (l - L) * (l - L);
        if (F) {
          const PetscReal cc = k * (alpha + beta * L / l);
          f4[4 * v] += cc * d0, f4[4 * v + 1] += cc * d1, f4[4 * v + 2] += cc * d2;
          f4[4 * j] -= cc * d0, f4[4 * j + 1] -= cc * d1, f4[4 * j + 2] -= cc * d2;
        }
      }
}
#endif

void MSimSpringSweepSlices(PetscInt nslice, const PetscInt *cptr, const PetscInt *sj, const PetscReal *sk, const PetscReal *sL, const PetscReal *x, PetscReal *f4, PetscReal alpha, PetscReal beta, PetscReal *energy)
{
  PetscReal e2 = 0;
  if (f4 && energy) SweepSlices<true, true>(nslice, cptr, sj, sk, sL, x, f4, alpha, beta, &e2);
  else if (f4) SweepSlices<true, false>(nslice, cptr, sj, sk, sL, x, f4, alpha, beta, &e2);
  else if (energy) SweepSlices<false, true>(nslice, cptr, sj, sk, sL, x, f4, alpha, beta, &e2);
  if (energy) *energy += 0.5 * e2;
}

void MSimSpringFold(PetscInt n, PetscReal *f4, PetscReal *f)
{
  PetscInt v = 0;
#if defined(__AVX2__) && defined(__FMA__)
  /* four rows (x, y, z, 0) at a time into twelve consecutive values (x0 y0 z0 x1 | y1 z1 x2 y2 |
     z2 x3 y3 z3) */
  const __m256d zero = _mm256_setzero_pd();
  for (; v + 4 <= n; v += 4) {
    double       *r  = f4 + 4 * v, *o = f + 3 * v;
    const __m256d r0 = _mm256_load_pd(r), r1 = _mm256_load_pd(r + 4), r2 = _mm256_load_pd(r + 8), r3 = _mm256_load_pd(r + 12);
    const __m256d o0 = _mm256_blend_pd(r0, _mm256_permute4x64_pd(r1, 0x00), 0x8);
    const __m256d o1 = _mm256_blend_pd(_mm256_permute4x64_pd(r1, 0x09), _mm256_permute4x64_pd(r2, 0x40), 0xC);
    const __m256d o2 = _mm256_blend_pd(_mm256_permute4x64_pd(r3, 0x90), _mm256_permute4x64_pd(r2, 0x02), 0x1);
    _mm256_storeu_pd(o, _mm256_add_pd(_mm256_loadu_pd(o), o0));
    _mm256_storeu_pd(o + 4, _mm256_add_pd(_mm256_loadu_pd(o + 4), o1));
    _mm256_storeu_pd(o + 8, _mm256_add_pd(_mm256_loadu_pd(o + 8), o2));
    _mm256_store_pd(r, zero);
    _mm256_store_pd(r + 4, zero);
    _mm256_store_pd(r + 8, zero);
    _mm256_store_pd(r + 12, zero);
  }
#endif
  for (; v < n; v++)
    for (int c = 0; c < 3; c++) {
      f[3 * v + c] += f4[4 * v + c];
      f4[4 * v + c] = 0;
    }
}

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
      PetscReal      *fi = (i[s] < nown ? fown : floc) + 3 * i[s], *fj = (j[s] < nown ? fown : floc) + 3 * j[s];
      fi[0] += c * d0;
      fi[1] += c * d1;
      fi[2] += c * d2;
      fj[0] -= c * d0;
      fj[1] -= c * d1;
      fj[2] -= c * d2;
    }
  }
  if (energy) *energy += 0.5 * e2;
}
