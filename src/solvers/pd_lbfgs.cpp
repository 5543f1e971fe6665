#include "pd_lbfgs.h"
#include <msim/petsc_compat.h>
#include <utility>

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
  lb->skipped = 0;
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
  lb->gamma = 1;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the sum over ranks of one local dot product */
static PetscErrorCode SumAll(Vec v, PetscScalar *x)
{
  PetscFunctionBeginUser;
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, x, 1, MPIU_SCALAR, MPIU_SUM, PetscObjectComm((PetscObject)v)));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* this rank's w . v, with four partial sums: one sum's chain of dependent additions would
   keep the loop from vectorizing and cost a few cycles per entry */
static inline PetscScalar LocalDot(PetscInt n, const PetscScalar *__restrict w, const PetscScalar *__restrict v)
{
  PetscScalar s0 = 0, s1 = 0, s2 = 0, s3 = 0;
  PetscInt    i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += w[i] * v[i];
    s1 += w[i + 1] * v[i + 1];
    s2 += w[i + 2] * v[i + 2];
    s3 += w[i + 3] * v[i + 3];
  }
  for (; i < n; i++) s0 += w[i] * v[i];
  return (s0 + s1) + (s2 + s3);
}

/* v = base + alpha u (base NULL: v itself; u NULL: v = alpha v), then the dot w . v (w NULL:
   none), in one pass */
