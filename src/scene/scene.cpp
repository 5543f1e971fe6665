/* Scene registry, the options every scene shares (stiffness, mass; fixed vertices: fix.cpp), and the
   order of the distributed steps after a generator ran. */
#include <msim/scene.h>
#include <msim/log.h>
#include <msim/registry.h>
#include <msim/private/sceneimpl.h>
#include <memory>
#include <cmath>
#include <algorithm>
#include <cstdint>

static MSimRegistry<MSimSceneGenerator> MSimScenes;

PetscErrorCode MSimSceneRegister(const char name[], MSimSceneGenerator gen)
{
  return MSimScenes.Add(name, gen);
}

PetscErrorCode MSimSceneRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (!MSimScenes.Fill()) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(MSimSceneRegister("cloth", MSimSceneGenerate_Cloth));
  PetscCall(MSimSceneRegister("chain", MSimSceneGenerate_Chain));
  PetscCall(MSimSceneRegister("tet", MSimSceneGenerate_Tet));
  PetscCall(MSimSceneRegister("mesh", MSimSceneGenerate_Mesh));
  PetscCall(MSimSceneRegister("box", MSimSceneGenerate_Box));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneFinalizePackage(void)
{
  return MSimScenes.Destroy();
}

PetscErrorCode MSimSceneOptionsFamilyStiffness_Private(PetscOptionItems *PetscOptionsObject, const MSimSceneData *s, const char family[], const char help[], PetscReal *k)
{
  char      name[64];
  PetscBool set;

  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(name, sizeof(name), "-msim_stiffness_%s", family));
  *k = s->stiffness; /* PETSc leaves the value alone where the option is not set */
  PetscCall(MSimOptionsReal_Private(PetscOptionsObject, name, help, NULL, s->stiffness, k, &set));
  PetscCheck(!set || *k > 0, PetscOptionsObject->comm, PETSC_ERR_ARG_OUTOFRANGE, "%s must be > 0 N/m (got %g)", name, (double)*k);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* -msim_scene_view: what a user checks after loading a mesh */
