/* msim's log class, events and stages: registered once, so -log_view reports msim's work beside
   PETSc's. */
#include <msim/log.h>
#include <vector>

PetscClassId  MSIM_CLASSID;
PetscLogEvent MSIM_Force, MSIM_Energy, MSIM_Step, MSIM_Output, MSIM_Jacobian, MSIM_Residual, MSIM_PDLocal, MSIM_PDGlobal, MSIM_PDSetUp, MSIM_Spectrum, MSIM_Setup, MSIM_LLTFactor, MSIM_LLTSweep;
PetscLogEvent MSIM_MeshRead, MSIM_MeshCheck, MSIM_MeshEdges, MSIM_TetGen, MSIM_Volume;
PetscLogStage MSIM_StageRead, MSIM_StagePartition, MSIM_StageDistribute, MSIM_StageRefine, MSIM_StageSetup, MSIM_StageStep;

PetscErrorCode MSimLogRegister(void)
{
  PetscFunctionBeginUser;
  /* the default log keeps event counts; msim reads them (MSimFactorizationCount), -log_view prints them */
  PetscCall(PetscLogDefaultBegin());
  PetscCall(PetscClassIdRegister("msim", &MSIM_CLASSID));
  PetscCall(PetscLogEventRegister("MSimSetup", MSIM_CLASSID, &MSIM_Setup));
  PetscCall(PetscLogEventRegister("MSimForce", MSIM_CLASSID, &MSIM_Force));
  PetscCall(PetscLogEventRegister("MSimEnergy", MSIM_CLASSID, &MSIM_Energy));
  PetscCall(PetscLogEventRegister("MSimStep", MSIM_CLASSID, &MSIM_Step));
  PetscCall(PetscLogEventRegister("MSimOutput", MSIM_CLASSID, &MSIM_Output));
  PetscCall(PetscLogEventRegister("MSimResidual", MSIM_CLASSID, &MSIM_Residual));
  PetscCall(PetscLogEventRegister("MSimJacobian", MSIM_CLASSID, &MSIM_Jacobian));
  PetscCall(PetscLogEventRegister("MSimPDSetUp", MSIM_CLASSID, &MSIM_PDSetUp));
  PetscCall(PetscLogEventRegister("MSimPDLocal", MSIM_CLASSID, &MSIM_PDLocal));
  PetscCall(PetscLogEventRegister("MSimPDGlobal", MSIM_CLASSID, &MSIM_PDGlobal));
  PetscCall(PetscLogEventRegister("MSimSpectrum", MSIM_CLASSID, &MSIM_Spectrum));
  PetscCall(PetscLogEventRegister("MSimLLTFactor", MSIM_CLASSID, &MSIM_LLTFactor));
  PetscCall(PetscLogEventRegister("MSimLLTSweep", MSIM_CLASSID, &MSIM_LLTSweep));
  PetscCall(PetscLogEventRegister("MSimMeshRead", MSIM_CLASSID, &MSIM_MeshRead));
  PetscCall(PetscLogEventRegister("MSimMeshCheck", MSIM_CLASSID, &MSIM_MeshCheck));
  PetscCall(PetscLogEventRegister("MSimMeshEdges", MSIM_CLASSID, &MSIM_MeshEdges));
  PetscCall(PetscLogEventRegister("MSimTetGen", MSIM_CLASSID, &MSIM_TetGen));
  PetscCall(PetscLogEventRegister("MSimVolume", MSIM_CLASSID, &MSIM_Volume));
  /* -log_view's stages: where setup goes at scale, apart from stepping */
  PetscCall(PetscLogStageRegister("Read", &MSIM_StageRead));
  PetscCall(PetscLogStageRegister("Partition", &MSIM_StagePartition));
  PetscCall(PetscLogStageRegister("Distribution", &MSIM_StageDistribute));
  PetscCall(PetscLogStageRegister("Refinement", &MSIM_StageRefine));
  PetscCall(PetscLogStageRegister("Setup", &MSIM_StageSetup));
  PetscCall(PetscLogStageRegister("Stepping", &MSIM_StageStep));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimLogHideUnusedStages(MPI_Comm comm)
{
  PetscStageLog          log;
  std::vector<PetscInt> used;

  PetscFunctionBeginUser;
  PetscCall(PetscLogGetStageLog(&log));
  for (int s = 0; s < log->numStages; s++) used.push_back(log->stageInfo[s].used);
  /* every rank hides the same stages: -log_view reduces over the ranks per visible stage */
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, used.data(), (PetscMPIInt)used.size(), MPIU_INT, MPI_MAX, comm));
  for (int s = 0; s < log->numStages; s++)
    if (!used[s]) PetscCall(PetscLogStageSetVisible(s, PETSC_FALSE));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimFactorizationCount(PetscInt *count)
{
  static PetscLogEvent ev = -1; /* looked up once: the lookup compares names with every registered event's, 0.5 M instructions a PD step of the 101 x 101 cloth (0.6%) */
  PetscEventPerfInfo   info;

  PetscFunctionBeginUser;
  *count = 0;
  /* a factor PC (PETSc's Cholesky/LU or msimllt) factors exactly when it sets up: PCSetUp returns
     before logging when the operator is unchanged. Counts are kept per stage: sum the main stage and
     msim's own (PD refactors in Stepping; reading stage 0 alone reported 0 factorizations) */
  if (ev < 0) PetscCall(PetscLogEventGetId("PCSetUp", &ev));
  for (PetscLogStage stage : {(PetscLogStage)0, MSIM_StageRead, MSIM_StagePartition, MSIM_StageDistribute, MSIM_StageRefine, MSIM_StageSetup, MSIM_StageStep}) {
    PetscCall(PetscLogEventGetPerfInfo(stage, ev, &info));
    *count += info.count;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
