/* Per-step monitors: a fixed-format line on rank 0 (no timings, so runs can be diffed) and a CSV
   with wall time. Energies: kinetic, potential (springs, the tets' volume term, gravity), total
   (their sum, the energy the divergence test compares); the CSV adds the obstacles' contact
   energy, which potential leaves out (msim/contact_force.h). */
#include <msim/output.h>
#include <msim/errors.h>
#include <msim/log.h>
#include <msim/private/systemimpl.h>
#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>
#include <unistd.h>

/* a step's line and row, formatted and written: -log_view shows them next to MSimEnergy (the
   monitored energies) */
static PetscLogEvent MSIM_Monitor = -1;

static const char header[] = "step,t,kinetic,potential,total,nonlinear_its,linear_its,residual,phi,contact_fx,contact_fy,contact_fz,contact_n,contact_energy,wall_s";

PetscErrorCode MSimMonitorCreate(MPI_Comm comm, MSimMonitor *mon)
{
  PetscFunctionBeginUser;
  if (MSIM_Monitor < 0) PetscCall(PetscLogEventRegister("MSimMonitor", MSIM_CLASSID, &MSIM_Monitor));
  mon->ascii       = PETSC_FALSE;
  mon->csv         = NULL;
  mon->csv_path[0] = 0;
  PetscOptionsBegin(comm, NULL, "msim monitors", NULL);
  PetscCall(PetscOptionsBool("-msim_monitor", "Print one line per step: energies, iterations, residual", NULL, mon->ascii, &mon->ascii, NULL));
  PetscCall(PetscOptionsString("-msim_monitor_csv", "Write a CSV per step: step,t,kinetic,potential,total,nonlinear_its,linear_its,residual,phi,contact_fx,contact_fy,contact_fz,contact_n,contact_energy,wall_s. potential: the springs', the tets' volume term's and gravity's energy, and total = kinetic + potential (what the divergence test compares), without the contact barriers; contact_energy: the obstacles' barrier (implicit) or penalty (explicit, ts) energy", NULL, mon->csv_path, mon->csv_path, sizeof(mon->csv_path), NULL));
  PetscOptionsEnd();
  PetscCall(PetscTime(&mon->wall0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Opens the CSV; collective, so a file that cannot be written is an error on every rank. Rows are
   written and flushed as they are made, so a run that is killed keeps every step before its last
   (at most the line being written is cut). */
PetscErrorCode MSimMonitorSetUp(MPI_Comm comm, MSimMonitor *mon, PetscInt resume_step, PetscReal resume_t)
{
  PetscMPIInt rank;
  int         ok    = 1;
  PetscReal   row_t = 0;

  PetscFunctionBeginUser;
  if (!mon->csv_path[0]) PetscFunctionReturn(PETSC_SUCCESS);
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    /* a restarted run keeps the rows up to its checkpoint and goes on from there, if they are the
       checkpoint's run's: a file another run wrote (another scene, another step size) is left
       as it is and the run refused, not spliced onto; so is a file whose header has other columns
       (an older msim's, before contact_energy), which rows of this layout would not fit */
    PetscBool kept = PETSC_FALSE, foreign = PETSC_FALSE;
    FILE     *old  = resume_step >= 0 ? fopen(mon->csv_path, "r") : NULL;
    if (old) {
      char line[4096]; /* a header cut short (no newline) is MSimCSVKeepSteps's: written anew */
      if (fgets(line, sizeof(line), old) && strchr(line, '\n') && (strncmp(line, header, sizeof(header) - 1) || line[sizeof(header) - 1] != '\n')) ok = -2;
      fclose(old);
    }
    if (ok != -2 && resume_step >= 0) PetscCall(MSimCSVKeepSteps(mon->csv_path, resume_step, &resume_t, &kept, &foreign, &row_t));
    if (foreign) ok = -1;
    else if (ok != -2) {
      mon->csv = fopen(mon->csv_path, kept ? "a" : "w");
      if (mon->csv && !kept) ok = fprintf(mon->csv, "%s\n", header) > 0 && fflush(mon->csv) == 0;
      else ok = mon->csv != NULL;
    }
  }
  PetscCallMPI(MPI_Bcast(&ok, 1, MPI_INT, 0, comm));
  PetscCallMPI(MPI_Bcast(&row_t, 1, MPIU_REAL, 0, comm));
  PetscCheck(ok != -2, comm, PETSC_ERR_FILE_UNEXPECTED, "-msim_monitor_csv %s: its header is not this msim's columns (%s): name another file or remove it", mon->csv_path, header);
  PetscCheck(ok != -1 || !PetscIsNanReal(row_t), comm, PETSC_ERR_FILE_UNEXPECTED, "-msim_monitor_csv %s: another run's monitor (no row for the checkpoint's step %" PetscInt_FMT "): name another file or remove it", mon->csv_path, resume_step);
  PetscCheck(ok != -1, comm, PETSC_ERR_FILE_UNEXPECTED, "-msim_monitor_csv %s: another run's monitor (its step %" PetscInt_FMT " is at t = %g s, the checkpoint's at %g s): name another file or remove it", mon->csv_path, resume_step, (double)row_t, (double)resume_t);
  PetscCheck(ok, comm, PETSC_ERR_FILE_OPEN, "-msim_monitor_csv: cannot write %s", mon->csv_path);
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* Rank 0: PATH keeps its header and its rows whose first field (the step) is <= last; *kept:
   whether PATH existed with its header. With t_last, the rows must end with step `last` at time
   *t_last (the second field, to its printed 10 digits); otherwise *foreign is set, *row_t is that
   row's time (NaN: no row for step `last`) and PATH is left untouched. Rows come in step order, so the rows to drop are the
   file's tail: it is read backward from the end, as far as the last row to keep (a checkpoint's
   interval of rows, not a 10-hour run's whole history), and cut there with one ftruncate, which a
   kill either does whole or not at all. A row cut short by a kill, the last one, goes too. */
PetscErrorCode MSimCSVKeepSteps(const char path[], PetscInt last, const PetscReal *t_last, PetscBool *kept, PetscBool *foreign, PetscReal *row_t)
{
  FILE *fp = fopen(path, "r+b");
  char  head[4096];

  PetscFunctionBeginUser;
  *kept = PETSC_FALSE;
  if (foreign) *foreign = PETSC_FALSE;
  if (!fp) PetscFunctionReturn(PETSC_SUCCESS);
  const bool header = fgets(head, sizeof(head), fp) && head[0] && head[strlen(head) - 1] == '\n';
  const long first  = header ? ftell(fp) : -1;
  if (!header || first < 0 || fseek(fp, 0, SEEK_END) != 0) {
    fclose(fp); /* no complete header: the caller writes the file anew */
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const long  size = ftell(fp);
  std::string tail; /* the file's bytes [from, size) */
  long        from = size;
  bool        io   = size >= first;
  /* the byte at p (first <= p < size), reading further back in doubling chunks */
  auto at = [&](long p) -> char {
    while (io && p < from) {
      const long n = std::min(from - first, std::max(65536L, (long)tail.size()));
      std::string more((size_t)n, '\0');
      io   = fseek(fp, from - n, SEEK_SET) == 0 && fread(&more[0], 1, (size_t)n, fp) == (size_t)n;
      tail = more + tail;
      from -= n;
    }
    return io ? tail[(size_t)(p - from)] : '\n';
  };
  long      end = size; /* rows [first, end) stay */
  PetscBool at_last = PETSC_FALSE; /* the last row kept is step `last`'s */
  PetscReal t_row   = PETSC_MAX_REAL;
  while (end > first && at(end - 1) != '\n') end--; /* a row cut by a kill */
  while (end > first && io) {
    long start = end - 1;
    while (start > first && at(start - 1) != '\n') start--;
    std::string row;
    for (long p = start; p < end - 1 && row.size() < 64; p++) row += at(p);
    char      *stop;
    const long step = strtol(row.c_str(), &stop, 10);
    if (stop != row.c_str() && *stop == ',' && step <= last) {
      at_last = (PetscBool)(step == last);
      t_row   = strtod(stop + 1, NULL);
      break;
    }
    end = start;
  }
  if (t_last && io && !(at_last && PetscAbsReal(t_row - *t_last) <= 1e-9 * PetscAbsReal(*t_last))) {
    fclose(fp); /* not the checkpoint's run's rows: left as they are */
    *foreign = PETSC_TRUE;
    *row_t   = at_last ? t_row : NAN;
    PetscFunctionReturn(PETSC_SUCCESS);
  }
  const bool cut = io && (end == size || ftruncate(fileno(fp), end) == 0);
  fclose(fp);
  PetscCheck(cut, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: cannot drop the rows after step %" PetscInt_FMT " (%s)", path, last, strerror(errno));
  *kept = PETSC_TRUE;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMonitorWanted(MSimMonitor *mon, PetscBool *want)
{
  PetscFunctionBeginUser;
  *want = (PetscBool)(mon->ascii || mon->csv_path[0]);
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMonitorWrite(MPI_Comm comm, MSimMonitor *mon, PetscInt step, PetscReal t, PetscReal kinetic, PetscReal potential, PetscInt nl, PetscInt lin, PetscReal residual, PetscReal phi, const PetscReal contact[5])
{
  PetscLogDouble now;

  PetscFunctionBeginUser;
  PetscCall(PetscLogEventBegin(MSIM_Monitor, 0, 0, 0, 0));
  if (mon->ascii) PetscCall(PetscPrintf(comm, "step %6" PetscInt_FMT " t %.6e kinetic %.10e potential %.10e total %.10e nl %" PetscInt_FMT " lin %" PetscInt_FMT " residual %.4e phi %.10e\n", step, (double)t, (double)kinetic, (double)potential, (double)(kinetic + potential), nl, lin, (double)residual, (double)phi));
  /* the obstacles' total contact force and vertices in contact at the step's result
     (msim/contact_force.h; zeros without obstacles) */
  const PetscReal fc[3] = {contact ? contact[0] : 0, contact ? contact[1] : 0, contact ? contact[2] : 0};
  const PetscInt  nc    = contact ? (PetscInt)(contact[3] + 0.5) : 0;
  const PetscReal ec    = contact ? contact[4] : 0;
  PetscBool written = PETSC_TRUE;
  if (mon->csv) { /* rank 0's */
    PetscCall(PetscTime(&now));
    const int wrote = fprintf(mon->csv, "%" PetscInt_FMT ",%.9e,%.12e,%.12e,%.12e,%" PetscInt_FMT ",%" PetscInt_FMT ",%.6e,%.12e,%.9e,%.9e,%.9e,%" PetscInt_FMT ",%.12e,%.6f\n", step, (double)t, (double)kinetic, (double)potential, (double)(kinetic + potential), nl, lin, (double)residual, (double)phi, (double)fc[0], (double)fc[1], (double)fc[2], nc, (double)ec, now - mon->wall0);
    written = (PetscBool)(wrote > 0 && fflush(mon->csv) == 0);
  }
  /* a failed write (disk full) is an error on every rank: rank 0's alone left the others in the
     next step's collectives, waiting for ever */
  if (mon->csv_path[0]) PetscCall(MSimCollectiveCheck(comm, written, std::string("-msim_monitor_csv: write to ") + mon->csv_path + " failed"));
  PetscCall(PetscLogEventEnd(MSIM_Monitor, 0, 0, 0, 0));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimMonitorDestroy(MPI_Comm comm, MSimMonitor *mon)
{
  PetscFunctionBeginUser;
  PetscBool closed = PETSC_TRUE;
  if (mon->csv) closed = (PetscBool)(fclose(mon->csv) == 0); /* rank 0's */
  mon->csv = NULL;
  if (mon->csv_path[0]) PetscCall(MSimCollectiveCheck(comm, closed, std::string("-msim_monitor_csv: write to ") + mon->csv_path + " failed"));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimViewFinalCheckWritable(MSimSystem sys)
{
  char      value[PETSC_MAX_PATH_LEN], dir[PETSC_MAX_PATH_LEN] = ".";
  PetscBool set;
  int       err = 0;

  PetscFunctionBeginUser;
  /* the viewer opens its file only at the end: a directory that is not there failed after the
     whole run, naming no option. PETSc's form is TYPE[:FILE[:FORMAT[:MODE]]] */
  PetscCall(PetscOptionsGetString(NULL, NULL, "-msim_view_final", value, sizeof(value), &set));
  const char *file = set ? strchr(value, ':') : NULL;
  if (!file || !file[1] || file[1] == ':') PetscFunctionReturn(PETSC_SUCCESS); /* stdout, or the type's default name here */
  std::string path(file + 1);
  path = path.substr(0, path.find(':'));
  const size_t slash = path.rfind('/');
  if (slash != std::string::npos) PetscCall(PetscStrncpy(dir, slash ? path.substr(0, slash).c_str() : "/", sizeof(dir)));
  if (sys->rank == 0 && access((std::string(dir) + "/.").c_str(), W_OK | X_OK) != 0) err = errno; /* "/.": a file there is no directory */
  PetscCallMPI(MPI_Bcast(&err, 1, MPI_INT, 0, sys->comm));
  PetscCheck(!err, sys->comm, PETSC_ERR_FILE_OPEN, "-msim_view_final %s: cannot write in %s (%s)", value, dir, strerror(err));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimViewFinal(MSimSystem sys, PetscReal t, Vec X)
{
  PetscViewer            viewer;
  PetscViewerFormat      format;
  PetscBool              set;
  Vec                    P;

  PetscFunctionBeginUser;
  PetscOptionsBegin(sys->comm, NULL, "msim final state", NULL);
  PetscCall(PetscOptionsViewer("-msim_view_final", "Final positions x,y,z of every vertex (fixed ones included) in msim's vertex order, whatever the rank count: the input file's order less the nodes it drops, then those msim adds (TetGen, -msim_refine; the frames' file_id array maps them to the file's ids)", NULL, &viewer, &format, &set));
  PetscOptionsEnd();
  if (!set) PetscFunctionReturn(PETSC_SUCCESS);
  /* in input order, distributed by the scene's directory blocks: any size, any viewer (ASCII
     prints through rank 0 block by block; binary and HDF5 write in parallel) */
  PetscCall(MSimSystemNaturalPositions(sys, t, X));
  P = sys->natural;
  PetscCall(PetscViewerPushFormat(viewer, format));
  PetscCall(VecView(P, viewer));
  PetscCall(PetscViewerPopFormat(viewer));
  PetscCall(PetscViewerDestroy(&viewer));
  PetscFunctionReturn(PETSC_SUCCESS);
}
