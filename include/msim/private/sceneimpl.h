/* The scene's body, for the scene layer and the system that takes the scene's springs (PETSc's
   include/petsc/private pattern); msim/scene.h holds the handle, the generators' MSimSceneData
   (a plain struct they fill) and the functions. */
#pragma once
#include <msim/scene.h>

struct _n_MSimScene {
  MSimSceneData data;
  PetscReal     fix_velocity[3]; /* fixed vertices translate with this velocity */
  PetscReal     prestretch;      /* initial positions = prestretch * rest positions */
  PetscReal     perturb;         /* plus a deterministic pseudo-random displacement of this size */
  PetscBool     view;            /* -msim_scene_view: what the system builds from the scene (its
                                    obstacles) is printed too */
  PetscBool     drawn;           /* output draws the cells (a series, mode shapes): the system
                                    keeps them past setup */
};
