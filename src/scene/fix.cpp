/* Fixed vertices, set where each vertex has its directory. -msim_fix corners|edge mean what the grid
   or chain defines; meshes pick theirs by a plane (the vertices within -msim_fix_plane_tol of the
   scene's extreme in one direction), a box, or a list of ids (a file's own ids: its order from 0,
   whatever vertices msim dropped, scene.h's file_id). Plane, box and list add to each other; set
   alone, plane or box replace the default corners. */
#include <msim/scene.h>
#include <algorithm>

/* -msim_fix_list where the file's ids differ from the input ids (the file had vertices no cell
   uses): each rank fixes the vertices of its block whose file ids are listed; an id no rank has
   names a dropped vertex, an error that says so */
static PetscErrorCode FixFileIds(MPI_Comm comm, MSimSceneData *s, const std::vector<PetscInt> &list)
{
  std::vector<PetscInt> sorted(list), found(list.size(), 0);

  PetscFunctionBeginUser;
  for (PetscInt f : list) PetscCheck(f >= 0 && f < s->nv_file, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_list: vertex %" PetscInt_FMT " is out of range [0, %" PetscInt_FMT "] (the ids of %s)", f, s->nv_file - 1, s->source.c_str());
  std::sort(sorted.begin(), sorted.end());
  /* found[q]: whether some rank holds the vertex sorted[q] (each vertex is in one block only) */
  for (size_t v = 0; v < s->file_id.size(); v++) {
    auto at = std::lower_bound(sorted.begin(), sorted.end(), s->file_id[v]);
    for (; at != sorted.end() && *at == s->file_id[v]; ++at) {
      s->fixed[v]                  = 1;
      found[at - sorted.begin()] = 1;
    }
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, found.data(), (PetscMPIInt)found.size(), MPIU_INT, MPI_SUM, comm));
  for (size_t q = 0; q < sorted.size(); q++) PetscCheck(found[q], comm, PETSC_ERR_ARG_WRONG, "-msim_fix_list: vertex %" PetscInt_FMT " of %s belongs to no %s and was dropped when the file was read (ids are the file's order from 0; fix one on the mesh)", sorted[q], s->source.c_str(), s->cell_size == 4 ? "tet" : "triangle");
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneSelectFixed(MPI_Comm comm, MSimSceneData *s)
{
  const char *fixes[]  = {"corners", "edge", "none", "list"};
  const char *planes[] = {"x_min", "x_max", "y_min", "y_max", "z_min", "z_max"};
  const bool  grid     = !s->corners.empty();
  PetscInt    ifix = grid ? 0 : 2, iplane = 0, nbox = 7; /* one more than needed: PETSc drops values past nbox silently */
  PetscReal   tol = 1e-6 * s->diameter, box[7] = {0, 0, 0, 0, 0, 0, 0};
  PetscBool   fix_set, plane_set, box_set, list_set;
  PetscMPIInt rank;
  std::vector<PetscInt> list;

  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  const PetscInt start = s->dir.Start(rank), count = s->dir.Count(rank);
  {
    /* room for a list of every vertex, up to 2^20 ids: beyond that a plane or a box says it */
    const PetscInt nids = s->nv_file > 0 ? s->nv_file : s->nv;
    const PetscInt room = PetscMax(PetscMin(nids, 1 << 20), 1);
    PetscInt       nlist = room;
    list.resize(nlist);
    PetscOptionsBegin(comm, NULL, "msim fixed vertices", NULL);
    PetscCall(PetscOptionsEList("-msim_fix", "Fixed vertices: corners, edge (grids and chains), none, list", NULL, fixes, 4, fixes[ifix], &ifix, &fix_set));
    PetscCall(MSimOptionsIntArray("-msim_fix_list", "Fixed vertex ids from 0: a mesh file's own order, whatever vertices msim drops", NULL, list.data(), &nlist, &list_set));
    PetscCall(PetscOptionsEList("-msim_fix_plane", "Fix the vertices on the scene's extreme plane in one direction", NULL, planes, 6, planes[0], &iplane, &plane_set));
    PetscCall(MSimOptionsReal("-msim_fix_plane_tol", "Distance from the plane within which -msim_fix_plane fixes vertices, m (default 1e-6 of the scene's bounding-box diagonal)", NULL, tol, &tol, NULL));
    PetscCall(MSimOptionsRealArray("-msim_fix_box", "Fix the vertices in the box x0,x1,y0,y1,z0,z1 (m, bounds included)", NULL, box, &nbox, &box_set));
    PetscOptionsEnd();
    PetscCheck(!list_set || nlist < room || room == nids, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_list: at most %" PetscInt_FMT " ids (fix large sets with -msim_fix_plane or -msim_fix_box)", room - 1);
    list.resize(list_set ? nlist : 0);
  }
  if (!fix_set && (plane_set || box_set)) ifix = 2;
  s->fixed.assign(count, 0);
  auto mark = [&](PetscInt v) {
    if (v >= start && v < start + count) s->fixed[v - start] = 1;
  };
  if (ifix <= 1) {
    PetscCheck(grid, comm, PETSC_ERR_ARG_WRONG, "-msim_fix %s is not defined for scene %s (fix a mesh's vertices with -msim_fix_plane, -msim_fix_box or -msim_fix_list)", fixes[ifix], s->name.c_str());
    for (PetscInt v : ifix == 0 ? s->corners : s->edge) mark(v);
  }
  PetscCheck(ifix != 3 || list_set, comm, PETSC_ERR_ARG_WRONG, "-msim_fix list needs -msim_fix_list i,j,...");
  if (s->nv_file > 0) PetscCall(FixFileIds(comm, s, list));
  else
    for (PetscInt v : list) {
      PetscCheck(v >= 0 && v < s->nv, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_list: vertex %" PetscInt_FMT " is out of range [0, %" PetscInt_FMT "]", v, s->nv - 1);
      mark(v);
    }
  if (plane_set) {
    const int axis = (int)iplane / 2;
    PetscReal ext  = iplane % 2 ? -PETSC_MAX_REAL : PETSC_MAX_REAL;
    PetscCheck(tol >= 0 && !PetscIsInfOrNanReal(tol), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_plane_tol must be >= 0 m (got %g)", (double)tol);
    for (PetscInt v = 0; v < count; v++) ext = iplane % 2 ? std::max(ext, s->x0[3 * v + axis]) : std::min(ext, s->x0[3 * v + axis]);
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &ext, 1, MPIU_REAL, iplane % 2 ? MPIU_MAX : MPIU_MIN, comm));
    for (PetscInt v = 0; v < count; v++)
      if (PetscAbsReal(s->x0[3 * v + axis] - ext) <= tol) s->fixed[v] = 1;
  }
  if (box_set) {
    PetscInt inside = 0;
    PetscCheck(nbox == 6, comm, PETSC_ERR_ARG_WRONG, "-msim_fix_box needs six comma-separated numbers x0,x1,y0,y1,z0,z1 (got %" PetscInt_FMT "%s)", nbox, nbox > 6 ? " or more" : "");
    for (int c = 0; c < 3; c++) PetscCheck(box[2 * c] <= box[2 * c + 1], comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_fix_box: %c0 = %g is above %c1 = %g", "xyz"[c], (double)box[2 * c], "xyz"[c], (double)box[2 * c + 1]);
    for (PetscInt v = 0; v < count; v++) {
      const PetscReal *p = &s->x0[3 * v];
      if (p[0] >= box[0] && p[0] <= box[1] && p[1] >= box[2] && p[1] <= box[3] && p[2] >= box[4] && p[2] <= box[5]) {
        s->fixed[v] = 1;
        inside++;
      }
    }
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &inside, 1, MPIU_INT, MPI_SUM, comm));
    PetscCheck(inside > 0, comm, PETSC_ERR_ARG_WRONG, "-msim_fix_box %g,%g,%g,%g,%g,%g holds no vertex of the %s scene", (double)box[0], (double)box[1], (double)box[2], (double)box[3], (double)box[4], (double)box[5], s->name.c_str());
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
