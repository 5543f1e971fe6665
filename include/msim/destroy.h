/* MSimDestroy(&a, &b, ...): each object destroyed in order by its type's own Destroy (VecDestroy,
   MatDestroy, ...; a NULL handle is skipped, every handle is left NULL), so that a Destroy function
   or a test's clean-up that frees a list of work objects says so in one line. Other types join by
   an MSimDestroyOne overload declared before the call (found by argument-dependent lookup). */
#pragma once
#include <petscts.h>

/* MSimDestroyOne(T *) for each PETSc type T below, by T's own TDestroy (VecScatter is PetscSF) */
#define MSIM_DESTROY_ONE(T) \
  static inline PetscErrorCode MSimDestroyOne(T *object) \
  { \
    return T##Destroy(object); \
  }
MSIM_DESTROY_ONE(Vec) MSIM_DESTROY_ONE(Mat) MSIM_DESTROY_ONE(IS) MSIM_DESTROY_ONE(PetscSF) MSIM_DESTROY_ONE(KSP) MSIM_DESTROY_ONE(SNES) MSIM_DESTROY_ONE(TS)
#undef MSIM_DESTROY_ONE

static inline PetscErrorCode MSimDestroy(void)
{
  return PETSC_SUCCESS;
}

template <typename T, typename... Rest>
static inline PetscErrorCode MSimDestroy(T *first, Rest *...rest)
{
  PetscFunctionBeginUser;
  PetscCall(MSimDestroyOne(first));
  PetscCall(MSimDestroy(rest...));
  PetscFunctionReturn(PETSC_SUCCESS);
}
