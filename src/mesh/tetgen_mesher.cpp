/* TetGen (libtet, AGPL-3+) turns a closed surface into tets. Built only with MSIM_WITH_TETGEN (the
   default): a binary linked with TetGen is AGPL-3+ as a whole, one without it is BSD-2-Clause, and
   then every input but a surface to tetrahedralize still works. */
#include <msim/mesh.h>
#include <msim/log.h>
#include <msim/crash_guard.h>
#include <csetjmp>
#include <csignal>
#include <cstring>
#include <new>
#ifdef MSIM_WITH_TETGEN
  #include <tetgen.h>
#endif

PetscBool MSimHaveTetGen(void)
{
#ifdef MSIM_WITH_TETGEN
  return PETSC_TRUE;
#else
  return PETSC_FALSE;
#endif
}

#ifdef MSIM_WITH_TETGEN
/* TetGen 1.5 throws an int when it gives up (terminatetetgen) */
static const char *TetGenReason(int code)
{
  switch (code) {
  case 1: return "out of memory";
  case 2: return "an internal error in TetGen";
  case 3: return "the surface intersects itself";
  case 4: return "a very small input feature (two vertices or a vertex and a facet almost touching)";
  case 5: return "two facets are very close to each other (nearly overlapping)";
  case 10: return "the input is invalid";
  default: return "an unknown error";
  }
}

/* TetGen 1.5 does not always throw: on some faulty surfaces it fails an assertion (abort) or reads
   out of bounds. A crash inside it becomes an error (MSimCallGuarded), and msim exits with one
   line (TetGen's state is abandoned, not reused). */
static int TetGenRun(const char *switches, tetgenio *in, tetgenio *out)
{
  int         code = 0;
  std::string sw(switches);

  const int sig = MSimCallGuarded([&]() {
    try {
      tetrahedralize(&sw[0], in, out);
    } catch (int c) {
      code = c;
    } catch (const std::bad_alloc &) {
      code = 1;
    }
  });
  return sig ? 100 + sig : code;
}
#endif

PetscErrorCode MSimMeshTetrahedralize(const MSimMesh *surf, const char switches[], MSimMesh *tets)
{
  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_TetGen, 0, 0, 0, 0));
#ifndef MSIM_WITH_TETGEN
  SETERRQ(PETSC_COMM_SELF, PETSC_ERR_SUP, "%s is a surface and this msim was built without TetGen (cmake -DMSIM_WITH_TETGEN=ON): give the tets as TetGen .node/.ele or Gmsh .msh", surf->file.c_str());
