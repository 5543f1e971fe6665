/* Phi's gradient in PD's local-step passes, for PD + L-BFGS (-snes_pd_lbfgs, pd_lbfgs.cpp). The
   local step gives rhs(x) and Phi's gradient is g = A x - rhs(x): a product with A (1.6 M of a
   fused iteration's 7.66 M instructions on the benchmark cloth, more than the local step's own
   passes). Each term's part of g is known where the local step computes its part of rhs:
   - inertia and the diagonal terms (drag): M (x - y) + w (x - c), in the inertia pass;
   - the springs: h2 k (1 - L/l) d where rhs takes h2 k (L/l) d (the same sweep with other
     coefficients; the damping's hd kd (n . u) n), their pd_gradient op;
   - a term with no weight in A (the tets' volume, self-contact, friction, obstacles without PD
     weights): its pd_rhs adds -grad E, so g takes the negative of what it adds: G is negated
     around their pd_rhs (exact in floating point), no pass of their own;
   - a term with weights in A and a pd_gradient (the obstacles' PD weights: their w_v x_v in
     A x and in rhs cancel, so their part is the barrier's gradient alone);
   - a term with weights in A but no pd_gradient: not here; *done = false and the caller takes
     rhs and the product. Terms whose weights follow the state (pd_reweight) take them here, as
     the local step would; where that changed A (a refactorization, once a time step at most),
     *done = false as well, for this solve: the stored pairs' Gram rows s_i^T A s_j belong to the
     old A, and a solve by the product keeps none, so the next fused solve starts its history
     afresh. */
#include <msim/implicit.h>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <petsc/private/petscimpl.h> /* PetscObjectStateGet: the Phi cache, as MSimImplicitPDRHS */
#if defined(__AVX2__) && defined(__FMA__)
  #include <immintrin.h>
#endif

/* g = m (x - y) + w (x - c), returning sum m (x - y)^2 + w (x - c)^2; 4-wide with AVX2 (the
   vectorizer does not reorder the sum) */
static PetscReal InertiaPass(PetscInt n, const PetscScalar *x, const PetscScalar *y, const PetscScalar *c, const PetscScalar *m, PetscReal w, PetscScalar *g)
{
  PetscInt  i = 0;
  PetscReal e = 0;
#if defined(__AVX2__) && defined(__FMA__)
  const __m256d vw = _mm256_set1_pd(w);
  __m256d       acc = _mm256_setzero_pd();
  for (; i + 4 <= n; i += 4) {
    const __m256d vx = _mm256_loadu_pd(x + i), vm = _mm256_loadu_pd(m + i);
    const __m256d a = _mm256_sub_pd(vx, _mm256_loadu_pd(y + i)), b = _mm256_sub_pd(vx, _mm256_loadu_pd(c + i));
    const __m256d ma = _mm256_mul_pd(vm, a), wb = _mm256_mul_pd(vw, b);
    _mm256_storeu_pd(g + i, _mm256_add_pd(ma, wb));
    acc = _mm256_fmadd_pd(ma, a, _mm256_fmadd_pd(wb, b, acc));
  }
  alignas(32) double t[4];
  _mm256_store_pd(t, acc);
  e = (t[0] + t[1]) + (t[2] + t[3]);
#endif
  for (; i < n; i++) {
    const PetscReal a = x[i] - y[i], b = x[i] - c[i];
    g[i] = m[i] * a + w * b;
    e += m[i] * a * a + w * b * b;
  }
  return e;
}

