/* 4-wide (AVX2) access to rows of 3 values, the layout of a block-size-3 Vec's array: one row into
   the low three lanes; four consecutive rows to and from x, y, z values (lane l = row l). */
#pragma once
#if defined(__AVX2__) && defined(__FMA__)
  #include <immintrin.h>
  #define MSIM_SIMD_ROWS 1

/* a row into lanes 0-2 (lane 3 zero), never reading past it */
static inline __m256d MSimLoad3(const double *p)
{
  return _mm256_insertf128_pd(_mm256_castpd128_pd256(_mm_loadu_pd(p)), _mm_load_sd(p + 2), 1);
}

static inline void MSimAdd3(double *p, __m256d v)
{
  _mm_storeu_pd(p, _mm_add_pd(_mm_loadu_pd(p), _mm256_castpd256_pd128(v)));
  p[2] += _mm_cvtsd_f64(_mm256_extractf128_pd(v, 1));
}

static inline void MSimSub3(double *p, __m256d v)
{
  _mm_storeu_pd(p, _mm_sub_pd(_mm_loadu_pd(p), _mm256_castpd256_pd128(v)));
  p[2] -= _mm_cvtsd_f64(_mm256_extractf128_pd(v, 1));
}

/* rows p[0..12) = (x0 y0 z0 x1 | y1 z1 x2 y2 | z2 x3 y3 z3) into X, Y, Z */
static inline void MSimRowsToXYZ(const double *p, __m256d *X, __m256d *Y, __m256d *Z)
{
  const __m256d a = _mm256_loadu_pd(p), b = _mm256_loadu_pd(p + 4), c = _mm256_loadu_pd(p + 8);
  const __m256d xy02 = _mm256_blend_pd(a, b, 0xC);          /* x0 y0 x2 y2 */
  const __m256d zx13 = _mm256_permute2f128_pd(a, c, 0x21);  /* z0 x1 z2 x3 */
  const __m256d yz13 = _mm256_blend_pd(b, c, 0xC);          /* y1 z1 y3 z3 */
  *X                 = _mm256_blend_pd(xy02, zx13, 0xA);
  *Y                 = _mm256_shuffle_pd(xy02, yz13, 0x5);
  *Z                 = _mm256_blend_pd(zx13, yz13, 0xA);
}

/* X, Y, Z as four rows: the values of p[0..12) in r[0..3) */
static inline void MSimXYZToRows(__m256d X, __m256d Y, __m256d Z, __m256d r[3])
{
  const __m256d xy02 = _mm256_unpacklo_pd(X, Y), yz13 = _mm256_unpackhi_pd(Y, Z), zx13 = _mm256_shuffle_pd(Z, X, 0xA);
  r[0]               = _mm256_permute2f128_pd(xy02, zx13, 0x20);
  r[1]               = _mm256_blend_pd(yz13, xy02, 0xC);
  r[2]               = _mm256_permute2f128_pd(zx13, yz13, 0x31);
}

/* p[0..12) += X, Y, Z as four rows */
static inline void MSimAddXYZToRows(double *p, __m256d X, __m256d Y, __m256d Z)
{
  __m256d r[3];
  MSimXYZToRows(X, Y, Z, r);
  for (int k = 0; k < 3; k++) _mm256_storeu_pd(p + 4 * k, _mm256_add_pd(_mm256_loadu_pd(p + 4 * k), r[k]));
}
#endif
