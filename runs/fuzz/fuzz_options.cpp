/* A libFuzzer harness for the options-to-scene path: the input is an options file. PETSc's parser
   reads it (PetscOptionsInsertFile, what -options_file does), then msim builds what a run builds
   before its first step: the scene (generated, or read from a mesh file and meshed by TetGen), the
   distributed system and the integrator with its solvers, set up. An input may be refused (an
   error code: the one-line message users see); it must never crash, overflow or read out of bounds.
   Big scenes are cut down (CutDown). It runs in a scratch directory, so relative paths an input
   names stay there. */
#include <msim/integrator.h>
#include <msim/scene.h>
#include <msim/system.h>
#include <msim/init.h>
#include "fuzz_common.h"
#include <cstdio>
#include <cstring>
#include <dirent.h>
#include <set>
#include <string>
#include <unistd.h>

static std::string dir;

extern "C" int LLVMFuzzerInitialize(int *, char ***)
{
  if (MSimFuzzInitializePETSc() || MSimInitialize()) return 1;
  PetscPushErrorHandler(MSimFuzzQuiet, NULL);
  char tmpl[] = "/tmp/msim_fuzz_options_XXXXXX";
  dir         = mkdtemp(tmpl);
  if (chdir(dir.c_str())) return 1;
  return 0;
}

/* the product of an integer list option's values (1 when absent or not integers: msim says so) */
static double Product(const char name[], int dims)
{
  PetscInt  v[3] = {1, 1, 1}, n = 3;
  PetscBool set;
  if (PetscOptionsGetIntArray(NULL, NULL, name, v, &n, &set) || !set) return 1;
  double p = 1;
  for (PetscInt i = 0; i < n; i++) p *= (double)(v[i] < 1 ? 1 : v[i]);
  for (PetscInt i = n; i < dims; i++) p *= (double)(v[0] < 1 ? 1 : v[0]); /* one value for every axis */
  return p;
}

/* Scenes beyond what a fuzzer can build thousands of times a minute (a few thousand vertices), and
   TetGen bounds that make meshes of any size, are cut down to small ones, so the rest of the input
   is still exercised: a large scene is not a fault. */
static void CutDown(void)
{
  PetscInt  refine = 0;
  PetscBool set;
  char      sw[256] = "";
  if (Product("-msim_cloth_n", 2) > 4096) PetscOptionsSetValue(NULL, "-msim_cloth_n", "16");
  if (Product("-msim_chain_n", 1) > 4096) PetscOptionsSetValue(NULL, "-msim_chain_n", "64");
  if (Product("-msim_box_n", 3) > 512) PetscOptionsSetValue(NULL, "-msim_box_n", "4,4,4");
  if (!PetscOptionsGetInt(NULL, NULL, "-msim_refine", &refine, &set) && set && refine > 1) PetscOptionsSetValue(NULL, "-msim_refine", "1");
  if (!PetscOptionsGetString(NULL, NULL, "-msim_tetgen_switches", sw, sizeof sw, &set) && set && strpbrk(sw, "aqAS")) PetscOptionsSetValue(NULL, "-msim_tetgen_switches", "pY");
}

static std::set<int> OpenDescriptors(void)
{
  std::set<int> fds;
  if (DIR *d = opendir("/proc/self/fd")) {
    const int self = dirfd(d);
    while (struct dirent *e = readdir(d))
      if (e->d_name[0] != '.' && atoi(e->d_name) != self) fds.insert(atoi(e->d_name));
    closedir(d);
  }
  return fds;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  const std::string file = dir + "/input.opts";
  MSimScene         scene = NULL;
  MSimSystem        sys   = NULL;
  MSimIntegrator    integ = NULL;
  FILE             *f     = fopen(file.c_str(), "wb");
  if (!f) abort();
  if (size && fwrite(data, 1, size, f) != size) abort();
  fclose(f);
  if (PetscOptionsClear(NULL)) abort();
  const std::set<int> open_before = OpenDescriptors();
  if (PetscOptionsInsertFile(PETSC_COMM_SELF, NULL, file.c_str(), PETSC_TRUE)) {
    /* PETSc 3.18 leaves the file open when it refuses a line (msim then exits): closed here, or
       the fuzzer runs out of descriptors after a few thousand refusals */
    for (int fd : OpenDescriptors())
      if (!open_before.count(fd)) close(fd);
    return 0;
  }
  CutDown();
  int stage = 0; /* how far the input got: MSIM_FUZZ_VERBOSE prints it, to see what the seeds reach */
  if (!MSimSceneCreateFromOptions(PETSC_COMM_SELF, &scene) && ++stage && !MSimSystemCreate(PETSC_COMM_SELF, scene, &sys) && ++stage && !MSimIntegratorCreate(sys, &integ) &&
      !MSimIntegratorSetFromOptions(integ) && ++stage && !MSimIntegratorSetUp(integ))
    ++stage;
  if (getenv("MSIM_FUZZ_VERBOSE")) printf("%s\n", (const char *[]){"scene refused", "system refused", "integrator refused", "set-up refused", "set up"}[stage]);
  /* a refusal may leave objects half made: destroying them must be safe too */
  if (integ) (void)MSimIntegratorDestroy(&integ);
  if (sys) (void)MSimSystemDestroy(&sys);
  if (scene) (void)MSimSceneDestroy(&scene);
  return 0;
}
