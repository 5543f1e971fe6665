/* The narrow phase's geometry for self-contact: closest points of a point and a triangle, of two
   segments (Ericson, Real-Time Collision Detection, 5.1.5 and 5.1.9), as weights of the four points
   so that the difference of the closest points is r = sum_k w_k x_k; and additive CCD. Only the
   unsigned distance is needed: the barrier keeps it positive and the CCD keeps it from crossing 0
   between iterates. */
#include <msim/self_contact.h>
#include <cmath>

static inline PetscReal Dot(const PetscReal *a, const PetscReal *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static inline PetscReal Residual2(const PetscReal *x0, const PetscReal *x1, const PetscReal *x2, const PetscReal *x3, const PetscReal w[4])
{
  PetscReal s = 0;
  for (int c = 0; c < 3; c++) {
    const PetscReal r = w[0] * x0[c] + w[1] * x1[c] + w[2] * x2[c] + w[3] * x3[c];
    s += r * r;
  }
  return s;
}

PetscReal MSimPointTriangleDistance2(const PetscReal *p, const PetscReal *a, const PetscReal *b, const PetscReal *c, PetscReal w[4])
{
  PetscReal ab[3], ac[3], ap[3], bp[3], cp[3], u, v, t; /* closest point u a + v b + t c */
  for (int k = 0; k < 3; k++) {
    ab[k] = b[k] - a[k];
    ac[k] = c[k] - a[k];
    ap[k] = p[k] - a[k];
    bp[k] = p[k] - b[k];
    cp[k] = p[k] - c[k];
  }
  const PetscReal d1 = Dot(ab, ap), d2 = Dot(ac, ap), d3 = Dot(ab, bp), d4 = Dot(ac, bp), d5 = Dot(ab, cp), d6 = Dot(ac, cp);
  const PetscReal vc = d1 * d4 - d3 * d2, vb = d5 * d2 - d1 * d6, va = d3 * d6 - d5 * d4;
  if (d1 <= 0 && d2 <= 0) u = 1, v = 0, t = 0;                                  /* vertex a */
  else if (d3 >= 0 && d4 <= d3) u = 0, v = 1, t = 0;                            /* vertex b */
  else if (vc <= 0 && d1 >= 0 && d3 <= 0) v = d1 / (d1 - d3), u = 1 - v, t = 0; /* edge ab */
  else if (d6 >= 0 && d5 <= d6) u = 0, v = 0, t = 1;                            /* vertex c */
  else if (vb <= 0 && d2 >= 0 && d6 <= 0) t = d2 / (d2 - d6), u = 1 - t, v = 0; /* edge ac */
  else if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) t = (d4 - d3) / ((d4 - d3) + (d5 - d6)), v = 1 - t, u = 0; /* edge bc */
  else { /* inside the face */
    const PetscReal den = 1 / (va + vb + vc);
    v = vb * den, t = vc * den, u = 1 - v - t;
  }
  w[0] = 1, w[1] = -u, w[2] = -v, w[3] = -t;
  return Residual2(p, a, b, c, w);
}

PetscReal MSimEdgeEdgeDistance2(const PetscReal *p1, const PetscReal *q1, const PetscReal *p2, const PetscReal *q2, PetscReal w[4])
{
  PetscReal       d1[3], d2[3], r[3], s, t;
  const PetscReal eps = 1e-30;
  for (int k = 0; k < 3; k++) {
    d1[k] = q1[k] - p1[k];
    d2[k] = q2[k] - p2[k];
    r[k]  = p1[k] - p2[k];
  }
  const PetscReal a = Dot(d1, d1), e = Dot(d2, d2), f = Dot(d2, r);
  if (a <= eps && e <= eps) s = t = 0;
  else if (a <= eps) s = 0, t = PetscMin(PetscMax(f / e, 0.0), 1.0);
  else {
    const PetscReal c = Dot(d1, r);
    if (e <= eps) t = 0, s = PetscMin(PetscMax(-c / a, 0.0), 1.0);
    else {
      const PetscReal b = Dot(d1, d2), den = a * e - b * b;
      /* parallel (den 0): any s; 0, and t from it */
      s = den > 1e-14 * a * e ? PetscMin(PetscMax((b * f - c * e) / den, 0.0), 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0) t = 0, s = PetscMin(PetscMax(-c / a, 0.0), 1.0);
      else if (t > 1) t = 1, s = PetscMin(PetscMax((b - c) / a, 0.0), 1.0);
    }
  }
  w[0] = 1 - s, w[1] = s, w[2] = -(1 - t), w[3] = -t;
  return Residual2(p1, q1, p2, q2, w);
}

static PetscReal PairDistance(const PetscReal *x, PetscBool ee)
{
  PetscReal w[4];
  return std::sqrt(ee ? MSimEdgeEdgeDistance2(x, x + 3, x + 6, x + 9, w) : MSimPointTriangleDistance2(x, x + 3, x + 6, x + 9, w));
}

/* Each advance moves no point of the pair further (relative to the others) than l_p t, so a pair
   d apart cannot touch within t < d / l_p: advancing by 0.9 of that (first (1 - s) of it) until the
   gap falls below s d0 gives a time before any contact. A cap on the advances keeps the cost
   bounded; stopping early only returns a smaller, still safe, t. */
PetscReal MSimAdditiveCCD(const PetscReal x0[12], const PetscReal u0[12], PetscBool ee, PetscReal s)
{
  PetscReal u[12], x[12], mean[3] = {0, 0, 0}, len[4];
  for (int k = 0; k < 4; k++)
    for (int c = 0; c < 3; c++) mean[c] += 0.25 * u0[3 * k + c];
  for (int k = 0; k < 4; k++) {
    len[k] = 0;
    for (int c = 0; c < 3; c++) {
      u[3 * k + c] = u0[3 * k + c] - mean[c];
      len[k] += u[3 * k + c] * u[3 * k + c];
    }
    len[k] = std::sqrt(len[k]);
  }
  const PetscReal lp = ee ? PetscMax(len[0], len[1]) + PetscMax(len[2], len[3]) : len[0] + PetscMax(len[1], PetscMax(len[2], len[3]));
  if (lp == 0) return 1;
  for (int k = 0; k < 12; k++) x[k] = x0[k];
  PetscReal d = PairDistance(x, ee), t = 0, tl = (1 - s) * d / lp;
  const PetscReal g = s * d;
  if (tl > 1) return 1; /* the whole motion stays within the first advance (most pairs) */
  for (int it = 0; it < 2000; it++) {
    for (int k = 0; k < 12; k++) x[k] += tl * u[k];
    d = PairDistance(x, ee);
    if (t > 0 && d < g) return t;
    t += tl;
    if (t > 1) return 1;
    tl = 0.9 * d / lp;
  }
  return t;
}
