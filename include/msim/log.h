/* msim's log class, events and stages (log.cpp), registered once by MSimLogRegister (from
   MSimInitialize); -log_view reports them and is msim's one timing source. */
#pragma once
#include <msim/petsc_compat.h>

extern PetscClassId  MSIM_CLASSID;
extern PetscLogEvent MSIM_Force, MSIM_Energy, MSIM_Step, MSIM_Output, MSIM_Jacobian, MSIM_Residual,
  MSIM_PDLocal, MSIM_PDGlobal, MSIM_PDSetUp, MSIM_Spectrum, MSIM_Setup, MSIM_LLTFactor, MSIM_LLTSweep;
/* rank 0's mesh work: parsing a file, validating it, finding its unique edges, TetGen */
extern PetscLogEvent MSIM_MeshRead, MSIM_MeshCheck, MSIM_MeshEdges, MSIM_TetGen;
/* the tets' volume term (msim/volume.h): its force, energy, Hessian and feasible step */
extern PetscLogEvent MSIM_Volume;
/* -log_view stages: reading a file (rank 0), partitioning, moving the scene between ranks,
   refining, building the system and the solvers, time stepping */
extern PetscLogStage MSIM_StageRead, MSIM_StagePartition, MSIM_StageDistribute, MSIM_StageRefine, MSIM_StageSetup, MSIM_StageStep;

/* Starts PETSc's default log (msim reads its counts) and registers the class, events and stages. */
PetscErrorCode MSimLogRegister(void);

/* Hides from -log_view the stages no rank pushed (collective): PETSc prints each registered
   stage's event table, one never pushed as "Unknown" (msim's Refinement without -msim_refine,
   another library's). Called once the stages are done with. */
PetscErrorCode MSimLogHideUnusedStages(MPI_Comm comm);

/* Preconditioner set-ups so far in this process (PETSc's log counter of PCSetUp, which logs only
   when it does work): bracketing a factor PC's solves with it counts its factorizations. */
PetscErrorCode MSimFactorizationCount(PetscInt *count);
