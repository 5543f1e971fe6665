/* Gmsh .msh: the $MeshFormat line says ASCII (file type 0) or binary (1); msim reads versions 2.2
   and 4.1 of both with its own readers (read_gmsh_ascii.cpp, read_gmsh_binary.cpp), which name
   the file and the line or byte of a fault. PETSc 3.18's DMPlex reader is not used: fuzzing found
   it crashing, hanging, overflowing a buffer, asking for gigabytes and corrupting the heap on
   malformed files (runs/fuzz/README.md). */
#include <msim/mesh.h>
#include <cerrno>
#include <cstdio>
#include <cstring>

/* Whether the $MeshFormat line (after any $Comments) says binary. Reads no further than that
   line; a file without one goes to the ASCII reader, which says what is wrong with it. */
static PetscErrorCode GmshIsBinary(const char file[], bool *binary)
{
  FILE *fp = fopen(file, "rb");
  char  line[256];

  PetscFunctionBeginUser;
  PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "%s: cannot open (%s)", file, strerror(errno));
  *binary = false;
  while (fgets(line, sizeof line, fp))
    if (!strncmp(line, "$MeshFormat", 11)) {
      double v    = 0;
      int    type = -1;
      *binary     = fgets(line, sizeof line, fp) && sscanf(line, "%lf %d", &v, &type) == 2 && type == 1;
      break;
    }
  fclose(fp);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshReadGmsh(const char file[], MSimMesh *m)
{
  bool binary;

  PetscFunctionBeginUser;
  PetscCall(GmshIsBinary(file, &binary));
  if (binary) PetscCall(MSimMeshReadGmshBinary(file, m));
  else PetscCall(MSimMeshReadGmshASCII(file, m));
  PetscFunctionReturn(PETSC_SUCCESS);
}
