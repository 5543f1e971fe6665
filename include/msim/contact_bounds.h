/* Obstacles as variable bounds for PETSc's VI solvers (-msim_contact_bounds, or -snes_type
   vinewtonrsls / vinewtonssls with obstacles): an axis-aligned plane n = +-e_k is the bound
   x_k >= d (or <= -d) on every free vertex; a solid box, the half-space of the face each vertex was
   nearest at the step's start (x_n; one face per vertex, so the vertex stays out of the box; one
   that the solve leaves held past that face's edge, where the box is not, takes the face it is
   beyond and the solve goes on: src/contact/contact_bounds.cpp). Those obstacles leave the barrier's list (and
   friction's), and each step solves min Phi subject to the bounds: no vertex is ever past a bound,
   with zero gap at contact (the barrier keeps a gap below dhat). The contact force is the bound's
   reaction, the residual g_i at an active bound divided by beta h^2 (a force in N), which
   msim/contact_force.h adds to the frames and the monitor. */
#pragma once
#include <msim/system.h>

typedef struct _n_MSimContactBounds *MSimContactBounds;

/* Reads -msim_contact_bounds; with it, or with a VI -snes_type, takes every obstacle out of the
   barrier's list as bounds (an obstacle that is not an axis-aligned plane or box, or one that
   moves, is refused in one line, as is -msim_friction without self-contact, the one friction left
   to it), sets -snes_type vinewtonrsls where the SNES is not a VI
   already, and PETSc's l2 line search (which projects onto the bounds) unless
   -snes_linesearch_type is given (vinewtonssls: not msim's shell search, refused in one line;
   its KSP and objective: src/integrators/impls/implicit.cpp). *b = NULL when bounds are not used.
   Collective. */
PetscErrorCode MSimContactBoundsCreate(MSimSystem sys, SNES snes, MSimContactBounds *b);
/* The step's bounds from the state Xn at its start (boxes: the face each vertex is nearest) */
PetscErrorCode MSimContactBoundsBeginStep(MSimContactBounds b, Vec Xn);
/* After the solve: X onto the bounds, *moved where it was past one anywhere (collective).
   vinewtonrsls keeps every iterate inside them; vinewtonssls reaches them only to its tolerance
   (a vertex 5.9e-11 m inside the table at |phi| <= 1.4e-10), and no vertex may ever be past a
   bound: the projection moves a vertex by that much, and the caller evaluates g again. */
PetscErrorCode MSimContactBoundsProject(MSimContactBounds b, Vec X, PetscBool *moved);
/* After the solve: the reactions from the residual F at X (F / h2 at the active bounds), and
   *residual, |F| over the components with no active bound (the VI's own residual) */
PetscErrorCode MSimContactBoundsEndStep(MSimContactBounds b, Vec X, Vec F, PetscReal h2, PetscReal *residual);
PetscErrorCode MSimContactBoundsDestroy(MSimContactBounds *b);
/* The reactions of the last step on the system's free vertices (NULL when bounds are not used):
   what msim/contact_force.h adds */
PetscErrorCode MSimContactBoundsGetReaction(MSimSystem sys, Vec *R);