PetscErrorCode MSimImplicitPDGradient(void *ctx, Vec X, Vec G, PetscReal *phi, PetscBool *done)
{
  MSimImplicit       imp = (MSimImplicit)ctx;
  MSimSystem         sys = imp->sys;
  const PetscScalar *x, *y, *m, *cg;
  PetscScalar       *g;
  PetscReal          energy = 0, w = 0;
  PetscBool          lagged = PETSC_FALSE; /* a term whose part is -(its pd_rhs) */
  PetscBool          reweight = PETSC_FALSE;
  Vec                C      = imp->Y;
  const PetscInt     n      = 3 * sys->nown;

  PetscFunctionBeginUser;
  *done = PETSC_FALSE;
  /* a deferred Phi check belongs to plain PD's rhs (never set while L-BFGS runs): let it resolve */
  if (imp->pd_pending) PetscFunctionReturn(PETSC_SUCCESS);
  for (PetscInt k = 0; k < imp->nterms; k++) {
    const MSimImplicitTermOps &o = imp->terms[k]->ops;
    if ((o.pd_reweight && !o.pd_gradient) || (!o.diagonal && o.pd_matrix && !o.pd_gradient)) PetscFunctionReturn(PETSC_SUCCESS);
    if (o.pd_rhs && !o.pd_gradient) lagged = PETSC_TRUE;
    if (o.pd_reweight) reweight = PETSC_TRUE;
  }
  if (reweight) {
    PetscObjectState before = 0, after = 0;
    if (imp->A) PetscCall(PetscObjectStateGet((PetscObject)imp->A, &before));
    PetscCall(MSimImplicitPDReweight(imp, X));
    if (imp->A) PetscCall(PetscObjectStateGet((PetscObject)imp->A, &after));
    if (after != before) {
      PetscCall(PetscInfo(NULL, "pd: the state's PD weights changed A at this gradient: this solve takes the product\n"));
      PetscFunctionReturn(PETSC_SUCCESS);
    }
  }
  *done = PETSC_TRUE;
  PetscCall(MSimImplicitPDSetUp(imp)); /* y and the step's reference are set up with A */
  PetscCall(PetscLogEventBegin(MSIM_PDLocal, X, G, 0, 0));
  /* the inertia pass with the first diagonal term fused, as MSimImplicitPDRHS */
  PetscInt next;
  PetscCall(MSimImplicitPDLocalBegin(imp, X, &w, &C, &next));
  PetscCall(VecGetArrayWrite(G, &g));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(imp->Y, &y));
  const Vec C0 = C;
  PetscCall(VecGetArrayRead(C0, &cg));
  PetscCall(VecGetArrayRead(sys->mass, &m));
  energy = 0.5 * InertiaPass(n, x, y, cg, m, w, g);
  for (PetscInt k = next; k < imp->nterms; k++) {
    const PetscScalar *c;
    if (!imp->terms[k]->ops.diagonal) continue;
    PetscCall(imp->terms[k]->ops.diagonal(imp->terms[k], &w, &C));
    PetscCall(VecGetArrayRead(C, &c));
    for (PetscInt i = 0; i < n; i++) {
      g[i] += w * (x[i] - c[i]);
      energy += 0.5 * w * (x[i] - c[i]) * (x[i] - c[i]);
    }
    PetscCall(VecRestoreArrayRead(C, &c));
  }
  PetscCall(VecRestoreArrayRead(sys->mass, &m));
  PetscCall(VecRestoreArrayRead(C0, &cg));
  PetscCall(VecRestoreArrayRead(imp->Y, &y));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(VecRestoreArrayWrite(G, &g));
  for (PetscInt k = 0; k < imp->nterms; k++)
    if (imp->terms[k]->ops.pd_gradient) PetscCall(imp->terms[k]->ops.pd_gradient(imp->terms[k], X, G, &energy));
  if (lagged) {
    PetscCall(VecScale(G, -1.0));
    for (PetscInt k = 0; k < imp->nterms; k++)
      if (imp->terms[k]->ops.pd_rhs && !imp->terms[k]->ops.pd_gradient) PetscCall(imp->terms[k]->ops.pd_rhs(imp->terms[k], X, G, &energy));
    PetscCall(VecScale(G, -1.0));
  }
  PetscCall(MPIU_Allreduce(&energy, phi, 1, MPIU_REAL, MPIU_SUM, sys->comm));
  imp->pd_phi = *phi;
  PetscCall(PetscObjectGetId((PetscObject)X, &imp->pd_phi_id));
  PetscCall(PetscObjectStateGet((PetscObject)X, &imp->pd_phi_state));
  PetscCall(PetscLogEventEnd(MSIM_PDLocal, X, G, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