#else
  tetgenio    in, out;
  std::string sw(switches);
  int         code;

  PetscCheck(sw.find('r') == std::string::npos, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "-msim_tetgen_switches %s: msim gives TetGen a surface, not tets to refine (drop r)", switches);
  PetscCheck(sw.find("o2") == std::string::npos, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "-msim_tetgen_switches %s: o2 makes quadratic tets; msim's springs join the 4 corners of linear tets", switches);
  for (char c : sw) PetscCheck(c > ' ' && c < 127, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "-msim_tetgen_switches: '%s' has a space or a control character (switches are one word, e.g. pq1.414a0.1)", switches);
  sw += "z";
  if (sw.find('V') == std::string::npos) sw += "Q";
  in.firstnumber    = 0;
  in.numberofpoints = (int)surf->nv;
  in.pointlist      = new REAL[3 * (size_t)surf->nv];
  memcpy(in.pointlist, surf->x.data(), 3 * (size_t)surf->nv * sizeof(REAL));
  in.numberoffacets = (int)surf->ncell;
  in.facetlist      = new tetgenio::facet[surf->ncell];
  for (PetscInt f = 0; f < surf->ncell; f++) {
    tetgenio::facet &fa = in.facetlist[f];
    tetgenio::init(&fa);
    fa.numberofpolygons = 1;
    fa.polygonlist      = new tetgenio::polygon[1];
    tetgenio::init(&fa.polygonlist[0]);
    fa.polygonlist[0].numberofvertices = 3;
    fa.polygonlist[0].vertexlist       = new int[3];
    for (int k = 0; k < 3; k++) fa.polygonlist[0].vertexlist[k] = (int)surf->cell[3 * (size_t)f + k];
  }
  {
    /* TetGen's own check for a surface that intersects itself (switch d) first: meshing such a
       surface can crash TetGen instead of failing */
    tetgenio check;
    code = TetGenRun("pdzQ", &in, &check);
    PetscCheck(code < 100, PETSC_COMM_SELF, PETSC_ERR_LIB, "%s: TetGen crashed (signal %d) checking the surface for self-intersections", surf->file.c_str(), code - 100);
    PetscCheck(!code, PETSC_COMM_SELF, PETSC_ERR_LIB, "%s: TetGen's check of the surface failed: %s", surf->file.c_str(), TetGenReason(code));
    PetscCheck(check.numberoftrifaces == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: the surface intersects itself: TetGen finds %d intersecting triangles, e.g. the one of vertices %d %d %d (a solid needs a closed surface that does not cross itself)", surf->file.c_str(), check.numberoftrifaces, check.trifacelist[0], check.trifacelist[1], check.trifacelist[2]);
  }
  code = TetGenRun(sw.c_str(), &in, &out);
  PetscCheck(code < 100, PETSC_COMM_SELF, PETSC_ERR_LIB, "%s: TetGen crashed (signal %d) with -msim_tetgen_switches %s", surf->file.c_str(), code - 100, switches);
  PetscCheck(!code, PETSC_COMM_SELF, PETSC_ERR_LIB, "%s: TetGen failed (-msim_tetgen_switches %s): %s", surf->file.c_str(), switches, TetGenReason(code));
  PetscCheck(out.numberoftetrahedra > 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "%s: TetGen made no tets (-msim_tetgen_switches %s; p keeps the surface)", surf->file.c_str(), switches);
  PetscCheck(out.numberofcorners == 4, PETSC_COMM_SELF, PETSC_ERR_LIB, "%s: TetGen made %d-node tets; msim needs 4", surf->file.c_str(), out.numberofcorners);
  tets->file      = surf->file + ", tetrahedralized by TetGen -" + switches;
  tets->nper      = 4;
  tets->cell_name = "tet";
  tets->nv        = out.numberofpoints;
  tets->x.assign(out.pointlist, out.pointlist + 3 * (size_t)out.numberofpoints);
  tets->ncell = out.numberoftetrahedra;
  tets->cell.assign(out.tetrahedronlist, out.tetrahedronlist + 4 * (size_t)out.numberoftetrahedra);
  tets->vline.assign(tets->nv, 0);
  tets->cline.assign(tets->ncell, 0);
  tets->notes = surf->notes;
  /* TetGen keeps the surface's vertices first, in their order (switch p), and adds its own after
     them: these keep their file ids, the new ones are numbered on from the file's */
  for (PetscInt v = 0; v < surf->nv; v++)
    for (int c = 0; c < 3; c++) PetscCheck(v < tets->nv && tets->x[3 * v + c] == surf->x[3 * v + c], PETSC_COMM_SELF, PETSC_ERR_LIB, "%s: TetGen moved or renumbered the surface's vertex %" PetscInt_FMT " (-msim_tetgen_switches %s): msim needs the surface's vertices kept in order", surf->file.c_str(), MSimMeshFileId(surf, v), switches);
  tets->nv_file = surf->nv_file + (tets->nv - surf->nv);
  if (!surf->file_id.empty()) {
    tets->file_id = surf->file_id;
    for (PetscInt v = surf->nv; v < tets->nv; v++) tets->file_id.push_back(surf->nv_file + (v - surf->nv));
  }
#endif
  PetscCall(PetscLogEventEnd(MSIM_TetGen, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}