static PetscErrorCode MSimSceneView(MPI_Comm comm, const MSimSceneData *s)
{
  PetscReal sum[2] = {0, 0}, lo[2] = {PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[2] = {0, 0};
  PetscInt  nfix = 0;

  PetscFunctionBeginUser;
  for (size_t v = 0; v < s->mass.size(); v++) {
    sum[0] += s->mass[v];
    nfix += s->fixed[v] ? 1 : 0;
  }
  for (size_t q = 0; q < s->sk.size(); q++) {
    lo[0] = std::min(lo[0], s->sk[q]);
    hi[0] = std::max(hi[0], s->sk[q]);
    lo[1] = std::min(lo[1], s->sL[q]);
    hi[1] = std::max(hi[1], s->sL[q]);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, sum, 1, MPIU_REAL, MPIU_SUM, comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &nfix, 1, MPIU_INT, MPI_SUM, comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, lo, 2, MPIU_REAL, MPIU_MIN, comm));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, hi, 2, MPIU_REAL, MPIU_MAX, comm));
  PetscCall(PetscPrintf(comm, "scene %s%s%s%s: %" PetscInt_FMT " vertices (%" PetscInt_FMT " fixed), ", s->name.c_str(), s->source.empty() ? "" : " (", s->source.c_str(), s->source.empty() ? "" : ")", s->nv, nfix));
  if (s->cell_size) PetscCall(PetscPrintf(comm, "%" PetscInt_FMT " %s, ", s->ncell, s->cell_size == 4 ? "tets" : "triangles"));
  PetscCall(PetscPrintf(comm, "%" PetscInt_FMT " springs\n", s->nspring));
  if (s->cell_size) PetscCall(PetscPrintf(comm, "  %s %.15g m^%d\n", s->cell_size == 4 ? "volume" : "area", (double)s->measure, s->cell_size == 4 ? 3 : 2));
  PetscCall(PetscPrintf(comm, "  mass %.15g kg; stiffness %.6g to %.6g N/m; rest length %.6g to %.6g m; bounding-box diagonal %.6g m\n", (double)sum[0], (double)lo[0], (double)hi[0], (double)lo[1], (double)hi[1], (double)s->diameter));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneCreateFromOptions(MPI_Comm comm, MSimScene *scene)
{
  MSimScene          sc;
  char               type[64] = "cloth";
  MSimSceneGenerator gen;
  PetscReal          mass = 1.0, density = 0;
  PetscBool          mass_set, density_set, view = PETSC_FALSE, refine_set, keep_cells = PETSC_FALSE, drawn, young_set;
  PetscInt           refine = 0;
  MSimOptionsWatch   watch;

  PetscFunctionBeginUser;
  PetscCall(MSimSceneRegisterAll());
  std::unique_ptr<_n_MSimScene> owner(new _n_MSimScene()); /* freed if the scene is refused */
  sc = owner.get();
  MSimSceneData &S = sc->data;
  sc->fix_velocity[0] = sc->fix_velocity[1] = sc->fix_velocity[2] = 0.0;
  sc->prestretch = 1.0;
  sc->perturb    = 0.0;
  /* self-contact is physics added to the scene, like -msim_volume, not what the scene is: read
     before the identity's watch, so a checkpoint may be restarted with it turned on or off */
  PetscCall(MSimSelfContactGetOptions(comm, &S.self_contact));
  PetscOptionsBegin(comm, NULL, "msim scene", NULL);
  /* whether output will draw the cells: -msim_output and -msim_spectrum_modes are read by their
     owners, the output series and the spectrum, in their own blocks once the system exists, after
     the scene is built; the scene must know now, to keep its cells only then (at scale they are
     most of setup's memory). So it asks whether they are set, inside its block, without reading
     (listing) them a second time */
  PetscCall(PetscOptionsHasName(PetscOptionsObject->options, NULL, "-msim_output", &drawn));
  if (!drawn) PetscCall(PetscOptionsHasName(PetscOptionsObject->options, NULL, "-msim_spectrum_modes", &drawn));
  /* what is printed and kept of the scene, not what the scene is: read before the watch */
  PetscCall(PetscOptionsBool("-msim_scene_view", "Print the scene: counts, volume or area, mass, stiffness and rest-length ranges", NULL, view, &view, NULL));
  PetscCall(PetscOptionsBool("-msim_scene_keep_cells", "Keep the scene's cells when nothing draws or refines them (for code that reads them)", NULL, keep_cells, &keep_cells, NULL));
  PetscCall(PetscOptionsBool("-msim_volume", "Tet scenes: a volume term per tet (Teschner) with an inversion barrier, so that no tet inverts in implicit steps (per PD step on the bunny: the full term +66-71%, the barrier alone with -msim_volume_stiffness 0, as examples/bunny.opts, +17-20%: runs/self_contact/volume)", NULL, S.volume, &S.volume, NULL));
  /* from here to MSimOptionsWatchEnd every option the user set that is read defines the scene
     (S.identity): whoever reads it, the scene, its generator, fixed vertices or a mesh reader */
  PetscCall(MSimOptionsWatchBegin(&watch));
  PetscCall(PetscOptionsFList("-msim_scene", "Scene generator", NULL, MSimScenes.list, type, type, sizeof(type), NULL));
  PetscCall(MSimOptionsReal("-msim_stiffness", "Spring constant of every spring, N/m", NULL, S.stiffness, &S.stiffness, NULL));
  /* read here, once, for the solid scenes' generators (tet, box), which take it from S.young */
  PetscCall(MSimOptionsReal("-msim_young", "Young's modulus of the solid scenes (tet, box), Pa: each spring's stiffness E V_e / L^2 (V_e: volume of the tets around the edge) instead of -msim_stiffness", NULL, S.young, &S.young, &young_set));
  PetscCall(MSimOptionsReal("-msim_mass", "Total mass, kg, lumped to the vertices: equally on grids and chains, by volume or area on meshes", NULL, mass, &mass, &mass_set));
  PetscCall(MSimOptionsReal("-msim_density", "Mass per volume (tets, kg/m^3) or per area (surfaces, kg/m^2), instead of -msim_mass", NULL, density, &density, &density_set));
  PetscCall(MSimOptionsVec3("-msim_fix_velocity", "Velocity of the fixed vertices (moving handles), m/s", sc->fix_velocity, NULL));
  PetscCall(MSimOptionsReal("-msim_prestretch", "Initial positions = prestretch * rest positions", NULL, sc->prestretch, &sc->prestretch, NULL));
  PetscCall(MSimOptionsReal("-msim_perturb", "Displace free vertices initially by up to this much (m), pseudo-random by vertex id", NULL, sc->perturb, &sc->perturb, NULL));
  PetscCall(MSimOptionsInt("-msim_refine", "Refine a tet scene r times, each tet into 8 (on the distributed mesh)", NULL, refine, &refine, &refine_set));
  PetscOptionsEnd();
  PetscCheck(refine >= 0 && refine <= 10, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_refine must be in [0, 10] (got %" PetscInt_FMT ")", refine);
  PetscCheck(!young_set || (S.young > 0 && !PetscIsInfOrNanReal(S.young)), comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_young must be > 0 Pa (got %g)", (double)S.young);
  PetscCheck(S.stiffness > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_stiffness must be > 0 N/m (got %g)", (double)S.stiffness);
  PetscCheck(mass > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_mass must be > 0 kg (got %g)", (double)mass);
  PetscCheck(!density_set || density > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_density must be > 0 (got %g)", (double)density);
  PetscCheck(!(mass_set && density_set), comm, PETSC_ERR_ARG_WRONG, "-msim_mass and -msim_density both set: give the total mass or the density, not both");
  PetscCheck(sc->perturb >= 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_perturb must be >= 0 m (got %g)", (double)sc->perturb);
  PetscCheck(sc->prestretch > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_prestretch must be > 0 (got %g)", (double)sc->prestretch);

  PetscCall(MSimScenes.Find(comm, "-msim_scene", type, &gen));
  S.name         = type;
  S.cells_wanted = (PetscBool)(drawn || refine > 0 || keep_cells || S.volume || S.self_contact.on);
  /* the Read stage holds reading a file or generating the scene's blocks */
  PetscCall(PetscLogStagePush(MSIM_StageRead));
  PetscCall((*gen)(comm, &S));
  PetscCall(PetscLogStagePop());
  PetscCheck(!S.volume || S.cell_size == 4, comm, PETSC_ERR_ARG_WRONG, "-msim_volume needs tets: use it with -msim_scene tet or box (scene '%s' has none)", type);
  if (S.cell_size != 4) {
    /* Young's modulus sets the springs of solids only: said to be irrelevant here, not applied to
       a surface's triangles */
    if (young_set) PetscCall(PetscFPrintf(comm, PETSC_STDERR, "msim: note: -msim_young does not apply to -msim_scene %s%s; it sets the springs of the solid scenes tet and box\n", type, S.cell_size == 3 ? " (a surface's springs take -msim_stiffness_edge, N/m)" : ""));
    S.young = 0;
  }

  /* -help lists every scene's options, not only the chosen one's: the other generators read
     their options on a scratch scene and build nothing */
  {
    PetscBool help;
    PetscCall(PetscOptionsHasHelp(NULL, &help));
    if (help) {
      const char **names;
      int           n;
      PetscCall(PetscFunctionListGet(MSimScenes.list, &names, &n));
      for (int q = 0; q < n && names[q]; q++) { /* the array ends with NULL, counted in n */
        MSimSceneData      scratch;
        MSimSceneGenerator g;
        if (!strcmp(names[q], type)) continue;
        scratch.options_only = PETSC_TRUE;
        scratch.stiffness    = S.stiffness;
        PetscCall(PetscFunctionListFind(MSimScenes.list, names[q], &g));
        PetscCall((*g)(comm, &scratch));
      }
      PetscCall(PetscFree(names));
    }
  }
  PetscCheck(!refine_set || S.cell_size == 4, comm, PETSC_ERR_ARG_WRONG, "-msim_refine refines tets: use it with -msim_scene tet or box, not %s", type);

  /* the distributed steps: vertices to their directory, cells spread, refined, springs from the
     cells' edges */
  if (refine && S.springs_made) { /* the refined mesh makes its own */
    S.si.clear();
    S.sj.clear();
    S.sk.clear();
    S.sL.clear();
    S.share.clear();
    S.springs_made = PETSC_FALSE;
  }
  PetscCall(PetscLogStagePush(MSIM_StageDistribute));
  PetscCall(MSimSceneToDirectory(comm, &S));
  if (S.cell_size && !S.springs_made) PetscCall(MSimSceneSpreadCells(comm, &S));
  PetscCall(PetscLogStagePop());
  if (refine) {
    PetscCall(PetscLogStagePush(MSIM_StageRefine));
    for (PetscInt r = 0; r < refine; r++) PetscCall(MSimSceneRefine(comm, &S));
    PetscCall(PetscLogStagePop());
  }
  PetscCall(PetscLogStagePush(MSIM_StageDistribute));
  if (S.cell_size && !S.springs_made) PetscCall(MSimSceneCellSprings(comm, &S));
  {
    PetscInt n[2] = {(PetscInt)S.si.size(), S.cell_size ? (PetscInt)(S.cells.size() / S.cell_size) + S.cells_not_stored : 0};
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, n, 2, MPIU_INT, MPI_SUM, comm));
    S.nspring = n[0];
    S.ncell   = n[1];
  }
  {
    PetscReal lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL};
    for (size_t v = 0; v < S.x0.size() / 3; v++)
      for (int c = 0; c < 3; c++) {
        lo[c] = std::min(lo[c], S.x0[3 * v + c]);
        hi[c] = std::max(hi[c], S.x0[3 * v + c]);
      }
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPIU_REAL, MPIU_MIN, comm));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPIU_REAL, MPIU_MAX, comm));
    S.diameter = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  }
  PetscCall(MSimSceneSelectFixed(comm, &S));

  /* Masses: on grids and chains equal, on meshes each vertex's share of the volume or area
     (fixed vertices included, so the total is the stated one) */
  const size_t nblock = S.x0.size() / 3;
  if (!S.cell_size) {
    PetscCheck(!density_set, comm, PETSC_ERR_ARG_WRONG, "-msim_density needs a mesh (-msim_scene tet, box or mesh); a %s takes its total -msim_mass", S.name.c_str());
    S.mass.assign(nblock, mass / S.nv);
  } else {
    const PetscReal f = density_set ? density : mass / S.measure;
    S.mass.resize(nblock);
    for (size_t v = 0; v < nblock; v++) S.mass[v] = f * S.share[v];
    S.share.clear();
    S.share.shrink_to_fit();
  }
  PetscCall(PetscLogStagePop());
  PetscCall(MSimOptionsWatchEnd(&watch, S.identity));
  if (view) PetscCall(MSimSceneView(comm, &S));
  sc->view  = view;
  sc->drawn = drawn;
  *scene = owner.release();
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A reproducible number in [-1, 1] for (vertex, component), the same on every rank and partition. */
PetscReal MSimSceneHash(PetscInt v, PetscInt c)
{
  uint64_t z = (uint64_t)(3 * v + c) + 0x9E3779B97F4A7C15ull;
  z          = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z          = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  z          = z ^ (z >> 31);
  return 2.0 * (PetscReal)(z >> 11) / 9007199254740992.0 - 1.0;
}

PetscErrorCode MSimSceneDestroy(MSimScene *scene)
{
  PetscFunctionBeginUser;
  delete *scene;
  *scene = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneGetData(MSimScene scene, const MSimSceneData **data)
{
  PetscFunctionBeginUser;
  *data = &scene->data;
  PetscFunctionReturn(PETSC_SUCCESS);
}
