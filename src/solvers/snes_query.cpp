/* What a SNES type needs, asked of the SNES rather than read off its type name. */
#include <petsc/private/snesimpl.h>
#include <msim/solvers.h>
#include <cstring>
#include <string>
#include <vector>

/* PETSc sets usesksp per type (qn turns it on with -snes_qn_scale_type jacobian); SNESView reads
   it to decide whether to print linear iterations. No public accessor in 3.18. */
PetscErrorCode MSimSNESUsesJacobian(SNES snes, PetscBool *uses)
{
  PetscFunctionBeginUser;
  *uses = snes->usesksp;
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* A type's own options, -snes_<type>_* (PETSc's -snes_qn_m, -snes_anderson_m, ...; msim's
   -snes_pd_fixed, -snes_ntr_eta, ...), are read only by a solver of that type: given for a solver
   of another type, or under -npc_ where the run has no nonlinear preconditioner, nothing read
   them and the run went on without them (-snes_pd_fixed with newtonls: the same steps, and a
   warning at the end). Refused in one line naming the option and the solver's type. solvers are
   the run's SNESes (the SNES, composite's, the nonlinear preconditioner) and what[k] the option
   choosing a composite's solvers[k]'s type. An option of the solver's own type left unread is a misspelling,
   for the unused-options warning. */
static PetscErrorCode CheckTypeOptions(SNES snes, const std::vector<SNES> &solvers, const std::vector<const char *> &what, PetscBool has_npc)
{
  MPI_Comm    comm = PetscObjectComm((PetscObject)snes);
  const char *prefix;
  PetscInt    n;
  char      **names, **values;

  PetscFunctionBeginUser;
  PetscCall(SNESGetOptionsPrefix(snes, &prefix));
  const std::string npc_prefix = std::string(prefix ? prefix : "") + "npc_";
  PetscCall(PetscOptionsLeftGet(((PetscObject)snes)->options, &n, &names, &values));
  std::string bad;
  for (PetscInt i = 0; i < n && bad.empty(); i++) {
    const std::string name = names[i][0] == '-' ? names[i] + 1 : names[i];
    /* the solver whose prefix the option has: k, or solvers.size() for the absent -npc_ one */
    for (size_t k = 0; k <= solvers.size() && bad.empty(); k++) {
      const char *p = NULL;
      if (k < solvers.size()) PetscCall(SNESGetOptionsPrefix(solvers[k], &p));
      else if (has_npc) break;
      const std::string head = (k < solvers.size() ? std::string(p ? p : "") : npc_prefix) + "snes_";
      if (name.compare(0, head.size(), head)) continue;
      const size_t end = name.find('_', head.size());
      if (end == std::string::npos) continue;
      const std::string owner = name.substr(head.size(), end - head.size());
      void (*create)(void);
      PetscCall(PetscFunctionListFind(SNESList, owner.c_str(), &create));
      if (!create) continue; /* -snes_linesearch_*, -snes_ksp_ew_*, ...: not a type's */
      if (k == solvers.size()) {
        bad = "-" + name + " is not supported without a nonlinear preconditioner: it is -npc_snes_type " + owner + "'s option, and the run has none (-npc_snes_type " + owner + ")";
        break;
      }
      PetscBool same;
      SNESType  t;
      PetscCall(PetscObjectTypeCompare((PetscObject)solvers[k], owner.c_str(), &same));
      if (same) continue;
      PetscCall(SNESGetType(solvers[k], &t));
      const std::string chooser = k == 0 ? "-" + std::string(prefix ? prefix : "") + "snes_type" : has_npc && k + 1 == solvers.size() ? "-" + npc_prefix + "snes_type" : what[k];
      bad = "-" + name + " with " + chooser + " " + t + " is not supported: only the type " + owner + " reads it";
      /* the nonlinear preconditioner's options take its prefix */
      if (has_npc && k == 0) {
        PetscBool npc_same;
        PetscCall(PetscObjectTypeCompare((PetscObject)solvers.back(), owner.c_str(), &npc_same));
        if (npc_same) bad += " (the nonlinear preconditioner's take its prefix: -" + npc_prefix + name.substr(prefix ? strlen(prefix) : 0) + ")";
      }
    }
  }
  PetscCall(PetscOptionsLeftRestore(((PetscObject)snes)->options, &n, &names, &values));
  PetscCheck(bad.empty(), comm, PETSC_ERR_SUP, "%s", bad.c_str());
  PetscFunctionReturn(PETSC_SUCCESS);
}

/* The types msim's problems cannot serve, a -npc_snes_type the type would not run and the
   options of a type the run does not use (CheckTypeOptions): said in one line at set-up, before
   any output, where PETSc would stop at the first solve in its own words or ignore the option
   without a word. */
