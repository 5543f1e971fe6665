/* Checkpoint and restart: -msim_checkpoint F [-msim_checkpoint_every k] writes the state the
   stepping loop carries (free positions and velocities in input vertex order, so that any rank
   count can read them; the step, time, step size, the initial energy the divergence check
   compares with) with a format version and what identifies the scene (its vertex and moving-spring
   counts and the options that define it, which the scene records where it reads them), through
   PETSc's binary viewer, collectively, to F.tmp renamed to F once closed: a killed run leaves its previous checkpoint whole. -msim_restart F
   continues from one. An integrator with a history (BDF2's x_{n-1}, v_{n-1}, Newmark's a_n) has it
   written too, under its type name, in the same order; a restart with the same integrator loads
   it, another starts its scheme up afresh. So does the state the implicit integrators' solver
   carries from one step's solve to the next (MSimSolverHistory: SNES pd's L-BFGS pairs, ntr's
   radius), under its name, its scalars then its vectors (in input vertex order too, so that
   another rank count gets them redistributed as x and v); a restart whose solver would carry the
   same takes it, another solver starts afresh. So do the shells' sides (a mesh obstacle with
   -msim_contact_thickness under the penalty keeps each vertex on the side it came from, past the
   surface too: msim/contact.h), two vectors per shell under what identifies the shells (each one's
   index, file and thickness); a restart with the same shells takes them, other obstacles start
   with no side known (the obstacles are options a restart may change, msim/contact.h's
   MSimContactCheckRestart). The rest state goes with them too (RestState): a mesh file edited in
   place keeps its counts and options, so its path says nothing and only its content counts. Nothing else carries from step to step (Anderson's
   history and the other SNES types' start afresh each solve; PETSc's qn keeps its pairs in a Mat
   whose contents PETSc 3.18 does not expose, so qn alone does not restart bit for bit, and a
   restart with it says so in one line), so a restarted run repeats the uninterrupted one bit for
   bit at the same rank count. */
#include <msim/output.h>
#include <msim/integrator.h>
#include <msim/implicit.h>
#include <msim/solvers.h>
#include <msim/options.h>
#include <msim/log.h>
#include <msim/private/integratorimpl.h>
#include <msim/private/systemimpl.h>
#include <msim/private/contactimpl.h>
#include <sstream>
#include <string>
#include <sys/stat.h>
#include <cerrno>
#include <cstring>
#include <algorithm>

static const PetscInt MSIM_CHECKPOINT_MAGIC   = 0x6d73696d; /* "msim" */
static const PetscInt MSIM_CHECKPOINT_VERSION = 4; /* 2: the integrator's history; 3: the solver's; 4: the shells' sides and the rest state */
enum { H_MAGIC, H_VERSION, H_NV, H_NSPRING, H_STEP, H_IDENT, H_NHIST, H_INTEG, H_SOLVER, H_SREAL, H_SVEC, H_SHELLS, H_NSIDE, H_COUNT };

/* What identifies the rest state besides the counts and options: a mesh file scaled, translated or
   edited in place has the same counts and options, and restarting its checkpoint's positions on
   another rest shape jumps the energy. The free vertices' mass and the moving springs' rest
   lengths summed (compensated on each rank, so that the sums agree to a few roundoffs at any rank
   count), and the bounding box of the positions at t = 0 (exact: minima and maxima) */
enum { R_MASS, R_LENGTH, R_LO, R_HI = R_LO + 3, R_COUNT = R_HI + 3 };
static const char *const rest_name[R_COUNT] = {"free vertices' mass", "sum of rest lengths", "least x at t = 0", "least y at t = 0", "least z at t = 0", "greatest x at t = 0", "greatest y at t = 0", "greatest z at t = 0"};

struct _n_MSimCheckpoint {
  MSimSystem sys;
  char       path[PETSC_MAX_PATH_LEN];    /* "" : no checkpoints */
  char       restart[PETSC_MAX_PATH_LEN]; /* "" : a fresh run */
  PetscInt   every;
  std::string ident;
  PetscReal   rest[R_COUNT]; /* RestState's, once */
  MSimIntegrator integ; /* whose history goes with x and v (NULL: none) */
};

