/* The mesh readers as a registry, PETSc style: a PetscFunctionList by name (so -msim_mesh_format
   and -help list them) and the extensions each reads, so a new format is one registration line. */
#include <msim/mesh.h>
#include <msim/log.h>
#include <cctype>
#include <cstring>
#include <unistd.h>
#include <utility>

static PetscFunctionList                                MSimMeshReaders = NULL;
static std::vector<std::pair<std::string, std::string>> MSimMeshExtensions; /* extension, reader */

PetscErrorCode MSimMeshReaderRegister(const char name[], const char extensions[], MSimMeshReader read)
{
  std::string list(extensions);

  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListAdd(&MSimMeshReaders, name, read));
  for (size_t at = 0; at <= list.size();) {
    size_t comma = list.find(',', at);
    if (comma == std::string::npos) comma = list.size();
    if (comma > at) MSimMeshExtensions.emplace_back(list.substr(at, comma - at), name);
    at = comma + 1;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode MSimMeshReaderRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (MSimMeshReaders) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscRegisterFinalize(MSimMeshReaderFinalize)); /* the list is freed with PETSc */
  PetscCall(MSimMeshReaderRegister("off", "off", MSimMeshReadOFF));
  PetscCall(MSimMeshReaderRegister("obj", "obj", MSimMeshReadOBJ));
  PetscCall(MSimMeshReaderRegister("stl", "stl", MSimMeshReadSTL));
  PetscCall(MSimMeshReaderRegister("tetgen", "node,ele", MSimMeshReadTetGen));
  PetscCall(MSimMeshReaderRegister("gmsh", "msh", MSimMeshReadGmsh));
  PetscCall(MSimMeshReaderRegister("medit", "mesh", MSimMeshReadMedit));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshReaderList(PetscFunctionList *list)
{
  PetscFunctionBeginUser;
  PetscCall(MSimMeshReaderRegisterAll());
  *list = MSimMeshReaders;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshReaderFinalize(void)
{
  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListDestroy(&MSimMeshReaders));
  MSimMeshExtensions.clear();
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* "msim reads .off .obj ..." for the message about an unknown format */
static std::string KnownFormats(void)
{
  std::string s;
  for (const auto &e : MSimMeshExtensions) s += (s.empty() ? "." : ", .") + e.first + " (" + e.second + ")";
  return s;
}

PetscErrorCode MSimMeshReadFileAs(const char file[], const char format[], int want, MSimMesh *m)
{
  std::string    f(file), ext, name;
  size_t         dot = f.find_last_of('.'), slash = f.find_last_of('/');
  MSimMeshReader read = NULL;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_MeshRead, 0, 0, 0, 0));
  PetscCall(MSimMeshReaderRegisterAll());
  if (format && format[0] && strcmp(format, "auto")) {
    name = format;
    PetscCall(PetscFunctionListFind(MSimMeshReaders, format, &read));
    PetscCheck(read, PETSC_COMM_SELF, PETSC_ERR_ARG_UNKNOWN_TYPE, "-msim_mesh_format %s: not a format msim reads (%s)", format, KnownFormats().c_str());
  } else {
    if (dot != std::string::npos && (slash == std::string::npos || dot > slash))
      for (char c : f.substr(dot + 1)) ext += (char)tolower((unsigned char)c);
    for (const auto &e : MSimMeshExtensions)
      if (e.first == ext) name = e.second;
    /* TetGen's files named by their stem */
    if (name.empty() && access((f + ".node").c_str(), F_OK) == 0) name = "tetgen";
    PetscCheck(!name.empty(), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s: unknown mesh format '%s' (msim reads %s; -msim_mesh_format names one for another extension)", file, ext.c_str(), KnownFormats().c_str());
    PetscCall(PetscFunctionListFind(MSimMeshReaders, name.c_str(), &read));
  }
  PetscCall((*read)(file, m));
  PetscCheck(!(want == 3 && m->nper == 4), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "%s holds tets; -msim_scene mesh needs a surface (use -msim_scene tet for a solid)", file);
  PetscCall(MSimMeshDropUnused(m));
  PetscCall(PetscLogEventEnd(MSIM_MeshRead, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMeshReadFile(const char file[], int want, MSimMesh *m)
{
  PetscFunctionBeginUser;
  PetscCall(MSimMeshReadFileAs(file, NULL, want, m));
  PetscFunctionReturn(PETSC_SUCCESS);
}
