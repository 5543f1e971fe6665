/* msim's own numeric options, read through PETSc's options database but checked first: every
   comma-separated item must be a whole number (an integer that fits PetscInt for integer options,
   a finite real otherwise), so "-msim_dt inf", "-msim_steps 99999999999999999999" or
   "-msim_wind a,b,c" are errors that name the option, raised once on the options' communicator
   (PETSc's own conversion would accept inf and nan, wrap an overflowing integer round to a
   negative number, and name only the value, once per rank). */
#include <msim/options.h>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <string>

/* PETSc's named values (PETSC_DEFAULT, DECIDE, ...): left to PETSc */
static bool IsPetscKeyword(const std::string &t)
{
  for (const char *k : {"PETSC_DEFAULT", "DEFAULT", "PETSC_DECIDE", "DECIDE", "PETSC_DETERMINE", "DETERMINE", "PETSC_UNLIMITED", "UNLIMITED"})
    if (!strcasecmp(t.c_str(), k)) return true;
  return false;
}

/* "" if t is an integer that fits PetscInt, else why not */
static std::string IntegerFault(const std::string &t)
{
  char *end = NULL;
  errno     = 0;
  long long v = strtoll(t.c_str(), &end, 10);
  if (t.empty() || *end) return "is not an integer";
  if (errno == ERANGE || v > PETSC_MAX_INT || v < PETSC_MIN_INT) return "is too large (at most " + std::to_string((long long)PETSC_MAX_INT) + ")";
  return "";
}

static PetscErrorCode MSimOptionsCheck(PetscOptionItems *PetscOptionsObject, const char name[], PetscBool integer, PetscBool list)
{
  const char *value = NULL;
  PetscBool   set   = PETSC_FALSE;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsFindPair(PetscOptionsObject->options, PetscOptionsObject->prefix, name, &value, &set));
  if (!set) PetscFunctionReturn(PETSC_SUCCESS);
  const MPI_Comm    comm = PetscOptionsObject->comm;
  /* the name as typed: with the options block's prefix (-pd_pc_msimllt_relax, not -pc_...) */
  const std::string typed = "-" + std::string(PetscOptionsObject->prefix ? PetscOptionsObject->prefix : "") + (name + 1);
  /* PETSc leaves a numeric option given without a value unset, silently: "-snes_pd_anderson" alone
     ran plain PD in the examples that meant Anderson */
  PetscCheck(value && value[0], comm, PETSC_ERR_ARG_WRONG, "%s needs a value (%s)", typed.c_str(), integer ? (list ? "comma-separated integers" : "an integer") : (list ? "comma-separated numbers" : "a number"));
  const std::string all(value);
  size_t            at = 0;
  while (true) {
    const size_t      comma = list ? all.find(',', at) : std::string::npos;
    const std::string t     = all.substr(at, comma == std::string::npos ? std::string::npos : comma - at);
    if (!IsPetscKeyword(t)) {
      if (integer) {
        /* integer lists take ranges a-b as PETSc does */
        const size_t dash  = list ? t.find('-', 1) : std::string::npos;
        std::string  fault = IntegerFault(dash == std::string::npos ? t : t.substr(0, dash));
        if (fault.empty() && dash != std::string::npos) fault = IntegerFault(t.substr(dash + 1));
        PetscCheck(fault.empty(), comm, PETSC_ERR_ARG_OUTOFRANGE, "%s: '%s' %s", typed.c_str(), t.c_str(), fault.c_str());
      } else {
        char *end = NULL;
        double v  = t.empty() ? 0 : strtod(t.c_str(), &end);
        PetscCheck(!t.empty() && !*end, comm, PETSC_ERR_ARG_WRONG, "%s: '%s' is not a number", typed.c_str(), t.c_str());
        PetscCheck(std::isfinite(v), comm, PETSC_ERR_ARG_OUTOFRANGE, "%s: '%s' is not a finite number", typed.c_str(), t.c_str());
      }
    }
    if (comma == std::string::npos) break;
    at = comma + 1;
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsReal_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], const char man[], PetscReal current, PetscReal *value, PetscBool *set)
{
  PetscFunctionBeginUser;
  PetscCall(MSimOptionsCheck(PetscOptionsObject, name, PETSC_FALSE, PETSC_FALSE));
  PetscCall(PetscOptionsReal_Private(PetscOptionsObject, name, help, man, current, value, set));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsInt_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], const char man[], PetscInt current, PetscInt *value, PetscBool *set)
{
  PetscFunctionBeginUser;
  PetscCall(MSimOptionsCheck(PetscOptionsObject, name, PETSC_TRUE, PETSC_FALSE));
  PetscCall(PetscOptionsInt_Private(PetscOptionsObject, name, help, man, current, value, set, PETSC_MIN_INT, PETSC_MAX_INT));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsRealArray_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], const char man[], PetscReal value[], PetscInt *n, PetscBool *set)
{
  PetscFunctionBeginUser;
  PetscCall(MSimOptionsCheck(PetscOptionsObject, name, PETSC_FALSE, PETSC_TRUE));
  PetscCall(PetscOptionsRealArray_Private(PetscOptionsObject, name, help, man, value, n, set));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsIntArray_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], const char man[], PetscInt value[], PetscInt *n, PetscBool *set)
{
  PetscFunctionBeginUser;
  PetscCall(MSimOptionsCheck(PetscOptionsObject, name, PETSC_TRUE, PETSC_TRUE));
  PetscCall(PetscOptionsIntArray_Private(PetscOptionsObject, name, help, man, value, n, set));
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsVec3_Private(PetscOptionItems *PetscOptionsObject, const char name[], const char help[], PetscReal v[3], PetscBool *set)
{
  PetscInt  n    = 4; /* one more than needed: PETSc drops values past n silently (-msim_gravity 0,0,-9.81,1 ran) */
  PetscReal w[4] = {v[0], v[1], v[2], 0};
  PetscBool flg;

  PetscFunctionBeginUser;
  PetscCall(MSimOptionsRealArray(name, help, NULL, w, &n, &flg));
  PetscCheck(!flg || n == 3, PetscOptionsObject->comm, PETSC_ERR_ARG_WRONG, "%s needs three comma-separated numbers x,y,z (got %" PetscInt_FMT "%s)", name, n, n > 3 ? " or more" : "");
  for (int c = 0; c < 3; c++) v[c] = w[c];
  if (set) *set = flg;
  PetscFunctionReturn(PETSC_SUCCESS);
}

PetscErrorCode MSimOptionsRefuseWithout(MPI_Comm comm, const char parent[], PetscInt n, const char *const names[], const PetscBool set[])
{
  PetscBool given;

  PetscFunctionBeginUser;
  PetscCall(PetscOptionsHasName(NULL, NULL, parent, &given));
  for (PetscInt k = 0; k < n; k++) PetscCheck(given || !set[k], comm, PETSC_ERR_ARG_WRONG, "%s has no effect without %s", names[k], parent);
  PetscFunctionReturn(PETSC_SUCCESS);
}
