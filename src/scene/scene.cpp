/* Scene registry and the options every scene shares: stiffness, mass (fixed vertices: fix.cpp). */
#include <msim/scene.h>
#include <cmath>
#include <algorithm>
#include <cstdint>

static PetscFunctionList MSimSceneList = NULL;
static PetscBool         MSimSceneRegisterAllCalled = PETSC_FALSE;

PetscErrorCode MSimSceneRegister(const char name[], MSimSceneGenerator gen)
{
  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListAdd(&MSimSceneList, name, gen));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneRegisterAll(void)
{
  PetscFunctionBeginUser;
  if (MSimSceneRegisterAllCalled) PetscFunctionReturn(PETSC_SUCCESS);
  MSimSceneRegisterAllCalled = PETSC_TRUE;
  PetscCall(MSimSceneRegister("cloth", MSimSceneGenerate_Cloth));
  PetscCall(MSimSceneRegister("chain", MSimSceneGenerate_Chain));
  PetscCall(MSimSceneRegister("tet", MSimSceneGenerate_Tet));
  PetscCall(MSimSceneRegister("mesh", MSimSceneGenerate_Mesh));
  PetscCall(MSimSceneRegister("box", MSimSceneGenerate_Box));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneFinalizePackage(void)
{
  PetscFunctionBeginUser;
  PetscCall(PetscFunctionListDestroy(&MSimSceneList));
  MSimSceneRegisterAllCalled = PETSC_FALSE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

void MSimSceneAddSpring(MSimSceneData *s, PetscInt i, PetscInt j, PetscReal k)
{
  const PetscReal *a = &s->x0[3 * i], *b = &s->x0[3 * j];
  s->si.push_back(i);
  s->sj.push_back(j);
  s->sk.push_back(k);
  s->sL.push_back(std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2])));
}

/* -msim_stiffness k, overridden per family by -msim_stiffness_<family>. Read inside the caller's
   options block so -help lists them with the scene. */
