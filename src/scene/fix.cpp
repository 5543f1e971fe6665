/* Fixed vertices. -msim_fix corners|edge mean what the grid or chain defines; meshes pick theirs by
   a plane (the vertices within -msim_fix_plane_tol of the mesh's extreme in one direction), a box,
   or a list of ids. Plane, box and list add to each other; set alone, plane or box replace the
   default corners. */
#include <msim/scene.h>
#include <algorithm>

PetscErrorCode MSimSceneSelectFixed(MPI_Comm comm, MSimSceneData *s)
{
  const char *fixes[]  = {"corners", "edge", "none", "list"};
  const char *planes[] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
  const bool  grid     = !s->corners.empty();
  PetscInt    ifix = grid ? 0 : 2, iplane = 0, nlist = PetscMax(s->nv, 1), nbox = 6;
  PetscReal   tol = 1e-6 * s->diameter, box[6] = {0, 0, 0, 0, 0, 0};
  PetscBool   fix_set, plane_set, box_set, list_set;
  std::vector<PetscInt> list(nlist);

  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, NULL, "msim fixed vertices", NULL);
  PetscCall(PetscOptionsEList("-msim_fix", "Fixed vertices: corners, edge (grids and chains), none, list", NULL, fixes, 4, fixes[ifix], &ifix, &fix_set));
  PetscCall(PetscOptionsIntArray("-msim_fix_list", "Fixed vertex ids (input order, from 0)", NULL, list.data(), &nlist, &list_set));
  PetscCall(PetscOptionsEList("-msim_fix_plane", "Fix the vertices on the scene's extreme plane in one direction", NULL, planes, 6, planes[0], &iplane, &plane_set));
  PetscCall(PetscOptionsReal("-msim_fix_plane_tol", "Distance from the plane within which -msim_fix_plane fixes vertices, m (default 1e-6 of the scene's diameter)", NULL, tol, &tol, NULL));
  PetscCall(PetscOptionsRealArray("-msim_fix_box", "Fix the vertices in the box x0,x1,y0,y1,z0,z1 (m, bounds included)", NULL, box, &nbox, &box_set));
  PetscOptionsEnd();
  if (!fix_set && (plane_set || box_set)) ifix = 2;
  s->fixed.assign(s->nv, 0);
  if (ifix <= 1) {
    PetscCheck(grid, comm, PETSC_ERR_ARG_WRONG, "-msim_fix %s is not defined for scene %s (fix a mesh's vertices with -msim_fix_plane, -msim_fix_box or -msim_fix_list)", fixes[ifix], s->name.c_str());
    for (PetscInt v : ifix == 0 ? s->corners : s->edge) s->fixed[v] = 1;
  }
  PetscCheck(ifix != 3 || list_set, comm, PETSC_ERR_ARG_WRONG, "-msim_fix list needs -msim_fix_list i,j,...");
  if (list_set)
    for (PetscInt q = 0; q < nlist; q++) {
      PetscCheck(list[q] >= 0 && list[q] < s->nv, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_list: vertex %" PetscInt_FMT " is out of range [0, %" PetscInt_FMT "]", list[q], s->nv - 1);
      s->fixed[list[q]] = 1;
    }
  if (plane_set) {
    const int axis = (int)iplane / 2;
    PetscReal ext  = iplane % 2 ? -PETSC_MAX_REAL : PETSC_MAX_REAL;
    PetscCheck(tol >= 0 && !PetscIsInfOrNanReal(tol), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_plane_tol must be >= 0 m (got %g)", (double)tol);
    for (PetscInt v = 0; v < s->nv; v++) ext = iplane % 2 ? std::max(ext, s->x0[3 * v + axis]) : std::min(ext, s->x0[3 * v + axis]);
    for (PetscInt v = 0; v < s->nv; v++)
      if (PetscAbsReal(s->x0[3 * v + axis] - ext) <= tol) s->fixed[v] = 1;
  }
  if (box_set) {
    PetscInt inside = 0;
    PetscCheck(nbox == 6, comm, PETSC_ERR_ARG_WRONG, "-msim_fix_box needs six comma-separated numbers x0,x1,y0,y1,z0,z1 (got %" PetscInt_FMT ")", nbox);
    for (int c = 0; c < 3; c++) PetscCheck(box[2 * c] <= box[2 * c + 1], comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_box: %c0 = %g is above %c1 = %g", "xyz"[c], (double)box[2 * c], "xyz"[c], (double)box[2 * c + 1]);
    for (PetscInt v = 0; v < s->nv; v++) {
      const PetscReal *p = &s->x0[3 * v];
      if (p[0] >= box[0] && p[0] <= box[1] && p[1] >= box[2] && p[1] <= box[3] && p[2] >= box[4] && p[2] <= box[5]) {
        s->fixed[v] = 1;
        inside++;
      }
    }
    PetscCheck(inside > 0, comm, PETSC_ERR_ARG_WRONG, "-msim_fix_box %g,%g,%g,%g,%g,%g holds no vertex of the %s scene", (double)box[0], (double)box[1], (double)box[2], (double)box[3], (double)box[4], (double)box[5], s->name.c_str());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