PetscErrorCode MSimSNESCheckServed(SNES snes)
{
  MPI_Comm           comm = PetscObjectComm((PetscObject)snes);
  PetscBool          has_npc, unserved, composite;
  SNESType           type, npc_type;
  SNES               npc;
  PetscInt           nsub = 0;
  std::vector<SNES>  solvers = {snes};
  std::vector<const char *> what = {"-snes_type"};

  PetscFunctionBeginUser;
  PetscCall(SNESGetType(snes, &type));
  PetscCall(SNESHasNPC(snes, &has_npc));
  PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESCOMPOSITE, &composite));
  if (composite) {
    PetscCall(SNESCompositeGetNumber(snes, &nsub));
    PetscCheck(nsub > 0, comm, PETSC_ERR_ARG_WRONG, "-snes_type composite needs its solvers: -snes_composite_sneses pd,newtonls (for example)");
    for (PetscInt k = 0; k < nsub; k++) {
      solvers.push_back(NULL);
      PetscCall(SNESCompositeGetSNES(snes, k, &solvers.back()));
      what.push_back("-snes_composite_sneses's");
    }
  }
  /* aspin makes itself newtonls with nasm as its preconditioner, so the preconditioner is asked
     too */
  if (has_npc) {
    solvers.push_back(NULL);
    PetscCall(SNESGetNPC(snes, &solvers.back()));
    what.push_back("the nonlinear preconditioner's type (-npc_snes_type, or -snes_type aspin's)");
  }
  /* they need what msim's problem (a DMShell, one Jacobian) does not give: a greedy coloring of
     an AIJ matrix, subdomains, a DMPlex, a solve set by code */
  for (size_t k = 0; k < solvers.size(); k++) {
    SNESType t;
    PetscCall(PetscObjectTypeCompareAny((PetscObject)solvers[k], &unserved, SNESNGS, SNESNASM, SNESASPIN, SNESPATCH, SNESSHELL, ""));
    PetscCall(SNESGetType(solvers[k], &t));
    PetscCheck(!unserved, comm, PETSC_ERR_SUP, "%s %s is not supported: it needs %s, which msim's problem does not provide (msim serves newtonls, ntr, pd, qn, anderson, ngmres, ncg, nrichardson, ms, composite, ksponly and the VI types)", what[k], t,
               !strcmp(t, SNESNGS) ? "a coloring of an AIJ Jacobian" : !strcmp(t, SNESPATCH) ? "a DMPlex" : !strcmp(t, SNESSHELL) ? "a solve set by code" : "subdomains of a DM");
  }
  /* newtonls preconditioned on the left solves for x - npc(x) = 0, whose Jacobian msim does not
     assemble: with the springs' Hessian its linear solves failed at the first step */
  if (has_npc) {
    PCSide    side;
    PetscBool newtonls;
    PetscCall(SNESGetNPCSide(snes, &side));
    PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESNEWTONLS, &newtonls));
    PetscCheck(!(newtonls && side == PC_LEFT), comm, PETSC_ERR_SUP, "-snes_npc_side left with -snes_type newtonls is not supported: it solves x - npc(x) = 0, whose Jacobian msim does not assemble; use the right side (the default)");
  }
  PetscCall(CheckTypeOptions(snes, solvers, what, has_npc));
  /* PETSc makes -npc_snes_type's solver for any type, and each type decides by usesnpc (no public
     accessor in 3.18) whether its solve calls it: pd, ntr, ksponly and the VI types do not */
  if (has_npc && !snes->usesnpc) {
    PetscCall(SNESGetNPC(snes, &npc));
    PetscCall(SNESGetType(npc, &npc_type));
    SETERRQ(comm, PETSC_ERR_SUP, "-npc_snes_type %s with -snes_type %s is not supported: %s runs no nonlinear preconditioner (newtonls, qn, ncg, nrichardson, anderson and ngmres do)", npc_type, type, type);
  }
  /* msim hands its analytic Jacobian to the outer SNES alone: a sub-solver that solves linear
     systems (composite's newtonls, anderson's or ngmres's -npc_snes_type newtonls, fas's smoother)
     got PETSc's default, a dense finite-difference Jacobian built one column at a time (-snes_view
     said so: seqdense), which msim never builds unasked */
  for (size_t k = 1; k < solvers.size(); k++) {
    PetscBool uses;
    SNESType  t;
    PetscCall(MSimSNESUsesJacobian(solvers[k], &uses));
    PetscCall(SNESGetType(solvers[k], &t));
    PetscCheck(!uses, comm, PETSC_ERR_SUP, "%s %s is not supported: msim gives its analytic Jacobian to the outer solver only, and PETSc would build this one by finite differences, dense; use -snes_type %s itself, or pd as the inner solver", what[k], t, t);
  }
  {
    PetscBool fas;
    PetscCall(PetscObjectTypeCompare((PetscObject)snes, SNESFAS, &fas));
    PetscCheck(!fas, comm, PETSC_ERR_SUP, "-snes_type fas is not supported: msim's problem has one level (no grid hierarchy), and its smoother would get a dense finite-difference Jacobian; use newtonls");
  }
  PetscFunctionReturn(PETSC_SUCCESS);
}