PetscErrorCode MSimSceneGetStiffness(const char family[], PetscReal *k)
{
  char      name[64];
  PetscReal kf;
  PetscBool set;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-msim_stiffness", k, NULL));
  PetscCheck(*k > 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "-msim_stiffness must be > 0 N/m (got %g)", (double)*k);
  if (family) {
    PetscCall(PetscSNPrintf(name, sizeof(name), "-msim_stiffness_%s", family));
    PetscCall(PetscOptionsGetReal(NULL, NULL, name, &kf, &set));
    if (set) {
      PetscCheck(kf > 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "%s must be > 0 N/m (got %g)", name, (double)kf);
      *k = kf;
    }
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* -msim_scene_view: what a user checks after loading a mesh */
static PetscErrorCode MSimSceneView(MPI_Comm comm, const MSimSceneData *s)
{
  PetscReal mass = 0, kmin = PETSC_MAX_REAL, kmax = 0, lmin = PETSC_MAX_REAL, lmax = 0;
  PetscInt  nfix = 0;

  PetscFunctionBeginUser;
  for (PetscInt v = 0; v < s->nv; v++) {
    mass += s->mass[v];
    nfix += s->fixed[v] ? 1 : 0;
  }
  for (size_t q = 0; q < s->sk.size(); q++) {
    kmin = std::min(kmin, s->sk[q]);
    kmax = std::max(kmax, s->sk[q]);
    lmin = std::min(lmin, s->sL[q]);
    lmax = std::max(lmax, s->sL[q]);
  }
  PetscCall(PetscPrintf(comm, "scene %s%s%s%s: %" PetscInt_FMT " vertices (%" PetscInt_FMT " fixed), ", s->name.c_str(), s->source.empty() ? "" : " (", s->source.c_str(), s->source.empty() ? "" : ")", s->nv, nfix));
  if (s->cell_size) PetscCall(PetscPrintf(comm, "%zu %s, ", s->cells.size() / s->cell_size, s->cell_size == 4 ? "tets" : "triangles"));
  PetscCall(PetscPrintf(comm, "%zu springs\n", s->si.size()));
  if (s->cell_size) PetscCall(PetscPrintf(comm, "  %s %.15g m^%d\n", s->cell_size == 4 ? "volume" : "area", (double)s->measure, s->cell_size == 4 ? 3 : 2));
  PetscCall(PetscPrintf(comm, "  mass %.15g kg; stiffness %.6g to %.6g N/m; rest length %.6g to %.6g m; diameter %.6g m\n", (double)mass, (double)kmin, (double)kmax, (double)lmin, (double)lmax, (double)s->diameter));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimSceneCreateFromOptions(MPI_Comm comm, MSimScene *scene)
{
  MSimScene          sc;
  char               type[64] = "cloth";
  MSimSceneGenerator gen;
  PetscReal          mass = 1.0, density = 0, k = 1000.0;
  PetscBool          mass_set, density_set, view = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(MSimSceneRegisterAll());
  sc = new _n_MSimScene();
  sc->fix_velocity[0] = sc->fix_velocity[1] = sc->fix_velocity[2] = 0.0;
  sc->prestretch = 1.0;
  sc->perturb    = 0.0;
  PetscOptionsBegin(comm, NULL, "msim scene", NULL);
  PetscCall(PetscOptionsFList("-msim_scene", "Scene generator", NULL, MSimSceneList, type, type, sizeof(type), NULL));
  PetscCall(PetscOptionsReal("-msim_stiffness", "Spring constant of every spring, N/m", NULL, k, &k, NULL));
  PetscCall(PetscOptionsReal("-msim_mass", "Total mass, kg, lumped to the vertices: equally on grids and chains, by volume or area on meshes", NULL, mass, &mass, &mass_set));
  PetscCall(PetscOptionsReal("-msim_density", "Mass per volume (tets, kg/m^3) or per area (surfaces, kg/m^2), instead of -msim_mass", NULL, density, &density, &density_set));
  PetscCall(MSimOptionsVec3("-msim_fix_velocity", "Velocity of the fixed vertices (moving handles), m/s", sc->fix_velocity, NULL));
  PetscCall(PetscOptionsReal("-msim_prestretch", "Initial positions = prestretch * rest positions", NULL, sc->prestretch, &sc->prestretch, NULL));
  PetscCall(PetscOptionsReal("-msim_perturb", "Displace free vertices initially by up to this much (m), pseudo-random by vertex id", NULL, sc->perturb, &sc->perturb, NULL));
  PetscCall(PetscOptionsBool("-msim_scene_view", "Print the scene: counts, volume or area, mass, stiffness and rest-length ranges", NULL, view, &view, NULL));
  PetscOptionsEnd();
  PetscCheck(k > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_stiffness must be > 0 N/m (got %g)", (double)k);
  PetscCheck(mass > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_mass must be > 0 kg (got %g)", (double)mass);
  PetscCheck(!density_set || density > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_density must be > 0 (got %g)", (double)density);
  PetscCheck(!(mass_set && density_set), comm, PETSC_ERR_ARG_WRONG, "-msim_mass and -msim_density both set: give the total mass or the density, not both");
  PetscCheck(sc->perturb >= 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_perturb must be >= 0 m (got %g)", (double)sc->perturb);
  PetscCheck(sc->prestretch > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_prestretch must be > 0 (got %g)", (double)sc->prestretch);

  PetscCall(PetscFunctionListFind(MSimSceneList, type, &gen));
  PetscCheck(gen, comm, PETSC_ERR_ARG_UNKNOWN_TYPE, "-msim_scene %s is not a known scene", type);
  sc->data.name = type;
  PetscCall((*gen)(comm, &sc->data));

  /* -help lists every scene's options, not only the chosen one's: the other generators read
     their options on a scratch scene and build nothing */
  {
    PetscBool help;
    PetscCall(PetscOptionsHasHelp(NULL, &help));
    if (help) {
      const char **names;
      int           n;
      PetscCall(PetscFunctionListGet(MSimSceneList, &names, &n));
      for (int q = 0; q < n && names[q]; q++) { /* the array ends with NULL, counted in n */
        MSimSceneData      scratch;
        MSimSceneGenerator g;
        if (!strcmp(names[q], type)) continue;
        scratch.options_only = PETSC_TRUE;
        PetscCall(PetscFunctionListFind(MSimSceneList, names[q], &g));
        PetscCall((*g)(comm, &scratch));
      }
      PetscCall(PetscFree(names));
    }
  }
  {
    PetscReal lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {PETSC_MIN_REAL, PETSC_MIN_REAL, PETSC_MIN_REAL};
    for (PetscInt v = 0; v < sc->data.nv; v++)
      for (int c = 0; c < 3; c++) {
        lo[c] = std::min(lo[c], sc->data.x0[3 * v + c]);
        hi[c] = std::max(hi[c], sc->data.x0[3 * v + c]);
      }
    sc->data.diameter = std::sqrt((hi[0] - lo[0]) * (hi[0] - lo[0]) + (hi[1] - lo[1]) * (hi[1] - lo[1]) + (hi[2] - lo[2]) * (hi[2] - lo[2]));
  }
  PetscCall(MSimSceneSelectFixed(comm, &sc->data));

  /* Masses: on grids and chains equal, on meshes each vertex's share of the volume or area
     (fixed vertices included, so the total is the stated one) */
  if (sc->data.share.empty()) {
    PetscCheck(!density_set, comm, PETSC_ERR_ARG_WRONG, "-msim_density needs a mesh (-msim_scene tet, box or mesh); a %s takes its total -msim_mass", sc->data.name.c_str());
    sc->data.mass.assign(sc->data.nv, mass / sc->data.nv);
  } else {
    const PetscReal f = density_set ? density : mass / sc->data.measure;
    sc->data.mass.resize(sc->data.nv);
    for (PetscInt v = 0; v < sc->data.nv; v++) sc->data.mass[v] = f * sc->data.share[v];
    sc->data.share.clear();
    sc->data.share.shrink_to_fit();
  }
  if (view) PetscCall(MSimSceneView(comm, &sc->data));
  *scene = sc;
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