static PetscErrorCode AXPYDot(Vec v, Vec base, PetscScalar alpha, Vec u, Vec w, PetscScalar *dot)
{
  PetscScalar       *pv, sum = 0;
  const PetscScalar *pu = NULL, *pw = NULL, *pb = NULL;
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(v, &n));
  PetscCall(VecGetArray(v, &pv));
  if (u) PetscCall(VecGetArrayRead(u, &pu));
  if (w) PetscCall(VecGetArrayRead(w, &pw));
  pb = pv;
  if (base) PetscCall(VecGetArrayRead(base, &pb));
  if (u)
    for (PetscInt i = 0; i < n; i++) pv[i] = pb[i] + alpha * pu[i];
  else
    for (PetscInt i = 0; i < n; i++) pv[i] = alpha * pb[i];
  if (w) sum = LocalDot(n, pw, pv);
  if (base) PetscCall(VecRestoreArrayRead(base, &pb));
  if (u) PetscCall(VecRestoreArrayRead(u, &pu));
  if (w) PetscCall(VecRestoreArrayRead(w, &pw));
  PetscCall(VecRestoreArray(v, &pv));
  PetscCall(PetscLogFlops(4.0 * n));
  if (w) {
    *dot = sum;
    PetscCall(SumAll(v, dot));
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimLBFGSApply(MSimLBFGS *lb, Vec g, Vec d, PetscErrorCode (*h0)(void *, Vec, Vec), void *ctx, PetscScalar *gd)
{
  const PetscInt c = lb->count;
  auto           slot = [&](PetscInt j) { return (lb->next - 1 - j + lb->m) % lb->m; }; /* j = 0: the newest pair */
  PetscScalar    dot;

  PetscFunctionBeginUser;
  if (c == 0) {
    PetscCall((*h0)(ctx, g, d));
    if (lb->gamma != 1) PetscCall(VecScale(d, lb->gamma));
    if (gd) PetscCall(VecDot(g, d, gd));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  /* first loop, newest pair first: a_i = rho_i s_i . q, q -= a_i y_i */
  PetscCall(VecDot(lb->S[slot(0)], g, &dot));
  for (PetscInt j = 0; j < c; j++) {
    const PetscInt i = slot(j);
    lb->a[i]         = lb->rho[i] * dot;
    PetscCall(AXPYDot(lb->q, j == 0 ? g : NULL, -lb->a[i], lb->Y[i], j + 1 < c ? lb->S[slot(j + 1)] : NULL, &dot));
  }
  /* r = gamma A^-1 q, then the second loop, oldest pair first: d += (a_i - rho_i y_i . d) s_i */
  PetscCall((*h0)(ctx, lb->q, d));
  PetscCall(AXPYDot(d, NULL, lb->gamma, NULL, lb->Y[slot(c - 1)], &dot));
  for (PetscInt j = c - 1; j >= 0; j--) {
    const PetscInt i = slot(j);
    PetscCall(AXPYDot(d, NULL, lb->a[i] - lb->rho[i] * dot, lb->S[i], j > 0 ? lb->Y[slot(j - 1)] : g, &dot));
  }
  if (gd) *gd = dot;
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

/* G = A X - rhs (rhs: the local step's at X) */
static PetscErrorCode PDGradient(MSimPDProblem *pd, Vec X, Vec rhs, Vec G)
{
  PetscFunctionBeginUser;
  PetscCall((*pd->apply)(pd->ctx, X, rhs, G));
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

PetscErrorCode MSimPDLBFGSBegin(MSimPDLBFGS *st, Vec X)
{
  PetscFunctionBeginUser;
  PetscCall((*st->pd->rhs)(st->pd->ctx, X, st->rhs, &st->phi));
  PetscCall(PDGradient(st->pd, X, st->rhs, st->G));
  st->first = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The new pair s = Xt - X, y = Gt - G into the history's next slot, in one pass with the sums
   s . y and s . (Rt - rhs): s^T A s = s . y + s . (Rt - rhs), because A s = y + Rt - rhs */
static PetscErrorCode PushPair(MSimPDLBFGS *st, Vec X)
{
  MSimLBFGS         *lb = &st->lb;
  const PetscScalar *x, *xt, *g, *gt, *r, *rt;
  PetscScalar       *s, *y, sum[2] = {0, 0};
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(X, &n));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(st->Xt, &xt));
  PetscCall(VecGetArrayRead(st->G, &g));
  PetscCall(VecGetArrayRead(st->Gt, &gt));
  PetscCall(VecGetArrayRead(st->rhs, &r));
  PetscCall(VecGetArrayRead(st->Rt, &rt));
  PetscCall(VecGetArrayWrite(lb->S[lb->next], &s));
  PetscCall(VecGetArrayWrite(lb->Y[lb->next], &y));
  for (PetscInt i = 0; i < n; i++) {
    s[i] = xt[i] - x[i];
    y[i] = gt[i] - g[i];
  }
  sum[0] = LocalDot(n, s, y);
  sum[1] = LocalDot(n, s, rt) - LocalDot(n, s, r);
  PetscCall(VecRestoreArrayWrite(lb->Y[lb->next], &y));
  PetscCall(VecRestoreArrayWrite(lb->S[lb->next], &s));
  PetscCall(VecRestoreArrayRead(st->Rt, &rt));
  PetscCall(VecRestoreArrayRead(st->rhs, &r));
  PetscCall(VecRestoreArrayRead(st->Gt, &gt));
  PetscCall(VecRestoreArrayRead(st->G, &g));
  PetscCall(VecRestoreArrayRead(st->Xt, &xt));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(PetscLogFlops(7.0 * n));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, sum, 2, MPIU_SCALAR, MPIU_SUM, PetscObjectComm((PetscObject)X)));
  const PetscReal sy = PetscRealPart(sum[0]), sas = sy + PetscRealPart(sum[1]);
  /* positive curvature only: a buckling cloth's Phi is not convex, and a pair with s . y <= 0
     would make H indefinite and its direction no descent */
  if (!(sy > 0) || PetscIsInfOrNanReal(sy)) {
    lb->skipped++;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  lb->rho[lb->next] = 1.0 / sy;
  lb->next          = (lb->next + 1) % lb->m;
  lb->count         = PetscMin(lb->count + 1, lb->m);
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
  PetscCall(MSimLBFGSApply(&st->lb, st->G, st->D, PDInitialHessian, pd, &gd));
  if (PetscRealPart(gd) > 0) { /* H is SPD: only roundoff or a non-finite g fails this */
    if (pd->max_step) PetscCall((*pd->max_step)(pd->ctx, X, st->D, &t));
    if (t < 1) st->cut++;
  }
  if (PetscRealPart(gd) > 0 && t > 0) {
    PetscCall(AXPYDot(st->Xt, X, -t, st->D, NULL, NULL));
    PetscCall((*pd->rhs)(pd->ctx, st->Xt, st->Rt, &phit));
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
      PetscCall((*pd->rhs)(pd->ctx, st->Xt, st->Rt, &phit));
      accept = (PetscBool)(phit <= st->phi - 1e-4 * t * PetscRealPart(gd) + MSIM_PHI_ROUNDOFF * PetscAbsReal(st->phi));
    }
  }
  if (!accept) {
    /* the plain PD step from X (its global step keeps the feasible set, and Phi's decrease
       where a barrier is stiffer than A), and a history that starts from its pair */
    st->fallbacks++;
    PetscCall(MSimLBFGSReset(&st->lb));
    PetscCall((*pd->global_solve)(pd->ctx, st->rhs, X, st->Xt));
    PetscCall((*pd->rhs)(pd->ctx, st->Xt, st->Rt, &phit));
  }
  PetscCall(PDGradient(pd, st->Xt, st->Rt, st->Gt));
  PetscCall(PushPair(st, X));
  PetscCall(VecCopy(st->Xt, X));
  std::swap(st->rhs, st->Rt);
  std::swap(st->G, st->Gt);
  st->phi = phit;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the scalars before rho's m, in this order */
enum { LB_M, LB_COUNT, LB_NEXT, LB_GAMMA, LB_SKIPPED, LB_FALLBACKS, LB_CUT, LB_BACKTRACKS, LB_NREAL };

PetscErrorCode MSimPDLBFGSGetHistory(MSimPDLBFGS *st, MSimSolverHistory *h)
{
  const MSimLBFGS *lb = &st->lb;

  PetscFunctionBeginUser;
  h->name = "pd_lbfgs";
  h->real = {(PetscReal)lb->m, (PetscReal)lb->count, (PetscReal)lb->next, lb->gamma, (PetscReal)lb->skipped, (PetscReal)st->fallbacks, (PetscReal)st->cut, (PetscReal)st->backtracks};
  h->real.insert(h->real.end(), lb->rho.begin(), lb->rho.end());
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
  if (h->name != "pd_lbfgs" || (PetscInt)h->real.size() != LB_NREAL + m || (PetscInt)h->vec.size() != 2 * m || h->real[LB_M] != m) PetscFunctionReturn(PETSC_SUCCESS);
  const PetscInt count = (PetscInt)h->real[LB_COUNT], next = (PetscInt)h->real[LB_NEXT];
  if (count < 0 || count > m || next < 0 || next >= m) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt k = 0; k < m; k++) {
    PetscCall(VecCopy(h->vec[k], lb->S[k]));
    PetscCall(VecCopy(h->vec[m + k], lb->Y[k]));
    lb->rho[k] = h->real[LB_NREAL + k];
  }
  lb->count      = count;
  lb->next       = next;
  lb->gamma      = h->real[LB_GAMMA];
  lb->skipped    = (PetscInt)h->real[LB_SKIPPED];
  st->fallbacks  = (PetscInt)h->real[LB_FALLBACKS];
  st->cut        = (PetscInt)h->real[LB_CUT];
  st->backtracks = (PetscInt)h->real[LB_BACKTRACKS];
  *taken         = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}
