#include "pd_lbfgs.h"
#include <msim/petsc_compat.h>
#include <utility>
#if defined(__AVX2__) && defined(__FMA__)
  #include <immintrin.h>
#endif

PetscErrorCode MSimLBFGSCreate(Vec tmpl, PetscInt m, MSimLBFGS *lb)
{
  PetscFunctionBeginUser;
  lb->m = m;
  lb->S.assign(m, NULL);
  lb->Y.assign(m, NULL);
  for (PetscInt k = 0; k < m; k++) {
    PetscCall(VecDuplicate(tmpl, &lb->S[k]));
    PetscCall(VecDuplicate(tmpl, &lb->Y[k]));
  }
  PetscCall(VecDuplicate(tmpl, &lb->q));
  lb->rho.assign(m, 0.0);
  lb->a.assign(m, 0.0);
  lb->gram.assign(m * m, 0.0);
  lb->arow.assign(m, 0.0);
  lb->b.assign(m, 0.0);
  lb->qs.assign(m, 0.0);
  lb->dad = lb->dad_scale = 0;
  lb->skipped = lb->exact_rows = 0;
  PetscCall(MSimLBFGSReset(lb));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimLBFGSDestroy(MSimLBFGS *lb)
{
  PetscFunctionBeginUser;
  for (Vec &v : lb->S) PetscCall(VecDestroy(&v));
  for (Vec &v : lb->Y) PetscCall(VecDestroy(&v));
  PetscCall(VecDestroy(&lb->q));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimLBFGSReset(MSimLBFGS *lb)
{
  PetscFunctionBeginUser;
  lb->count = lb->next = 0;
  lb->gamma            = 1;
  lb->sg_valid         = PETSC_FALSE;
  lb->gram_valid       = PETSC_TRUE; /* no pairs: nothing to keep */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The vector passes, 4-wide with AVX2 (written out: the compiler's vectorizer gives up on loops
   with this many pointers, whose overlap it would have to test, and on FP sums it may not
   reorder; valgrind counted 14 instructions per entry in the pair's pass). Each sum keeps 4-wide
   partial sums, added at the end. */
#if defined(__AVX2__) && defined(__FMA__)
typedef __m256d V4;
static inline V4 V4Zero(void) { return _mm256_setzero_pd(); }
static inline V4 V4Load(const PetscScalar *p) { return _mm256_loadu_pd(p); }
static inline void V4Store(PetscScalar *p, V4 v) { _mm256_storeu_pd(p, v); }
static inline V4 V4Set(PetscScalar a) { return _mm256_set1_pd(a); }
static inline V4 V4Fma(V4 a, V4 b, V4 c) { return _mm256_fmadd_pd(a, b, c); }
static inline V4 V4Sub(V4 a, V4 b) { return _mm256_sub_pd(a, b); }
static inline V4 V4Mul(V4 a, V4 b) { return _mm256_mul_pd(a, b); }
static inline PetscScalar V4Sum(V4 v)
{
  alignas(32) double t[4];
  _mm256_store_pd(t, v);
  return (t[0] + t[1]) + (t[2] + t[3]);
}
#else
struct V4 {
  PetscScalar v[4];
};
static inline V4 V4Zero(void) { return V4{{0, 0, 0, 0}}; }
static inline V4 V4Load(const PetscScalar *p) { return V4{{p[0], p[1], p[2], p[3]}}; }
static inline void V4Store(PetscScalar *p, V4 a)
{
  for (int l = 0; l < 4; l++) p[l] = a.v[l];
}
static inline V4 V4Set(PetscScalar a) { return V4{{a, a, a, a}}; }
static inline V4 V4Fma(V4 a, V4 b, V4 c)
{
  for (int l = 0; l < 4; l++) c.v[l] += a.v[l] * b.v[l];
  return c;
}
static inline V4 V4Sub(V4 a, V4 b)
{
  for (int l = 0; l < 4; l++) a.v[l] -= b.v[l];
  return a;
}
static inline V4 V4Mul(V4 a, V4 b)
{
  for (int l = 0; l < 4; l++) a.v[l] *= b.v[l];
  return a;
}
static inline PetscScalar V4Sum(V4 a) { return (a.v[0] + a.v[1]) + (a.v[2] + a.v[3]); }
#endif
#define MSIM_LB_W 4

/* v = b + alpha u (U false: v = alpha b; b may be v), d1 = w1 . v, d2 = w2 . u (U false: w2 . v) */
template <bool U, bool W1, bool W2>
static void AXPYDotKernel(PetscInt n, PetscScalar *v, const PetscScalar *b, PetscScalar alpha, const PetscScalar *u, const PetscScalar *w1, const PetscScalar *w2, PetscScalar *d1, PetscScalar *d2)
{
  const V4 va = V4Set(alpha);
  V4       a1 = V4Zero(), a2 = V4Zero();
  PetscInt i  = 0;
  for (; i + MSIM_LB_W <= n; i += MSIM_LB_W) {
    const V4 uu = U ? V4Load(u + i) : V4Zero();
    const V4 x  = U ? V4Fma(va, uu, V4Load(b + i)) : V4Mul(va, V4Load(b + i));
    V4Store(v + i, x);
    if (W1) a1 = V4Fma(V4Load(w1 + i), x, a1);
    if (W2) a2 = V4Fma(V4Load(w2 + i), U ? uu : x, a2);
  }
  PetscScalar s1 = V4Sum(a1), s2 = V4Sum(a2);
  for (; i < n; i++) {
    const PetscScalar x = U ? b[i] + alpha * u[i] : alpha * b[i];
    v[i]                = x;
    if (W1) s1 += w1[i] * x;
    if (W2) s2 += w2[i] * (U ? u[i] : x);
  }
  *d1 = s1;
  *d2 = s2;
}

/* v = base + alpha u (base NULL: v itself; u NULL: v = alpha v), then the dots w1 . v and w2 . u
   (u NULL: w2 . v; w1, w2 NULL: none), in one pass and one reduction */
static PetscErrorCode AXPYDot(Vec v, Vec base, PetscScalar alpha, Vec u, Vec w1, PetscScalar *dot1, Vec w2 = NULL, PetscScalar *dot2 = NULL)
{
  PetscScalar       *pv, sum[2] = {0, 0}, d1 = 0, d2 = 0;
  const PetscScalar *pu = NULL, *pw1 = NULL, *pw2 = NULL, *pb = NULL;
  PetscInt           n, nd = 0;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(v, &n));
  PetscCall(VecGetArray(v, &pv));
  if (u) PetscCall(VecGetArrayRead(u, &pu));
  if (w1) PetscCall(VecGetArrayRead(w1, &pw1));
  if (w2) PetscCall(VecGetArrayRead(w2, &pw2));
  pb = pv;
  if (base) PetscCall(VecGetArrayRead(base, &pb));
  switch ((u ? 4 : 0) + (w1 ? 2 : 0) + (w2 ? 1 : 0)) {
  case 0: AXPYDotKernel<false, false, false>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  case 1: AXPYDotKernel<false, false, true>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  case 2: AXPYDotKernel<false, true, false>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  case 3: AXPYDotKernel<false, true, true>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  case 4: AXPYDotKernel<true, false, false>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  case 5: AXPYDotKernel<true, false, true>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  case 6: AXPYDotKernel<true, true, false>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  default: AXPYDotKernel<true, true, true>(n, pv, pb, alpha, pu, pw1, pw2, &d1, &d2); break;
  }
  if (w1) sum[nd++] = d1;
  if (w2) sum[nd++] = d2;
  if (base) PetscCall(VecRestoreArrayRead(base, &pb));
  if (u) PetscCall(VecRestoreArrayRead(u, &pu));
  if (w1) PetscCall(VecRestoreArrayRead(w1, &pw1));
  if (w2) PetscCall(VecRestoreArrayRead(w2, &pw2));
  PetscCall(VecRestoreArray(v, &pv));
  PetscCall(PetscLogFlops((2.0 + 2.0 * nd) * n));
  if (nd) PetscCall(MPIU_Allreduce(MPI_IN_PLACE, sum, nd, MPIU_SCALAR, MPIU_SUM, PetscObjectComm((PetscObject)v)));
  if (w1) *dot1 = sum[0];
  if (w2) *dot2 = sum[w1 ? 1 : 0];
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimLBFGSApply(MSimLBFGS *lb, Vec g, Vec d, PetscErrorCode (*h0)(void *, Vec, Vec), void *ctx, PetscScalar *gd, PetscBool track)
{
  const PetscInt c = lb->count, m = lb->m;
  auto           slot = [&](PetscInt j) { return (lb->next - 1 - j + lb->m) % lb->m; }; /* j = 0: the newest pair */
  PetscScalar    dot, d0q = 0;

  PetscFunctionBeginUser;
  if (c == 0) {
    PetscCall((*h0)(ctx, g, d));
    if (lb->gamma != 1) PetscCall(VecScale(d, lb->gamma));
    if (gd || track) PetscCall(VecDot(g, d, &dot));
    if (gd) *gd = dot;
    lb->dad      = lb->gamma * PetscRealPart(dot); /* d = gamma A^-1 g: d^T A d = gamma g . d */
    lb->dad_scale = lb->dad;
    lb->sg_valid = PETSC_FALSE;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* first loop, newest pair first: a_i = rho_i s_i . q, q -= a_i y_i (s_newest . g: from the pass
     that made that pair, where it holds) */
  if (lb->sg_valid) dot = lb->sg;
  else PetscCall(VecDot(lb->S[slot(0)], g, &dot));
  lb->sg_valid = PETSC_FALSE;
  for (PetscInt j = 0; j < c; j++) {
    const PetscInt i = slot(j);
    lb->a[i]         = lb->rho[i] * dot;
    PetscCall(AXPYDot(lb->q, j == 0 ? g : NULL, -lb->a[i], lb->Y[i], j + 1 < c ? lb->S[slot(j + 1)] : NULL, &dot));
  }
  /* r = A^-1 q, d = gamma r (with track also d . q), then the second loop, oldest pair first:
     d += b_i s_i, b_i = a_i - rho_i y_i . d (with track also s_i . q) */
  PetscCall((*h0)(ctx, lb->q, d));
  PetscCall(AXPYDot(d, NULL, lb->gamma, NULL, lb->Y[slot(c - 1)], &dot, track ? lb->q : NULL, &d0q));
  for (PetscInt j = c - 1; j >= 0; j--) {
    const PetscInt i = slot(j);
    lb->b[i]         = lb->a[i] - lb->rho[i] * dot;
    PetscCall(AXPYDot(d, NULL, lb->b[i], lb->S[i], j > 0 ? lb->Y[slot(j - 1)] : g, &dot, track ? lb->q : NULL, &lb->qs[i]));
  }
  if (gd) *gd = dot;
  if (track) {
    /* A d = gamma q + sum_i b_i A s_i: (A d) . s_j = gamma q . s_j + sum_i b_i G_ij, and
       d^T A d = gamma (d0 . q) + 2 gamma sum_i b_i (q . s_i) + b^T G b, since d0 = gamma A^-1 q
       gives d0^T A d0 = gamma d0 . q and s_i^T A d0 = gamma s_i . q */
    PetscReal bqs = 0, bgb = 0, parts = 0;
    for (PetscInt jj = 0; jj < c; jj++) {
      const PetscInt j = slot(jj);
      PetscReal      r = lb->gamma * PetscRealPart(lb->qs[j]);
      for (PetscInt ii = 0; ii < c; ii++) {
        const PetscInt i = slot(ii);
        r += PetscRealPart(lb->b[i]) * lb->gram[i * m + j];
      }
      lb->arow[j] = r;
      bqs += PetscRealPart(lb->b[j] * lb->qs[j]);
      bgb += PetscRealPart(lb->b[j]) * (r - lb->gamma * PetscRealPart(lb->qs[j]));
      parts += PetscAbsReal(PetscRealPart(lb->b[j])) * PetscSqrtReal(PetscMax(lb->gram[j * m + j], 0.0));
    }
    lb->dad       = lb->gamma * PetscRealPart(d0q) + 2 * lb->gamma * bqs + bgb;
    parts += PetscSqrtReal(PetscMax(lb->gamma * PetscRealPart(d0q), 0.0));
    lb->dad_scale = parts * parts;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* H0 = A^-1: the plain global solve (no guess: no max_step cut, no halving; the step's
   feasibility is the caller's) */
static PetscErrorCode PDInitialHessian(void *ctx, Vec q, Vec r)
{
  MSimPDProblem *pd = (MSimPDProblem *)ctx;
  PetscFunctionBeginUser;
  PetscCall((*pd->global_solve)(pd->ctx, q, NULL, r));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPDLBFGSCreate(MSimPDProblem *pd, Vec X, PetscInt m, PetscReal gamma_max, MSimPDLBFGS *st)
{
  PetscFunctionBeginUser;
  PetscCheck(pd->apply, PetscObjectComm((PetscObject)X), PETSC_ERR_SUP, "-snes_pd_lbfgs needs a problem that applies its PD matrix (msim's implicit schemes)");
  st->pd        = pd;
  st->gamma_max = gamma_max;
  st->phi       = 0;
  st->fallbacks = st->cut = st->backtracks = 0;
  st->use_fused = PETSC_TRUE;
  st->check     = PETSC_FALSE;
  st->fused = st->rhs_valid = PETSC_FALSE;
  PetscCall(MSimLBFGSCreate(X, m, &st->lb));
  PetscCall(VecDuplicate(X, &st->rhs));
  PetscCall(VecDuplicate(X, &st->G));
  PetscCall(VecDuplicate(X, &st->D));
  PetscCall(VecDuplicate(X, &st->Xt));
  PetscCall(VecDuplicate(X, &st->Rt));
  PetscCall(VecDuplicate(X, &st->Gt));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPDLBFGSDestroy(MSimPDLBFGS *st)
{
  PetscFunctionBeginUser;
  PetscCall(MSimLBFGSDestroy(&st->lb));
  PetscCall(VecDestroy(&st->rhs));
  PetscCall(VecDestroy(&st->G));
  PetscCall(VecDestroy(&st->D));
  PetscCall(VecDestroy(&st->Xt));
  PetscCall(VecDestroy(&st->Rt));
  PetscCall(VecDestroy(&st->Gt));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The local step's part at an iterate X: fused, Phi and the gradient G from the problem's
   passes; else Phi and rhs R (the gradient follows with the product, FinishGradient) */
static PetscErrorCode Local(MSimPDLBFGS *st, Vec X, Vec R, Vec G, PetscReal *phi)
{
  MSimPDProblem *pd = st->pd;
  PetscBool      done;

  PetscFunctionBeginUser;
  if (st->fused) {
    PetscCall((*pd->gradient)(pd->ctx, X, G, phi, &done));
    PetscCheck(done, PetscObjectComm((PetscObject)X), PETSC_ERR_PLIB, "pd: the problem's fused gradient stopped being available within a solve");
  } else PetscCall((*pd->rhs)(pd->ctx, X, R, phi));
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode FinishGradient(MSimPDLBFGS *st, Vec X, Vec R, Vec G)
{
  PetscFunctionBeginUser;
  if (!st->fused) PetscCall((*st->pd->apply)(st->pd->ctx, X, R, G)); /* G = A X - rhs */
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* -snes_pd_lbfgs_check: the fused gradient G at X against the product A X - rhs(X) (Rt, Gt
   are scratch here), for the tests: the difference is roundoff of |A X| and |rhs| */
static PetscErrorCode CheckGradient(MSimPDLBFGS *st, Vec X)
{
  MSimPDProblem *pd = st->pd;
  PetscReal      ng, nr, nd;

  PetscFunctionBeginUser;
  PetscCall((*pd->rhs)(pd->ctx, X, st->Rt, NULL));
  PetscCall((*pd->apply)(pd->ctx, X, st->Rt, st->Gt));
  PetscCall(VecNorm(st->Rt, NORM_2, &nr));
  PetscCall(VecAXPY(st->Gt, -1.0, st->G));
  PetscCall(VecNorm(st->Gt, NORM_2, &nd));
  PetscCall(VecNorm(st->G, NORM_2, &ng));
  PetscCall(PetscInfo(NULL, "pd: L-BFGS fused gradient check: |g - (A x - rhs)| %.3e |g| %.3e |rhs| %.3e\n", (double)nd, (double)ng, (double)nr));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPDLBFGSBegin(MSimPDLBFGS *st, Vec X)
{
  MSimPDProblem *pd = st->pd;
  PetscBool      done = PETSC_FALSE;

  PetscFunctionBeginUser;
  st->lb.sg_valid = PETSC_FALSE; /* a new gradient */
  if (st->use_fused && pd->gradient) PetscCall((*pd->gradient)(pd->ctx, X, st->G, &st->phi, &done));
  if (st->use_fused && !done) PetscCall(PetscInfo(NULL, "pd: L-BFGS: this problem's gradient takes the product A x - rhs(x) (a term cannot give its part in the local step)\n"));
  st->fused     = done;
  st->rhs_valid = (PetscBool)!done;
  if (done && !st->lb.gram_valid) {
    PetscCall(PetscInfo(NULL, "pd: L-BFGS: the stored pairs have no Gram rows (made without the fused gradient): the history starts afresh\n"));
    PetscCall(MSimLBFGSReset(&st->lb));
  }
  if (!done) {
    PetscCall((*pd->rhs)(pd->ctx, X, st->rhs, &st->phi));
    PetscCall((*pd->apply)(pd->ctx, X, st->rhs, st->G));
  } else if (st->check) {
    PetscCall(CheckGradient(st, X));
    PetscCall(PetscInfo(NULL, "pd: L-BFGS so far: %" PetscInt_FMT " Gram rows by the product\n", st->lb.exact_rows));
  }
  st->first = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* s = -t d (D) or xt - x, y = gt - g, x = xt; sum = s . y, s . gt, s . (rt - r) (R) */
template <bool D, bool R>
static void PairKernel(PetscInt n, PetscReal t, const PetscScalar *d, PetscScalar *x, const PetscScalar *xt, const PetscScalar *g, const PetscScalar *gt, const PetscScalar *r, const PetscScalar *rt, PetscScalar *s, PetscScalar *y, PetscScalar sum[3])
{
  const V4 vt = V4Set(-t);
  V4       a0 = V4Zero(), a1 = V4Zero(), a2 = V4Zero();
  PetscInt i  = 0;
  for (; i + MSIM_LB_W <= n; i += MSIM_LB_W) {
    const V4 vxt = V4Load(xt + i), vgt = V4Load(gt + i);
    const V4 vs  = D ? V4Mul(vt, V4Load(d + i)) : V4Sub(vxt, V4Load(x + i));
    const V4 vy  = V4Sub(vgt, V4Load(g + i));
    V4Store(s + i, vs);
    V4Store(y + i, vy);
    V4Store(x + i, vxt);
    a0 = V4Fma(vs, vy, a0);
    a1 = V4Fma(vs, vgt, a1);
    if (R) a2 = V4Fma(vs, V4Sub(V4Load(rt + i), V4Load(r + i)), a2);
  }
  PetscScalar s0 = V4Sum(a0), s1 = V4Sum(a1), s2 = V4Sum(a2);
  for (; i < n; i++) {
    const PetscScalar si = D ? -t * d[i] : xt[i] - x[i], yi = gt[i] - g[i];
    s[i] = si;
    y[i] = yi;
    x[i] = xt[i];
    s0 += si * yi;
    s1 += si * gt[i];
    if (R) s2 += si * (rt[i] - r[i]);
  }
  sum[0] = s0, sum[1] = s1, sum[2] = s2;
}

/* The new pair s = Xt - X (-t D for an L-BFGS step), y = Gt - G into the history's next slot, with X = Xt, in one pass with
   the sums s . y, s . Gt (the next apply's first dot) and, without the fused gradient,
   s . (Rt - rhs): s^T A s = s . y + s . (Rt - rhs), because A s = y + Rt - rhs. Fused, s^T A s
   comes from the Gram matrix for an L-BFGS step s = -t D (t), or from a product with A for the
   plain PD step (t = 0), which restarted the history. */
static PetscErrorCode PushPair(MSimPDLBFGS *st, Vec X, PetscReal t)
{
  MSimLBFGS         *lb = &st->lb;
  const PetscInt     m  = lb->m, k = lb->next;
  const PetscScalar *xt, *g, *gt, *r = NULL, *rt = NULL, *d = NULL;
  PetscScalar       *x, *s, *y, sum[3] = {0, 0, 0};
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(X, &n));
  PetscCall(VecGetArray(X, &x));
  if (t > 0) PetscCall(VecGetArrayRead(st->D, &d));
  PetscCall(VecGetArrayRead(st->Xt, &xt));
  PetscCall(VecGetArrayRead(st->G, &g));
  PetscCall(VecGetArrayRead(st->Gt, &gt));
  if (!st->fused) {
    PetscCall(VecGetArrayRead(st->rhs, &r));
    PetscCall(VecGetArrayRead(st->Rt, &rt));
  }
  PetscCall(VecGetArrayWrite(lb->S[k], &s));
  PetscCall(VecGetArrayWrite(lb->Y[k], &y));
  /* an L-BFGS step's s is -t D, whose Gram row the apply gave (xt - x would differ from it by
     the roundoff of x, all of s where the step is at roundoff near convergence) */
  if (t > 0) {
    if (st->fused) PairKernel<true, false>(n, t, d, x, xt, g, gt, NULL, NULL, s, y, sum);
    else PairKernel<true, true>(n, t, d, x, xt, g, gt, r, rt, s, y, sum);
  } else {
    if (st->fused) PairKernel<false, false>(n, t, d, x, xt, g, gt, NULL, NULL, s, y, sum);
    else PairKernel<false, true>(n, t, d, x, xt, g, gt, r, rt, s, y, sum);
  }
  PetscCall(VecRestoreArrayWrite(lb->Y[k], &y));
  PetscCall(VecRestoreArrayWrite(lb->S[k], &s));
  if (!st->fused) {
    PetscCall(VecRestoreArrayRead(st->Rt, &rt));
    PetscCall(VecRestoreArrayRead(st->rhs, &r));
  }
  PetscCall(VecRestoreArrayRead(st->Gt, &gt));
  PetscCall(VecRestoreArrayRead(st->G, &g));
  PetscCall(VecRestoreArrayRead(st->Xt, &xt));
  if (t > 0) PetscCall(VecRestoreArrayRead(st->D, &d));
  PetscCall(VecRestoreArray(X, &x));
  PetscCall(PetscLogFlops((st->fused ? 6.0 : 10.0) * n));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, sum, st->fused ? 2 : 3, MPIU_SCALAR, MPIU_SUM, PetscObjectComm((PetscObject)X)));
  const PetscReal sy = PetscRealPart(sum[0]);
  /* positive curvature only: a buckling cloth's Phi is not convex, and a pair with s . y <= 0
     would make H indefinite and its direction no descent */
  if (!(sy > 0) || PetscIsInfOrNanReal(sy)) {
    lb->skipped++;
    lb->sg_valid = PETSC_FALSE;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscReal sas;
  if (!st->fused) sas = sy + PetscRealPart(sum[2]);
  else if (t > 0 && lb->dad > 1e-6 * lb->dad_scale) {
    /* the new slot's row of the Gram matrix: (A s) . s_j = -t (A D) . s_j for the other pairs;
       d^T A d within about 1e-10 of itself (its parts' roundoff is 1e-16 of dad_scale) */
    sas = t * t * lb->dad;
    for (PetscInt jj = 0; jj < lb->count; jj++) {
      const PetscInt j = (lb->next - 1 - jj + m) % m;
      if (j != k) lb->gram[k * m + j] = lb->gram[j * m + k] = -t * lb->arow[j];
    }
  } else {
    /* the plain PD step's pair (t = 0: the first of a new history), or a d that mostly cancels:
       the row by the product, A s and its dots with the pairs' s (one pass) */
    std::vector<Vec>         w(1, lb->S[k]);
    std::vector<PetscInt>    js(1, k);
    std::vector<PetscScalar> v;
    lb->exact_rows++;
    PetscCall((*st->pd->apply)(st->pd->ctx, lb->S[k], NULL, st->Rt));
    for (PetscInt jj = 0; jj < lb->count; jj++) {
      const PetscInt j = (lb->next - 1 - jj + m) % m;
      if (j == k) continue;
      w.push_back(lb->S[j]);
      js.push_back(j);
    }
    v.resize(w.size());
    PetscCall(VecMDot(st->Rt, (PetscInt)w.size(), w.data(), v.data()));
    for (size_t q = 1; q < w.size(); q++) lb->gram[k * m + js[q]] = lb->gram[js[q] * m + k] = PetscRealPart(v[q]);
    sas = PetscRealPart(v[0]);
  }
  if (!st->fused) lb->gram_valid = PETSC_FALSE;
  if (st->fused) {
    lb->gram[k * m + k] = sas;
    if (st->check) {
      PetscScalar v;
      PetscCall((*st->pd->apply)(st->pd->ctx, lb->S[k], NULL, st->Rt));
      PetscCall(VecDot(lb->S[k], st->Rt, &v));
      PetscCall(PetscInfo(NULL, "pd: L-BFGS Gram check: s^T A s %.17g, by the product %.17g (relative difference %.3e)\n", (double)sas, (double)PetscRealPart(v), (double)(PetscAbsReal(sas - PetscRealPart(v)) / PetscAbsReal(PetscRealPart(v)))));
    }
  }
  lb->rho[k]   = 1.0 / sy;
  lb->next     = (k + 1) % m;
  lb->count    = PetscMin(lb->count + 1, m);
  lb->sg       = sum[1];
  lb->sg_valid = PETSC_TRUE;
  /* H0 = gamma A^-1 with gamma = s^T A s / s^T y: along s, Phi's curvature against A's. A, the
     springs' stiffness in every direction, is stiffer than Phi's Hessian across stretched
     springs, so gamma >= 1 mostly and the unscaled steps fall short; gamma is kept in
     [1, gamma_max] because a buckling cloth's s^T y can be near 0 */
  lb->gamma = PetscMin(st->gamma_max, PetscMax(1.0, sas / sy));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPDLBFGSIterate(MSimPDLBFGS *st, Vec X)
{
  MSimPDProblem *pd = st->pd;
  PetscScalar    gd;
  PetscReal      t = 1, phit = 0;
  PetscBool      accept = PETSC_FALSE;

  PetscFunctionBeginUser;
  /* the first iteration of a solve: the kept pairs, but H0 unscaled (the newest pair's scale
     belonged to the end of the last solve; scaled, the new step's first gradient overshot) */
  if (st->first) st->lb.gamma = 1;
  st->first = PETSC_FALSE;
  PetscCall(MSimLBFGSApply(&st->lb, st->G, st->D, PDInitialHessian, pd, &gd, st->fused));
  if (PetscRealPart(gd) > 0) { /* H is SPD: only roundoff or a non-finite g fails this */
    if (pd->max_step) PetscCall((*pd->max_step)(pd->ctx, X, st->D, &t));
    if (t < 1) st->cut++;
  }
  /* a step that would leave the feasible set is not shortened but replaced by the plain PD step:
     the quasi-Newton model knows the barrier only through A's lagged weights, so where a vertex
     near an obstacle stops the direction, the cut (one alpha for all vertices) left t ~ 1e-3 to
     1e-4 at each iteration, Armijo passed those crawls, and 10 iterations ended far above the
     minimum: the 31 x 31 and 51 x 51 cloths on the ball gained 2.8 J and 59 J
     (runs/contact/README.md). PD's global step holds such vertices by the barrier's weights. */
  if (PetscRealPart(gd) > 0 && t >= 1) {
    PetscCall(AXPYDot(st->Xt, X, -t, st->D, NULL, NULL));
    PetscCall(Local(st, st->Xt, st->Rt, st->Gt, &phit));
    /* Armijo's sufficient decrease, c1 = 1e-4; Phi's roundoff (MSIM_PHI_ROUNDOFF of |Phi|) is
       allowed near convergence, where the decrease asked for falls below what Phi resolves and
       the plain PD step would fare no better */
    accept = (PetscBool)(phit <= st->phi - 1e-4 * t * PetscRealPart(gd) + MSIM_PHI_ROUNDOFF * PetscAbsReal(st->phi));
    if (!accept && !PetscIsInfOrNanReal(phit)) {
      /* one step back to the minimum of the parabola through Phi(X), its slope -gd and Phi(Xt),
         in [0.1 t, 0.5 t]: a local step, where the plain PD step costs a sweep as well */
      const PetscReal curv = phit - st->phi + PetscRealPart(gd) * t;
      const PetscReal tb   = PetscMin(0.5 * t, PetscMax(0.1 * t, PetscRealPart(gd) * t * t / (2 * curv)));
      st->backtracks++;
      t = tb;
      PetscCall(AXPYDot(st->Xt, X, -t, st->D, NULL, NULL));
      PetscCall(Local(st, st->Xt, st->Rt, st->Gt, &phit));
      accept = (PetscBool)(phit <= st->phi - 1e-4 * t * PetscRealPart(gd) + MSIM_PHI_ROUNDOFF * PetscAbsReal(st->phi));
    }
  }
  if (!accept) {
    /* the plain PD step from X (its global step keeps the feasible set, and Phi's decrease
       where a barrier is stiffer than A), and a history that starts from its pair; fused, the
       local step's rhs at X is A X - g (one product) */
    st->fallbacks++;
    t = 0;
    PetscCall(MSimLBFGSReset(&st->lb));
    if (!st->rhs_valid) PetscCall((*pd->apply)(pd->ctx, X, st->G, st->rhs));
    PetscCall((*pd->global_solve)(pd->ctx, st->rhs, X, st->Xt));
    PetscCall(Local(st, st->Xt, st->Rt, st->Gt, &phit));
  }
  PetscCall(FinishGradient(st, st->Xt, st->Rt, st->Gt));
  PetscCall(PushPair(st, X, t)); /* and X = Xt */
  if (!st->fused) std::swap(st->rhs, st->Rt);
  st->rhs_valid = (PetscBool)!st->fused;
  std::swap(st->G, st->Gt);
  st->phi = phit;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the scalars before rho's m and the Gram matrix's m^2 (of the slots, as rho), in this order */
enum { LB_M, LB_COUNT, LB_NEXT, LB_GAMMA, LB_SKIPPED, LB_FALLBACKS, LB_CUT, LB_BACKTRACKS, LB_EXACT_ROWS, LB_GRAM_VALID, LB_NREAL };

PetscErrorCode MSimPDLBFGSGetHistory(MSimPDLBFGS *st, MSimSolverHistory *h)
{
  const MSimLBFGS *lb = &st->lb;

  PetscFunctionBeginUser;
  h->name = "pd_lbfgs";
  h->real = {(PetscReal)lb->m, (PetscReal)lb->count, (PetscReal)lb->next, lb->gamma, (PetscReal)lb->skipped, (PetscReal)st->fallbacks, (PetscReal)st->cut, (PetscReal)st->backtracks, (PetscReal)lb->exact_rows, (PetscReal)lb->gram_valid};
  h->real.insert(h->real.end(), lb->rho.begin(), lb->rho.end());
  h->real.insert(h->real.end(), lb->gram.begin(), lb->gram.end()); /* the next apply's s_i^T A s_j */
  /* every slot, not only the count in use: the ring then goes on exactly where it was */
  h->vec = lb->S;
  h->vec.insert(h->vec.end(), lb->Y.begin(), lb->Y.end());
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimPDLBFGSSetHistory(MSimPDLBFGS *st, const MSimSolverHistory *h, PetscBool *taken)
{
  MSimLBFGS     *lb = &st->lb;
  const PetscInt m  = lb->m;

  PetscFunctionBeginUser;
  *taken = PETSC_FALSE;
  if (h->name != "pd_lbfgs" || (PetscInt)h->real.size() != LB_NREAL + m + m * m || (PetscInt)h->vec.size() != 2 * m || h->real[LB_M] != m) PetscFunctionReturn(PETSC_SUCCESS);
  const PetscInt count = (PetscInt)h->real[LB_COUNT], next = (PetscInt)h->real[LB_NEXT];
  if (count < 0 || count > m || next < 0 || next >= m) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt k = 0; k < m; k++) {
    PetscCall(VecCopy(h->vec[k], lb->S[k]));
    PetscCall(VecCopy(h->vec[m + k], lb->Y[k]));
    lb->rho[k] = h->real[LB_NREAL + k];
  }
  for (PetscInt k = 0; k < m * m; k++) lb->gram[k] = h->real[LB_NREAL + m + k];
  lb->count      = count;
  lb->next       = next;
  lb->gamma      = h->real[LB_GAMMA];
  lb->skipped    = (PetscInt)h->real[LB_SKIPPED];
  lb->exact_rows = (PetscInt)h->real[LB_EXACT_ROWS];
  lb->gram_valid = (PetscBool)(h->real[LB_GRAM_VALID] != 0);
  st->fallbacks  = (PetscInt)h->real[LB_FALLBACKS];
  st->cut        = (PetscInt)h->real[LB_CUT];
  st->backtracks = (PetscInt)h->real[LB_BACKTRACKS];
  *taken         = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}
