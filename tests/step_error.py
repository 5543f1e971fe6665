#!/usr/bin/env python3
"""A step that fails with a PETSc error (here -ksp_error_if_not_converged) ends the run with one
error line and leaves no reduction of the stop poll (msim/signals.h) pending: every way out of the
time loop ends the poll, waiting for the MPI_Iallreduce it started at the solver's last iteration
and restoring the SIGINT/SIGTERM handlers. An interposer (tests/mpi_pending.c, LD_PRELOAD) counts
the requests each rank leaves pending at MPI_Finalize: 2 on each rank at 2 ranks before (the
in-step poll's and the after-step poll's, started and never completed), none now. At 1 rank the
poll has no reduction; the check holds there as well.
Usage: step_error.py path/to/msim path/to/libmsim_mpi_pending.so --np N"""
import re
import subprocess
import sys

import msimtest as mt

MSIM = mt.msim_path()
SHIM = sys.argv[2]
NP = mt.ranks()[0]
check = mt.Checks()
# an implicit cloth whose linear solves stop at 1 iteration: step 1's converges in it, step 2's
# falls short of its tolerance and KSPSolve errors out, after the after-step poll of step 1 and the
# in-step poll at step 2's first Newton iteration each started a reduction
ARGS = ["-msim_cloth_n", "8", "-msim_integrator", "implicit_euler", "-msim_steps", "3",
        "-ksp_max_it", "1", "-ksp_rtol", "1e-14", "-ksp_error_if_not_converged"]


def main():
    env = dict(mt.RUN_ENV)
    if NP == 1:
        env["LD_PRELOAD"] = SHIM
        cmd = [MSIM] + ARGS
    else:  # the ranks only: mpirun is no MPI program
        cmd = mt.mpirun(NP) + ["-x", "LD_PRELOAD=" + SHIM, MSIM] + ARGS
    r = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=120)
    lines = mt.lines(r.stderr)
    counts = {}
    for l in lines:
        m = re.match(r"mpi_pending: rank (\d+): (\d+) MPI_Iallreduce pending at MPI_Finalize$", l)
        if m:
            counts[int(m.group(1))] = int(m.group(2))
    errors = [l for l in lines if not l.startswith("mpi_pending: ")]
    check(r.returncode != 0 and len(errors) == 1 and "KSPSolve has not converged" in errors[0],
          f"np={NP}: the failed step ends the run with one error line, exit {r.returncode} ({errors[:3]})")
    check(sorted(counts) == list(range(NP)), f"np={NP}: every rank reached MPI_Finalize with the interposer loaded ({counts})")
    check(counts and all(c == 0 for c in counts.values()), f"np={NP}: no MPI_Iallreduce pending at MPI_Finalize on any rank ({counts})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
