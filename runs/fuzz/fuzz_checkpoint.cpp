/* A libFuzzer harness for the checkpoint reader: the input is a checkpoint file, read by
   -msim_restart's code (MSimCheckpointRestart) into a small chain scene (the one its seeds were
   written for: seeds.py runs msim to make them). A damaged file, another scene's or another
   version's checkpoint must be refused with an error code, never crash, overflow or read beyond
   the file. */
#include <msim/output.h>
#include <msim/scene.h>
#include <msim/system.h>
#include <msim/init.h>
#include "fuzz_common.h"
#include <cstdio>
#include <string>
#include <unistd.h>

/* the scene of the seeds (seeds.py CHECKPOINT_SCENE) */
static const char scene_options[] = "-msim_scene chain -msim_chain_n 8 -msim_fix edge";
static std::string dir;
static MSimSystem  sys;
static Vec         X, V;

extern "C" int LLVMFuzzerInitialize(int *, char ***)
{
  MSimScene    scene;
  if (MSimFuzzInitializePETSc() || MSimInitialize()) return 1;
  char tmpl[] = "/tmp/msim_fuzz_checkpoint_XXXXXX";
  dir         = mkdtemp(tmpl);
  if (PetscOptionsInsertString(NULL, scene_options) || PetscOptionsSetValue(NULL, "-msim_restart", (dir + "/input.ck").c_str())) return 1;
  if (MSimSceneCreateFromOptions(PETSC_COMM_SELF, &scene) || MSimSystemCreate(PETSC_COMM_SELF, scene, &sys) || MSimSceneDestroy(&scene)) return 1;
  Vec X0, V0;
  if (MSimSystemGetInitialState(sys, &X0, &V0) || VecDuplicate(X0, &X) || VecDuplicate(V0, &V)) return 1;
  PetscPushErrorHandler(MSimFuzzQuiet, NULL);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  MSimCheckpoint ck;
  PetscInt       step;
  PetscReal      t, dt, E0;
  PetscBool      restarted;
  FILE          *f = fopen((dir + "/input.ck").c_str(), "wb");
  if (!f) abort();
  if (size && fwrite(data, 1, size, f) != size) abort();
  fclose(f);
  if (MSimCheckpointCreate(sys, &ck)) abort();
  const PetscErrorCode ierr = MSimCheckpointRestart(ck, 1000, X, V, &step, &t, &dt, &E0, &restarted);
  if (getenv("MSIM_FUZZ_VERBOSE")) printf("%s\n", ierr ? "refused" : "restarted"); /* what the seeds reach */
  (void)MSimCheckpointDestroy(&ck);
  return 0;
}
