/* The self-contact barrier counts a contact once whatever features are closest
   (src/implicit/terms/self_contact.cpp, the point-edge and point-point weights), at any rank count.
   The scene: a flat sheet (a surface mesh: 5 x 5 vertices 1 m apart in z = 0, cells split along
   alternating diagonals) and a small tetrahedron's surface, its apex p pointing down, its other
   vertices 0.6 m above p, so that p's edges leave it steeply upwards. With p at height h < dhat
   above (a) a triangle's inside, (b) the middle of an interior edge (two triangles on it, and p's
   three edges each as close to it as p is: 2 point-triangle and 3 edge-edge pairs at distance h)
   and (c) an interior vertex with 4 edges and 4 triangles (4 + 3 point-triangle pairs, the
   vertex against p's faces too, and 3 x 4 edge-edge pairs at h), the only contact is
   one point at distance h from a flat surface, so, derived:
     energy E = C b(h^2), the gradient on p is 2 C b'(h^2) h e_z, on the sheet the opposite,
   C the term's weight (msim/self_contact.h: a pair's stiffness at dhat/2 equals a mean vertex's
   mass term), with -msim_self_contact_once; without it (the pairs' sum, the default) 5 x that
   above the edge and 19 x above the vertex, derived from the pairs counted. Also: the gradient against
   central differences of the energy near (b) and (c) (moved off the feature, so that the pairs'
   distances differ), and the Hessian is PSD (x^T H x >= 0 in random directions).
   The PSD Hessian (-msim_psd's, the one Newton-CG and Cholesky use) at (a), (b), (c): along the
   apex's vertical motion it must equal the energy's second derivative, derived m C (4 h^2 b'' +
   2 b') (d^2/dh^2 of m C b(h^2)) and measured by central second differences of the energy; with
   the option m = 1 only if the blocks of one contact are projected together (each term's block
   projected alone gave 5 and 32 x that above the edge and the vertex: the duplicates' positive
   blocks kept, their negative corrections dropped). */
#include "harness.h"
#include <msim/contact.h>
#include <msim/private/systemimpl.h>
#include <msim/private/implicitimpl.h>
#include <cstdio>
#include <unistd.h>
#include <string>

