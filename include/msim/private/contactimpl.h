/* The contact object's body, for the contact code and the terms and forces that use it (PETSc's
   include/petsc/private pattern); msim/contact.h holds the handle, the obstacles and the
   functions. */
#pragma once
#include <msim/contact.h>
#include <vector>

struct _n_MSimContact {
  MSimSystem                sys;
  std::vector<MSimObstacle> obs;
  PetscReal                 dhat;  /* the barrier acts below this distance */
  PetscReal                 mu;    /* Coulomb friction coefficient */
  PetscReal                 kappa; /* barrier stiffness per unit mass (1/s^2); 0: chosen at the first step */
  PetscReal                 kc;    /* explicit penalty stiffness, N/m per vertex */
  PetscReal                 eps_v; /* friction's static velocity threshold (m/s) */
  PetscReal                 thickness; /* mesh obstacles: the shell the cloth keeps out of */
  PetscBool                 moving;    /* some obstacle has a velocity */
  PetscBool                 pd_weight; /* PD: the barrier's stiffness in the matrix (else the rhs only) */
  PetscBool                 psd_curvature; /* PSD Hessian: keep the barrier's curvature term, clamped */
  /* this rank's totals at the last force or gradient evaluation: the monitor's columns */
  PetscReal                 force[3];
  PetscInt                  ncontact;
};
