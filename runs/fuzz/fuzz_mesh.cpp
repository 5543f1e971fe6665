/* A libFuzzer harness for msim's mesh readers: the input is written to a file and read by one
   reader (chosen at compile time by MSIM_FUZZ_FORMAT: 0 OFF, 1 OBJ, 2 STL, 3 TetGen, 4 Gmsh
   ASCII or binary, 5 Medit), then its unused vertices dropped and the rest validated as msim
   does with every mesh (MSimMeshDropUnused, MSimMeshCheck). A reader may
   refuse an input (an error code: the one-line message users see); it must never crash, read or
   write out of bounds, overflow, or ask for memory the file cannot justify. TetGen's input is a
   .node and an .ele file: the fuzz input holds both, split at the first line "#ele".
   Built with -fsanitize=fuzzer it is a fuzzer; without, standalone_main.cpp runs it over files
   (the seed corpus, in ctest). */
#include <msim/mesh.h>
#include "fuzz_common.h"
#include <cstdio>
#include <string>
#include <unistd.h>

#ifndef MSIM_FUZZ_FORMAT
  #define MSIM_FUZZ_FORMAT 0
#endif

static std::string dir;

extern "C" int LLVMFuzzerInitialize(int *, char ***)
{
  if (MSimFuzzInitializePETSc()) return 1;
  PetscPushErrorHandler(MSimFuzzQuiet, NULL);
  char tmpl[] = "/tmp/msim_fuzz_XXXXXX";
  dir         = mkdtemp(tmpl);
  return 0;
}

static void Write(const std::string &path, const uint8_t *data, size_t size)
{
  FILE *f = fopen(path.c_str(), "wb");
  if (!f) abort();
  if (size && fwrite(data, 1, size, f) != size) abort();
  fclose(f);
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  MSimMesh          m;
  PetscErrorCode    ierr;
  const char *const ext[] = {"off", "obj", "stl", "node", "msh", "mesh"};
  const std::string file  = dir + "/input." + ext[MSIM_FUZZ_FORMAT];

#if MSIM_FUZZ_FORMAT == 3
  const std::string text((const char *)data, size);
  size_t            at = text.find("\n#ele\n");
  const size_t      cut = at == std::string::npos ? size : at + 1, rest = at == std::string::npos ? size : at + 6;
  Write(file, data, cut);
  Write(dir + "/input.ele", data + rest, size - rest);
#else
  Write(file, data, size);
#endif
#if MSIM_FUZZ_FORMAT == 0
  ierr = MSimMeshReadOFF(file.c_str(), &m);
#elif MSIM_FUZZ_FORMAT == 1
  ierr = MSimMeshReadOBJ(file.c_str(), &m);
#elif MSIM_FUZZ_FORMAT == 2
  ierr = MSimMeshReadSTL(file.c_str(), &m);
#elif MSIM_FUZZ_FORMAT == 3
  ierr = MSimMeshReadTetGen(file.c_str(), &m);
#elif MSIM_FUZZ_FORMAT == 4
  ierr = MSimMeshReadGmsh(file.c_str(), &m);
#else
  ierr = MSimMeshReadMedit(file.c_str(), &m);
#endif
  if (!ierr) ierr = MSimMeshDropUnused(&m);
  if (!ierr) (void)MSimMeshCheck(&m);
  return 0;
}