PetscErrorCode MSimCheckpointSetIntegrator(MSimCheckpoint ck, MSimIntegrator integ)
{
  PetscFunctionBeginUser;
  ck->integ = integ;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the integrator's history vectors (none without one or without the op) */
static PetscErrorCode History(MSimCheckpoint ck, PetscInt *n, Vec **history, const char **name)
{
  PetscFunctionBeginUser;
  *n       = 0;
  *history = NULL;
  *name    = "";
  if (ck->integ && ck->integ->ops.get_history) {
    PetscCall(ck->integ->ops.get_history(ck->integ, n, history));
    *name = ck->integ->type;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the solver whose state (MSimSolverHistory) goes with x and v: the implicit integrators' (NULL
   for the others) */
static PetscErrorCode Solver(MSimCheckpoint ck, SNES *snes)
{
  PetscBool implicit = PETSC_FALSE;

  PetscFunctionBeginUser;
  *snes = NULL;
  if (ck->integ) PetscCall(MSimImplicitSchemeIsRegistered(ck->integ->type, &implicit));
  if (implicit) PetscCall(MSimImplicitEulerGetSNES(ck->integ, snes));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* the mesh obstacles that keep their vertices' sides (shells under the penalty) and what
   identifies them, one line each: a restart gives the sides back to the same shells only */
static PetscErrorCode Shells(MSimCheckpoint ck, std::vector<MSimMeshObstacle> &shells, std::string &ident)
{
  MSimContact ct;

  PetscFunctionBeginUser;
  shells.clear();
  ident.clear();
  PetscCall(MSimContactGet(ck->sys, &ct));
  for (size_t k = 0; ct && k < ct->obs.size(); k++) {
    PetscBool   lost;
    PetscReal   p[3];
    const char *file;
    char        line[PETSC_MAX_PATH_LEN + 64];
    if (ct->obs[k].kind != MSIM_OBSTACLE_MESH || !MSimMeshObstacleKeepsSides(ct->obs[k].mesh, &lost, p)) continue;
    MSimMeshObstacleInfo(ct->obs[k].mesh, &file, NULL, NULL);
    PetscCall(PetscSNPrintf(line, sizeof(line), "%d %s %.17g\n", (int)k, file, (double)ct->thickness));
    shells.push_back(ct->obs[k].mesh);
    ident += line;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

static PetscErrorCode RestState(MSimSystem sys, PetscReal rest[R_COUNT])
{
  PetscReal          sum[4] = {0, 0, 0, 0}; /* mass, its compensation; length, its compensation */
  PetscReal          box[6];                /* least x, y, z and greatest ones negated: one MIN */
  const PetscScalar *a;
  PetscInt           n;
  auto add = [](PetscReal *s, PetscReal x) { /* Neumaier */
    const PetscReal t = s[0] + x;
    s[1] += PetscAbsReal(s[0]) >= PetscAbsReal(x) ? (s[0] - t) + x : (x - t) + s[0];
    s[0] = t;
  };

  PetscFunctionBeginUser;
  PetscCall(VecGetLocalSize(sys->mass, &n));
  PetscCall(VecGetArrayRead(sys->mass, &a));
  for (PetscInt i = 0; i < n; i += 3) add(&sum[0], PetscRealPart(a[i])); /* per dof: one a vertex */
  PetscCall(VecRestoreArrayRead(sys->mass, &a));
  MSimSpringsForEach(sys->springs, [&](PetscInt, PetscInt, PetscReal, PetscReal L) { add(&sum[2], L); });
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, sum, 4, MPIU_REAL, MPIU_SUM, sys->comm));
  rest[R_MASS]   = sum[0] + sum[1];
  rest[R_LENGTH] = sum[2] + sum[3];
  for (PetscReal &b : box) b = PETSC_MAX_REAL;
  PetscCall(MSimSystemNaturalPositions(sys, 0, sys->X0)); /* every vertex, the fixed ones too */
  PetscCall(VecGetLocalSize(sys->natural, &n));
  PetscCall(VecGetArrayRead(sys->natural, &a));
  for (PetscInt i = 0; i < n; i++) {
    box[i % 3]     = PetscMin(box[i % 3], PetscRealPart(a[i]));
    box[3 + i % 3] = PetscMin(box[3 + i % 3], -PetscRealPart(a[i]));
  }
  PetscCall(VecRestoreArrayRead(sys->natural, &a));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, box, 6, MPIU_REAL, MPIU_MIN, sys->comm));
  for (int c = 0; c < 3; c++) {
    rest[R_LO + c] = box[c];
    rest[R_HI + c] = -box[3 + c];
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCheckpointCreate(MSimSystem sys, MSimCheckpoint *ck)
{
  PetscBool set;

  PetscFunctionBeginUser;
  *ck          = new _n_MSimCheckpoint();
  (*ck)->sys   = sys;
  (*ck)->every = 100;
  PetscOptionsBegin(sys->comm, NULL, "msim checkpoint and restart", NULL);
  PetscCall(PetscOptionsString("-msim_checkpoint", "Write the state to this file (PETSc binary) every -msim_checkpoint_every steps, at the end and when stopped by SIGINT or SIGTERM", NULL, (*ck)->path, (*ck)->path, sizeof((*ck)->path), NULL));
  PetscCall(MSimOptionsInt("-msim_checkpoint_every", "Steps between checkpoints", NULL, (*ck)->every, &(*ck)->every, &set));
  PetscCall(PetscOptionsString("-msim_restart", "Continue from this checkpoint", NULL, (*ck)->restart, (*ck)->restart, sizeof((*ck)->restart), NULL));
  PetscOptionsEnd();
  PetscCheck((*ck)->every >= 1, sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_checkpoint_every must be >= 1 (got %" PetscInt_FMT ")", (*ck)->every);
  PetscCheck(!set || (*ck)->path[0], sys->comm, PETSC_ERR_ARG_WRONG, "-msim_checkpoint_every needs -msim_checkpoint F");
  /* the options that define the scene, from where the scene read them */
  (*ck)->ident = sys->scene_identity;
  if ((*ck)->path[0] || (*ck)->restart[0]) PetscCall(RestState(sys, (*ck)->rest)); /* collective: every rank has the options */
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCheckpointWanted(MSimCheckpoint ck, PetscInt step, PetscInt last, PetscBool *want)
{
  PetscFunctionBeginUser;
  *want = (PetscBool)(ck->path[0] && (step % ck->every == 0 || step == last));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCheckpointWrite(MSimCheckpoint ck, PetscInt step, PetscReal t, PetscReal dt, PetscReal E0, Vec X, Vec V)
{
  MSimSystem        sys = ck->sys;
  PetscViewer       v;
  const std::string tmp = std::string(ck->path) + ".tmp";
  PetscInt          header[H_COUNT];
  PetscReal         reals[3 + R_COUNT] = {t, dt, E0};
  int               ok       = 1;
  PetscInt          nhist;
  Vec              *hist;
  const char       *integ;
  SNES              snes;
  MSimSolverHistory solver;
  std::vector<MSimMeshObstacle> shells;
  std::string                   shell_ident;

  PetscFunctionBeginUser;
  if (!ck->path[0]) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCall(PetscLogEventBegin(MSIM_Output, X, 0, 0, 0));
  header[H_MAGIC]   = MSIM_CHECKPOINT_MAGIC;
  header[H_VERSION] = MSIM_CHECKPOINT_VERSION;
  header[H_NV]      = sys->nv;
  header[H_NSPRING] = sys->nspring_global;
  header[H_STEP]    = step;
  header[H_IDENT]   = (PetscInt)ck->ident.size();
  PetscCall(History(ck, &nhist, &hist, &integ));
  header[H_NHIST]   = nhist;
  header[H_INTEG]   = nhist ? (PetscInt)strlen(integ) : 0;
  PetscCall(Solver(ck, &snes));
  PetscCall(MSimSNESGetHistory(snes, &solver));
  header[H_SOLVER]  = (PetscInt)solver.name.size();
  header[H_SREAL]   = header[H_SOLVER] ? (PetscInt)solver.real.size() : 0;
  header[H_SVEC]    = header[H_SOLVER] ? (PetscInt)solver.vec.size() : 0;
  PetscCall(Shells(ck, shells, shell_ident));
  header[H_SHELLS]  = (PetscInt)shell_ident.size();
  header[H_NSIDE]   = 2 * (PetscInt)shells.size();
  std::copy(ck->rest, ck->rest + R_COUNT, reals + 3);
  PetscCall(PetscViewerCreate(sys->comm, &v));
  PetscCall(PetscViewerSetType(v, PETSCVIEWERBINARY));
  PetscCall(PetscViewerSetFromOptions(v)); /* -viewer_binary_mpiio */
  PetscCall(PetscViewerBinarySetSkipInfo(v, PETSC_TRUE));
  PetscCall(PetscViewerFileSetMode(v, FILE_MODE_WRITE));
  PetscCall(PetscViewerFileSetName(v, tmp.c_str()));
  PetscCall(PetscViewerBinaryWrite(v, header, H_COUNT, PETSC_INT));
  PetscCall(PetscViewerBinaryWrite(v, reals, 3 + R_COUNT, PETSC_REAL));
  if (header[H_IDENT]) PetscCall(PetscViewerBinaryWrite(v, ck->ident.data(), header[H_IDENT], PETSC_CHAR));
  if (header[H_INTEG]) PetscCall(PetscViewerBinaryWrite(v, integ, header[H_INTEG], PETSC_CHAR));
  if (header[H_SOLVER]) PetscCall(PetscViewerBinaryWrite(v, solver.name.data(), header[H_SOLVER], PETSC_CHAR));
  if (header[H_SREAL]) PetscCall(PetscViewerBinaryWrite(v, solver.real.data(), header[H_SREAL], PETSC_REAL));
  if (header[H_SHELLS]) PetscCall(PetscViewerBinaryWrite(v, shell_ident.data(), header[H_SHELLS], PETSC_CHAR));
  PetscCall(MSimSystemNaturalPositions(sys, t, X));
  PetscCall(VecView(sys->natural, v));
  PetscCall(MSimSystemNaturalVector(sys, V));
  PetscCall(VecView(sys->natural, v));
  for (PetscInt k = 0; k < nhist; k++) {
    PetscCall(MSimSystemNaturalVector(sys, hist[k]));
    PetscCall(VecView(sys->natural, v));
  }
  for (PetscInt k = 0; k < header[H_SVEC]; k++) {
    PetscCall(MSimSystemNaturalVector(sys, solver.vec[k]));
    PetscCall(VecView(sys->natural, v));
  }
  if (!shells.empty()) {
    Vec          w[2];
    PetscScalar *a[2];
    PetscCall(VecDuplicate(X, &w[0]));
    PetscCall(VecDuplicate(X, &w[1]));
    for (MSimMeshObstacle mo : shells) {
      PetscCall(VecGetArray(w[0], &a[0]));
      PetscCall(VecGetArray(w[1], &a[1]));
      MSimMeshObstacleGetSides(mo, sys->nown, a[0], a[1]);
      PetscCall(VecRestoreArray(w[0], &a[0]));
      PetscCall(VecRestoreArray(w[1], &a[1]));
      for (Vec wk : w) {
        PetscCall(MSimSystemNaturalVector(sys, wk));
        PetscCall(VecView(sys->natural, v));
      }
    }
    PetscCall(VecDestroy(&w[0]));
    PetscCall(VecDestroy(&w[1]));
  }
  PetscCall(PetscViewerDestroy(&v)); /* collective: the file is complete here */
  if (sys->rank == 0) ok = rename(tmp.c_str(), ck->path) == 0;
  PetscCallMPI(MPI_Bcast(&ok, 1, MPI_INT, 0, sys->comm));
  PetscCheck(ok, sys->comm, PETSC_ERR_FILE_WRITE, "-msim_checkpoint: cannot rename %s to %s", tmp.c_str(), ck->path);
  PetscCall(PetscLogEventEnd(MSIM_Output, X, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The checkpoint's file is written first at -msim_checkpoint_every steps, so a path that cannot be
   written (a missing directory, no permission) failed only then, in PETSc's words, after the run
   had spent those steps and written frames and monitor rows. Called where the other output files
   are opened (the output directory, which may hold it, exists by then): rank 0 creates F.tmp,
   the file each write goes through, and removes it again. */
PetscErrorCode MSimCheckpointCheckWritable(MSimCheckpoint ck)
{
  MSimSystem        sys = ck->sys;
  const std::string tmp = std::string(ck->path) + ".tmp";
  int               err = 0;

  PetscFunctionBeginUser;
  if (!ck->path[0]) PetscFunctionReturn(PETSC_SUCCESS);
  if (sys->rank == 0) {
    FILE *fp = fopen(tmp.c_str(), "wb");
    if (!fp) err = errno;
    else if (fclose(fp) != 0 || remove(tmp.c_str()) != 0) err = errno;
  }
  PetscCallMPI(MPI_Bcast(&err, 1, MPI_INT, 0, sys->comm));
  PetscCheck(!err, sys->comm, PETSC_ERR_FILE_OPEN, "-msim_checkpoint %s: cannot write %s (%s)", ck->path, tmp.c_str(), strerror(err));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The first option line that differs between two identities, as "-a x there, -a y here"; the
   mesh file's path is not compared (a moved copy is the same scene): its content is (RestState) */
static std::string FirstDifference(const std::string &there, const std::string &here)
{
  std::stringstream a(there), b(here);
  std::string       la, lb;
  auto              opt = [](const std::string &l) { return l.substr(0, l.find(' ')); };
  while (true) {
    const bool ga = (bool)std::getline(a, la), gb = (bool)std::getline(b, lb);
    if (!ga && !gb) return "";
    if (ga && gb && (la == lb || (opt(la) == opt(lb) && opt(la) == "-msim_mesh_file"))) continue;
    if (ga && gb && opt(la) == opt(lb)) return la + " there, " + lb.substr(lb.find(' ') + 1) + " here";
    if (!gb || (ga && la < lb)) return la + " there, not here";
    return lb + " here, not there";
  }
}

PetscErrorCode MSimCheckpointRestart(MSimCheckpoint ck, PetscInt steps, Vec X, Vec V, PetscInt *step, PetscReal *t, PetscReal *dt, PetscReal *E0, PetscBool *restarted)
{
  MSimSystem  sys = ck->sys;
  PetscViewer v;
  PetscInt    header[H_COUNT];
  PetscReal   reals[3 + R_COUNT];
  long long   size = -1;
  const char *F    = ck->restart;

  PetscFunctionBeginUser;
  *restarted = PETSC_FALSE;
  if (!F[0]) PetscFunctionReturn(PETSC_SUCCESS);
  /* what a damaged file cannot make the ranks disagree on: rank 0 checks its size before any
     collective read */
  if (sys->rank == 0) {
    struct stat st;
    if (stat(F, &st) == 0 && S_ISREG(st.st_mode)) size = (long long)st.st_size;
  }
  PetscCallMPI(MPI_Bcast(&size, 1, MPI_LONG_LONG, 0, sys->comm));
  PetscCheck(size >= 0, sys->comm, PETSC_ERR_FILE_OPEN, "-msim_restart %s: cannot open it", F);
  const long long head = (long long)(H_COUNT * sizeof(PetscInt) + (3 + R_COUNT) * sizeof(PetscReal));
  PetscCheck(size >= head, sys->comm, PETSC_ERR_FILE_UNEXPECTED, "-msim_restart %s: not an msim checkpoint (%lld bytes, too short)", F, size);
  PetscCall(PetscViewerBinaryOpen(sys->comm, F, FILE_MODE_READ, &v));
  PetscCall(PetscViewerBinaryRead(v, header, H_COUNT, NULL, PETSC_INT));
  PetscCall(PetscViewerBinaryRead(v, reals, 3 + R_COUNT, NULL, PETSC_REAL));
  if (header[H_MAGIC] != MSIM_CHECKPOINT_MAGIC) {
    PetscCall(PetscViewerDestroy(&v));
    SETERRQ(sys->comm, PETSC_ERR_FILE_UNEXPECTED, "-msim_restart %s: not an msim checkpoint", F);
  }
  if (header[H_VERSION] != MSIM_CHECKPOINT_VERSION) {
    PetscCall(PetscViewerDestroy(&v));
    SETERRQ(sys->comm, PETSC_ERR_FILE_UNEXPECTED, "-msim_restart %s: checkpoint format version %" PetscInt_FMT "; this msim reads version %" PetscInt_FMT, F, header[H_VERSION], MSIM_CHECKPOINT_VERSION);
  }
  /* counts no larger than the file keep the size below from overflowing */
  bool sane = true;
  for (PetscInt k : {H_IDENT, H_NV, H_NHIST, H_INTEG, H_SOLVER, H_SREAL, H_SVEC, H_SHELLS, H_NSIDE}) sane = sane && header[k] >= 0 && header[k] <= size;
  const long long expect = sane ? head + (long long)header[H_IDENT] + (long long)header[H_INTEG] + (long long)header[H_SOLVER] + (long long)header[H_SREAL] * (long long)sizeof(PetscReal) + (long long)header[H_SHELLS] +
                                    (2 + (long long)header[H_NHIST] + (long long)header[H_SVEC] + (long long)header[H_NSIDE]) * (2 * (long long)sizeof(PetscInt) + 3 * (long long)header[H_NV] * (long long)sizeof(PetscScalar))
                                : -1;
  if (!sane || size != expect) {
    PetscCall(PetscViewerDestroy(&v));
    SETERRQ(sys->comm, PETSC_ERR_FILE_UNEXPECTED, "-msim_restart %s: damaged checkpoint (%lld bytes, its header says %lld)", F, size, expect);
  }
  std::string there((size_t)header[H_IDENT], '\0');
  if (header[H_IDENT]) PetscCall(PetscViewerBinaryRead(v, &there[0], header[H_IDENT], NULL, PETSC_CHAR));
  const std::string diff = FirstDifference(there, ck->ident);
  if (!diff.empty() || header[H_NV] != sys->nv || header[H_NSPRING] != sys->nspring_global) {
    PetscCall(PetscViewerDestroy(&v));
    if (!diff.empty()) SETERRQ(sys->comm, PETSC_ERR_ARG_INCOMP, "-msim_restart %s: a checkpoint of another scene (%s)", F, diff.c_str());
    SETERRQ(sys->comm, PETSC_ERR_ARG_INCOMP, "-msim_restart %s: a checkpoint of another scene (%" PetscInt_FMT " vertices and %" PetscInt_FMT " moving springs there, %" PetscInt_FMT " and %" PetscInt_FMT " here)", F, header[H_NV], header[H_NSPRING], sys->nv, sys->nspring_global);
  }
  /* the same counts and options, the same rest state? Relative to the value (mass, length) or to
     the box's extent (its corners), 1e-12: rounding at another rank count stays far below */
  const PetscReal *rest   = ck->rest;
  PetscReal        extent = 0;
  for (int c = 0; c < 3; c++) extent = PetscMax(extent, rest[R_HI + c] - rest[R_LO + c]);
  for (int k = 0; k < R_COUNT; k++) {
    const PetscReal scale = k < R_LO ? PetscMax(PetscAbsReal(rest[k]), PetscAbsReal(reals[3 + k])) : extent;
    if (PetscAbsReal(rest[k] - reals[3 + k]) <= 1e-12 * scale) continue;
    const std::string lines = "\n" + ck->ident; /* the mesh file's line, if any, named */
    const size_t      at    = lines.find("\n-msim_mesh_file ");
    const std::string mesh  = at == std::string::npos ? "" : lines.substr(at + 1, lines.find('\n', at + 1) - at - 1) + ": ";
    PetscCall(PetscViewerDestroy(&v));
    SETERRQ(sys->comm, PETSC_ERR_ARG_INCOMP, "-msim_restart %s: a checkpoint of another scene (%sthe rest state differs: %s %.15g there, %.15g here)", F, mesh.c_str(), rest_name[k], (double)reals[3 + k], (double)rest[k]);
  }
  if (header[H_STEP] >= steps) {
    PetscCall(PetscViewerDestroy(&v));
    SETERRQ(sys->comm, PETSC_ERR_ARG_OUTOFRANGE, "-msim_restart %s: the checkpoint is at step %" PetscInt_FMT " and -msim_steps is %" PetscInt_FMT ": nothing left to run", F, header[H_STEP], steps);
  }
  /* the integrator's history goes back only to the integrator that wrote it, whole */
  PetscInt    nhist;
  Vec        *hist;
  const char *integ;
  std::string integ_there((size_t)header[H_INTEG], '\0');
  PetscCall(History(ck, &nhist, &hist, &integ));
  if (header[H_INTEG]) PetscCall(PetscViewerBinaryRead(v, &integ_there[0], header[H_INTEG], NULL, PETSC_CHAR));
  const PetscBool load_hist = (PetscBool)(nhist > 0 && header[H_NHIST] == nhist && integ_there == integ);
  /* the solver's state goes to the solver, which takes it if it would carry the same */
  SNES              snes;
  MSimSolverHistory solver;
  PetscCall(Solver(ck, &snes));
  solver.name.assign((size_t)header[H_SOLVER], '\0');
  solver.real.assign((size_t)header[H_SREAL], 0.0);
  if (header[H_SOLVER]) PetscCall(PetscViewerBinaryRead(v, &solver.name[0], header[H_SOLVER], NULL, PETSC_CHAR));
  if (header[H_SREAL]) PetscCall(PetscViewerBinaryRead(v, solver.real.data(), header[H_SREAL], NULL, PETSC_REAL));
  const PetscBool load_solver = (PetscBool)(snes && header[H_SOLVER] > 0);
  if (load_solver)
    for (PetscInt k = 0; k < header[H_SVEC]; k++) {
      solver.vec.push_back(NULL);
      PetscCall(VecDuplicate(X, &solver.vec.back()));
    }
  /* the shells' sides go back to the same shells, whole */
  std::vector<MSimMeshObstacle> shells;
  std::string                   shell_ident, shells_there((size_t)header[H_SHELLS], '\0');
  std::vector<Vec>              sides;
  PetscCall(Shells(ck, shells, shell_ident));
  if (header[H_SHELLS]) PetscCall(PetscViewerBinaryRead(v, &shells_there[0], header[H_SHELLS], NULL, PETSC_CHAR));
  const PetscBool load_sides = (PetscBool)(!shells.empty() && header[H_NSIDE] == 2 * (PetscInt)shells.size() && shells_there == shell_ident);
  if (!shells.empty() && !load_sides) PetscCall(PetscInfo(NULL, "-msim_restart %s: the checkpoint's shells are not this run's: every vertex starts with no side known\n", F));
  if (load_sides)
    for (PetscInt k = 0; k < header[H_NSIDE]; k++) {
      sides.push_back(NULL);
      PetscCall(VecDuplicate(X, &sides.back()));
    }
  /* the file's vectors in order; NULL: one to read past (another integrator's history) */
  std::vector<Vec> targets = {X, V};
  targets.insert(targets.end(), (size_t)header[H_NHIST], NULL);
  if (load_hist) std::copy(hist, hist + nhist, targets.begin() + 2);
  targets.insert(targets.end(), solver.vec.begin(), solver.vec.end());
  if (load_sides) targets.insert(targets.end(), sides.begin(), sides.end());
  else targets.insert(targets.end(), (size_t)header[H_NSIDE], NULL);
  /* a vector the file's size admits but VecLoad refuses still closes the file */
  PetscErrorCode load = PETSC_SUCCESS;
  PetscCall(MSimSystemNaturalSetUp(sys));
  for (Vec target : targets) {
    if ((load = VecLoad(sys->natural, v))) break;
    if (!target) continue;
    PetscCall(VecScatterBegin(sys->to_natural, sys->natural, target, INSERT_VALUES, SCATTER_REVERSE));
    PetscCall(VecScatterEnd(sys->to_natural, sys->natural, target, INSERT_VALUES, SCATTER_REVERSE));
  }
  PetscCall(PetscViewerDestroy(&v));
  if (!load && load_solver) {
    PetscBool taken;
    PetscCall(MSimSNESSetHistory(snes, &solver, &taken));
    if (!taken) PetscCall(PetscInfo(NULL, "-msim_restart %s: the checkpoint's %s state is not this solver's: it starts afresh\n", F, solver.name.c_str()));
  }
  for (Vec &w : solver.vec) PetscCall(VecDestroy(&w));
  if (!load)
    for (size_t k = 0; k < sides.size(); k += 2) {
      const PetscScalar *a[2];
      PetscCall(VecGetArrayRead(sides[k], &a[0]));
      PetscCall(VecGetArrayRead(sides[k + 1], &a[1]));
      MSimMeshObstacleSetSides(shells[k / 2], sys->nown, a[0], a[1]);
      PetscCall(VecRestoreArrayRead(sides[k], &a[0]));
      PetscCall(VecRestoreArrayRead(sides[k + 1], &a[1]));
    }
  for (Vec &w : sides) PetscCall(VecDestroy(&w));
  PetscCall(load);
  if (snes) {
    PetscBool complete;
    PetscCall(MSimSNESHistoryIsComplete(snes, &complete));
    if (!complete) PetscCall(PetscFPrintf(sys->comm, PETSC_STDERR, "msim: warning: -msim_restart with -snes_type qn: PETSc keeps qn's pairs from step to step where a checkpoint cannot reach them, so the restarted run is not bit for bit the uninterrupted one\n"));
  }
  if (ck->integ) ck->integ->restart_dt = reals[1]; /* a reader without an integrator (fuzz_checkpoint) has none */
  if (load_hist) PetscCall(ck->integ->ops.history_loaded(ck->integ));
  *step      = header[H_STEP];
  *t         = reals[0];
  *dt        = reals[1];
  *E0        = reals[2];
  *restarted = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCheckpointRestartState(MSimCheckpoint ck, PetscInt step, PetscReal t, char buf[], size_t len)
{
  PetscFunctionBeginUser;
  PetscCall(PetscSNPrintf(buf, len, "the checkpoint's state (-msim_restart %s: step %" PetscInt_FMT ", t = %g s)", ck->restart, step, (double)t));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* for a message after an interrupted run: what was kept and how to go on */
PetscErrorCode MSimCheckpointPath(MSimCheckpoint ck, char buf[], size_t len)
{
  PetscFunctionBeginUser;
  if (ck->path[0]) PetscCall(PetscSNPrintf(buf, len, "state saved in %s: continue with -msim_restart %s", ck->path, ck->path));
  else PetscCall(PetscSNPrintf(buf, len, "no checkpoint asked for (-msim_checkpoint F would keep the state)"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimCheckpointDestroy(MSimCheckpoint *ck)
{
  PetscFunctionBeginUser;
  delete *ck;
  *ck = NULL;
  PetscFunctionReturn(PETSC_SUCCESS);
}