static PetscErrorCode FindTerm(MSimImplicit imp, const char name[], MSimImplicitTerm *term)
{
  PetscFunctionBeginUser;
  *term = NULL;
  for (PetscInt k = 0; k < imp->nterms; k++) {
    PetscBool same;
    PetscCall(PetscStrcmp(imp->terms[k]->type, name, &same));
    if (same) *term = imp->terms[k];
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* X = X0 with the tetrahedron (the vertices above z = 0.25) moved so that its apex is at p */
static PetscErrorCode Place(Vec X0, const PetscReal p0[3], const PetscReal p[3], Vec X)
{
  PetscScalar *x;
  PetscInt     n;

  PetscFunctionBeginUser;
  PetscCall(VecCopy(X0, X));
  PetscCall(VecGetLocalSize(X, &n));
  PetscCall(VecGetArray(X, &x));
  for (PetscInt k = 0; k < n; k += 3)
    if (PetscRealPart(x[k + 2]) > 0.25)
      for (int c = 0; c < 3; c++) x[k + c] += p[c] - p0[c];
  PetscCall(VecRestoreArray(X, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* D = the unit vector along z at the vertex at p (the apex, moved there up to roundoff) */
static PetscErrorCode ApexZ(Vec X, const PetscReal p[3], Vec D)
{
  const PetscScalar *x;
  PetscScalar       *d;
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecZeroEntries(D));
  PetscCall(VecGetLocalSize(X, &n));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArray(D, &d));
  for (PetscInt k = 0; k < n; k += 3)
    if (PetscAbsReal(PetscRealPart(x[k]) - p[0]) + PetscAbsReal(PetscRealPart(x[k + 1]) - p[1]) + PetscAbsReal(PetscRealPart(x[k + 2]) - p[2]) < 1e-9) d[k + 2] = 1;
  PetscCall(VecRestoreArray(D, &d));
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the gradient's entries at the vertex at p (summed over ranks), and its sum over all vertices */
static PetscErrorCode At(Vec X, Vec G, const PetscReal p[3], PetscReal gp[3], PetscReal gsum[3])
{
  const PetscScalar *x, *g;
  PetscInt           n;

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(X, &n));
  PetscCall(VecGetArrayRead(X, &x));
  PetscCall(VecGetArrayRead(G, &g));
  for (int c = 0; c < 3; c++) gp[c] = gsum[c] = 0;
  for (PetscInt k = 0; k < n; k += 3) {
    const bool here = PetscAbsReal(PetscRealPart(x[k]) - p[0]) + PetscAbsReal(PetscRealPart(x[k + 1]) - p[1]) + PetscAbsReal(PetscRealPart(x[k + 2]) - p[2]) < 1e-9; /* the apex, moved there up to roundoff */
    for (int c = 0; c < 3; c++) {
      gsum[c] += PetscRealPart(g[k + c]);
      if (here) gp[c] += PetscRealPart(g[k + c]);
    }
  }
  PetscCall(VecRestoreArrayRead(X, &x));
  PetscCall(VecRestoreArrayRead(G, &g));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, gp, 3, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, gsum, 3, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* once: -msim_self_contact_once; without it the pairs' sum: derived multiplicities 1, 5, 19 */
static PetscErrorCode Run(PetscBool once)
{
  char            path[PETSC_MAX_PATH_LEN];
  int             pid = (int)getpid();
  const PetscReal dhat = 0.1, p0[3] = {1.3, 1.6, 0.5};
  PetscMPIInt     rank;
  TestSim         s;
  MSimImplicit    imp;
  MSimImplicitTerm t;
  Vec             X, G, Xp, D;
  Mat             J;
  PetscReal       C;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  /* rank 0's process id in the name: the tests at 1 and 2 ranks may run at once (ctest -j) */
  PetscCallMPI(MPI_Bcast(&pid, 1, MPI_INT, 0, PETSC_COMM_WORLD));
  PetscCall(PetscSNPrintf(path, sizeof path, "/tmp/msim_test_self_features_%d.off", pid));
  if (!rank) {
    FILE *f = fopen(path, "w");
    PetscCheck(f, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "cannot write %s", path);
    fprintf(f, "OFF\n%d %d 0\n", 25 + 4, 32 + 4);
    for (int j = 0; j < 5; j++)
      for (int i = 0; i < 5; i++) fprintf(f, "%d %d 0\n", i, j);
    fprintf(f, "%g %g %g\n%g %g %g\n%g %g %g\n%g %g %g\n", p0[0], p0[1], p0[2], p0[0] + 0.15, p0[1], p0[2] + 0.6, p0[0] - 0.075, p0[1] + 0.13, p0[2] + 0.6, p0[0] - 0.075, p0[1] - 0.13, p0[2] + 0.6);
    for (int j = 0; j < 4; j++)
      for (int i = 0; i < 4; i++) {
        const int a = 5 * j + i, b = a + 1, c = a + 6, d = a + 5;
        if ((i + j) % 2) fprintf(f, "3 %d %d %d\n3 %d %d %d\n", a, b, c, a, c, d);
        else fprintf(f, "3 %d %d %d\n3 %d %d %d\n", a, b, d, b, c, d);
      }
    fprintf(f, "3 25 26 27\n3 25 27 28\n3 25 28 26\n3 26 28 27\n");
    fclose(f);
  }
  PetscCallMPI(MPI_Barrier(PETSC_COMM_WORLD));
  {
    std::string opts = std::string("-msim_scene mesh -msim_mesh_file ") + path + " -msim_fix none -msim_self_contact -msim_self_contact_distance 0.1 -msim_integrator implicit_euler" + (once ? " -msim_self_contact_once" : "");
    PetscCall(TestSimCreate(opts.c_str(), &s));
  }
  PetscCall(MSimImplicitCreate(s.sys, &imp));
  PetscCall(FindTerm(imp, "self_contact", &t));
  CHECK(t && t->ops.energy, "no self_contact term");
  if (!(t && t->ops.energy)) {
    PetscCall(MSimDestroy(&imp, &s));
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  PetscCall(MSimImplicitBeginStep(imp, 0.0, s.dt, s.X, s.V));
  {
    /* the term's weight, as the term sets it (stiffness 1) */
    const PetscReal s0 = 0.25 * dhat * dhat, mbar = s.sys->total_mass / s.sys->nv;
    PetscReal       b, db, d2b;
    MSimBarrier(s0, dhat * dhat, &b, &db, &d2b);
    C = mbar / (4 * s0 * d2b + 2 * db);
  }
  PetscCall(VecDuplicate(s.X, &X));
  PetscCall(VecDuplicate(s.X, &G));
  PetscCall(VecDuplicate(s.X, &Xp));
  PetscCall(VecDuplicate(s.X, &D));
  PetscCall(MSimSystemCreateMatrix(s.sys, &J));
  /* (a) the centroid of triangle (1,1)-(2,1)-(1,2) (its cell, i + j even, is split along (2,1)-(1,2)),
     0.29 m from its edges; (b) the middle of the interior edge (2,2)-(3,2), 0.35 m from the
     nearest other edge; (c) vertex (2,2), which no diagonal meets */
  const PetscReal    xy[3][2] = {{1 + 1.0 / 3, 1 + 1.0 / 3}, {2.5, 2}, {2, 2}};
  const char        *what[3]  = {"a triangle's inside", "an edge's middle", "a vertex"};
  const PetscReal    hs[3]    = {0.02, 0.05, 0.08};
  for (PetscReal h : hs) {
    PetscReal b, db, d2b, e[3], gp[3][3], gs[3];
    MSimBarrier(h * h, dhat * dhat, &b, &db, &d2b);
    for (int k = 0; k < 3; k++) {
      /* without the weights: 1 pair above the face, 2 point-triangle + 3 edge-edge above the edge,
         4 + 3 point-triangle (the vertex against p's faces) + 3 x 4 edge-edge above the vertex */
      const PetscReal m = once ? 1 : (k == 0 ? 1 : (k == 1 ? 5 : 19)), eref = m * C * b, gref = m * 2 * C * db * h;
      const PetscReal p[3] = {xy[k][0], xy[k][1], h};
      PetscCall(Place(s.X, p0, p, X));
      e[k] = 0;
      PetscCall(t->ops.energy(t, X, &e[k]));
      PetscCall(VecZeroEntries(G));
      PetscCall(t->ops.gradient(t, X, G));
      PetscCall(At(X, G, p, gp[k], gs));
      NOTE("%s: h %.2f m above %s: energy %.12e (m C b(h^2) %.12e), gradient on p (%.3e, %.3e, %.12e) (m 2 C b' h %.12e), sum (%.1e, %.1e, %.1e)\n", once ? "once" : "pairs", (double)h, what[k], (double)e[k], (double)eref, (double)gp[k][0], (double)gp[k][1], (double)gp[k][2], (double)gref, (double)gs[0], (double)gs[1], (double)gs[2]);
      CHECK(PetscAbsReal(e[k] - eref) <= 1e-10 * PetscAbsReal(eref), "h %g above %s: energy %.12e, one barrier's %.12e", (double)h, what[k], (double)e[k], (double)eref);
      CHECK(PetscAbsReal(gp[k][2] - gref) <= 1e-10 * PetscAbsReal(gref) && PetscAbsReal(gp[k][0]) + PetscAbsReal(gp[k][1]) <= 1e-10 * PetscAbsReal(gref), "h %g above %s: force on p %.12e along z (and %.2e across), one barrier's %.12e", (double)h, what[k], (double)gp[k][2], (double)(PetscAbsReal(gp[k][0]) + PetscAbsReal(gp[k][1])), (double)gref);
      CHECK(PetscAbsReal(gs[0]) + PetscAbsReal(gs[1]) + PetscAbsReal(gs[2]) <= 1e-10 * PetscAbsReal(gref), "h %g above %s: the forces do not sum to 0 (%g %g %g)", (double)h, what[k], (double)gs[0], (double)gs[1], (double)gs[2]);
      {
        /* the PSD Hessian along the apex's vertical motion against the energy's second derivative */
        const PetscReal href = m * C * (4 * h * h * d2b + 2 * db), eps = 1e-4 * h;
        PetscReal       dHd, ep = 0, em = 0;
        PetscCall(ApexZ(X, p, D));
        PetscCall(MatZeroEntries(J));
        PetscCall(t->ops.hessian(t, X, PETSC_TRUE, J));
        PetscCall(MatMult(J, D, G));
        PetscCall(VecDot(D, G, &dHd));
        PetscCall(VecWAXPY(Xp, eps, D, X));
        PetscCall(t->ops.energy(t, Xp, &ep));
        PetscCall(VecWAXPY(Xp, -eps, D, X));
        PetscCall(t->ops.energy(t, Xp, &em));
        const PetscReal fd2 = (ep - 2 * e[k] + em) / (eps * eps);
        NOTE("%s: h %.2f m above %s: PSD Hessian along the apex's z %.10e, m C (4 h^2 b'' + 2 b') %.10e, second difference of the energy %.10e\n", once ? "once" : "pairs", (double)h, what[k], (double)dHd, (double)href, (double)fd2);
        CHECK(PetscAbsReal(dHd - href) <= 1e-10 * PetscAbsReal(href), "h %g above %s: PSD Hessian along the apex's z %.10e, the energy's second derivative %.10e (%.3g x)", (double)h, what[k], (double)dHd, (double)href, (double)(dHd / href));
        CHECK(PetscAbsReal(fd2 - href) <= 3e-5 * PetscAbsReal(href), "h %g above %s: second difference of the energy %.10e against the derived %.10e", (double)h, what[k], (double)fd2, (double)href);
      }
    }
  }
  /* off the features (pairs at different distances, duplicates' weights acting): the gradient
     against central differences of the energy along random directions, and the Hessian PSD */
  {
    const PetscReal off[4][3] = {{2.5 + 0.013, 2 + 0.021, 0.04}, {2 + 0.017, 2 - 0.011, 0.05}, {2 - 0.006, 2 + 0.03, 0.03}, {2.5 - 0.02, 2 - 0.015, 0.06}};
    PetscRandom     r;
    PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &r));
    PetscCall(PetscRandomSetInterval(r, -1, 1));
    for (int k = 0; k < 4; k++) {
      PetscReal ep, em, gd, dn, fd = 1e-6, dHd, worst = PETSC_MAX_REAL;
      PetscCall(Place(s.X, p0, off[k], X));
      PetscCall(VecSetRandom(D, r));
      PetscCall(VecNorm(D, NORM_INFINITY, &dn));
      PetscCall(VecScale(D, 1.0 / dn));
      PetscCall(VecZeroEntries(G));
      PetscCall(t->ops.gradient(t, X, G));
      PetscCall(VecDot(G, D, &gd));
      PetscCall(VecWAXPY(Xp, fd, D, X));
      ep = 0;
      PetscCall(t->ops.energy(t, Xp, &ep));
      PetscCall(VecWAXPY(Xp, -fd, D, X));
      em = 0;
      PetscCall(t->ops.energy(t, Xp, &em));
      const PetscReal cd = (ep - em) / (2 * fd);
      NOTE("off the features (%.3f, %.3f, %.3f): g . d %.10e, central difference %.10e\n", (double)off[k][0], (double)off[k][1], (double)off[k][2], (double)gd, (double)cd);
      CHECK(PetscAbsReal(gd - cd) <= 1e-6 * PetscAbsReal(gd) + 1e-12, "gradient vs central differences at (%g, %g, %g): %.10e vs %.10e", (double)off[k][0], (double)off[k][1], (double)off[k][2], (double)gd, (double)cd);
      PetscCall(MatZeroEntries(J));
      PetscCall(t->ops.hessian(t, X, PETSC_TRUE, J));
      for (int q = 0; q < 10; q++) {
        PetscCall(VecSetRandom(D, r));
        PetscCall(MatMult(J, D, G));
        PetscCall(VecDot(D, G, &dHd));
        worst = PetscMin(worst, dHd);
      }
      CHECK(worst >= 0, "Hessian not PSD at (%g, %g, %g): d^T H d = %g", (double)off[k][0], (double)off[k][1], (double)off[k][2], (double)worst);
    }
    PetscCall(PetscRandomDestroy(&r));
  }
  PetscCall(MatDestroy(&J));
  PetscCall(MSimDestroy(&D, &Xp, &G, &X, &imp, &s));
  if (!rank) remove(path);
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode Body(void)
{
  PetscFunctionBeginUser;
  PetscCall(Run(PETSC_TRUE));
  PetscCall(Run(PETSC_FALSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

MSIM_TEST_MAIN(Body)
