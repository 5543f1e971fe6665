/* A mesh file by its extension. */
#include <msim/mesh.h>
#include <cctype>
#include <cstring>
#include <unistd.h>

PetscErrorCode MSimMeshReadFile(const char file[], int want, MSimMesh *m)
{
  std::string f(file), ext;
  size_t      dot = f.find_last_of('.'), slash = f.find_last_of('/');

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_MeshRead, 0, 0, 0, 0));
  if (dot != std::string::npos && (slash == std::string::npos || dot > slash))
    for (char c : f.substr(dot + 1)) ext += (char)tolower((unsigned char)c);
  if (ext == "off") PetscCall(MSimMeshReadOFF(file, m));
  else if (ext == "obj") PetscCall(MSimMeshReadOBJ(file, m));
  else if (ext == "stl") PetscCall(MSimMeshReadSTL(file, m));
  else if (ext == "msh") PetscCall(MSimMeshReadGmsh(file, m));
  else if (ext == "node" || ext == "ele" || access((f + ".node").c_str(), F_OK) == 0) {
    PetscCheck(want == 4, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s: TetGen .node/.ele files hold tets; -msim_scene mesh needs a surface (.off, .obj, .stl, or a .msh of triangles)", file);
    PetscCall(MSimMeshReadTetGen(file, m));
  } else SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s: unknown mesh format '%s' (msim reads surfaces .off .obj .stl, TetGen .node/.ele and Gmsh .msh)", file, ext.c_str());
  PetscCheck(!(want == 3 && m->nper == 4), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s holds tets; -msim_scene mesh needs a surface (use -msim_scene tet for a solid)", file);
  PetscCall(PetscLogEventEnd(MSIM_MeshRead, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
