#!/usr/bin/env python3
"""The command line as a user meets it, at 1 rank (a singleton: standard output is msim's own):
- `msim -help`'s first line names what msim simulates today (it said "cloth, chains" alone);
- standard output closed by its reader (`msim -msim_monitor | head -1`): the run stops after the
  step quietly, exit status 141 (was PETSc's "Caught signal number 13 Broken Pipe" trace and Open
  MPI's abort lines, exit 59), the checkpoint asked for written, and a restart from it runs on;
- -msim_view_final into a directory that is not there, or under a file: refused before any step
  in one line naming the option (failed after the whole run, naming none);
- -msim_view lists the energy terms that act (it listed every registered one: drag, obstacles,
  friction, self-contact and volume for a cloth with none of them) and names PD's global solve,
  which msim chooses by the scene's size, and counts its PC's set-ups as factorizations only where
  it factors;
- -log_view names every stage it prints (those no rank pushed printed as "Unknown") and has the
  run's frames, the first one's too, in Stepping, none in the main stage (the first frame and the
  run's set-up were there), and the system's setup event (MSimSetup) in Setup, where it ran in the
  main stage until the stage was pushed before the event began;
- a friction lag's unconverged steps are reported with the user's -snes_atol, not the lag solves'."""
import os
import subprocess
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()


def main():
    check = mt.Checks()
    r = mt.run(MSIM, ["-help"])
    first = r.stdout.splitlines()[0] if r.stdout else ""
    check(r.returncode == 0 and all(w in first for w in ("surfaces", "tet solids", "obstacles", "self-contact", "PETSc TS")),
          f"-help's first line describes msim: {first!r}")
    with tempfile.TemporaryDirectory() as tmp:
        ck = os.path.join(tmp, "chain.ck")
        # 20000 monitor lines (2.7 MB) fill any pipe's buffer: msim is still stepping when the reader leaves
        args = ["-msim_scene", "chain", "-msim_steps", "20000"]
        p = mt.popen(MSIM, args + ["-msim_monitor", "-msim_checkpoint", ck], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        line = p.stdout.readline()
        p.stdout.close()
        err = p.stderr.read().decode()
        rc = p.wait()
        check(line.startswith(b"step      0 ") and rc == 141 and err == "" and os.path.exists(ck),
              f"standard output closed after one line: exit {rc} (141), nothing on stderr ({err[-300:]!r}), the checkpoint written")
        r = mt.run(MSIM, args + ["-msim_restart", ck])
        check(r.returncode == 0 and r.stderr.strip() == "", f"the restart from it runs to the end (exit {r.returncode}, {r.stderr.strip()[-200:]!r})")
        open(os.path.join(tmp, "afile"), "w").close()
        for where, why in (("nodir/x.bin", "No such file or directory"), ("afile/x.bin", "Not a directory")):
            r = mt.run(MSIM, ["-msim_scene", "chain", "-msim_steps", "3", "-msim_monitor", "-msim_view_final", "binary:" + where], cwd=tmp)
            lines = mt.lines(r.stderr)
            check(r.returncode != 0 and r.stdout == "" and lines == [f"msim: error: -msim_view_final binary:{where}: cannot write in {where.split('/')[0]} ({why})"],
                  f"-msim_view_final binary:{where}: refused before the first step in one line ({lines!r}, stdout {r.stdout[:80]!r})")
    implicit = ["-msim_cloth_n", "5", "-msim_integrator", "implicit_euler", "-msim_steps", "1", "-msim_view"]
    for extra, terms, solve in ((["-msim_drag", "0.1"], "springs, drag", None),
                                (["-msim_contact_plane", "0,0,1,-0.1", "-snes_type", "pd"], "springs, obstacles", "-pd_ksp_type preonly -pd_pc_type msimllt")):
        r = mt.run(MSIM, implicit + extra)
        got = [l.strip() for l in r.stdout.splitlines() if "energy terms:" in l or "global solve:" in l]
        want = [f"implicit problem: scheme implicit_euler (beta 1.), energy terms: {terms}"] + ([f"projective dynamics' global solve: {solve}"] if solve else [])
        check(r.returncode == 0 and got == want, f"-msim_view with {' '.join(extra)}: {got!r}")
    # PD's count of its global solve's set-ups: factorizations where the PC factors, not where a
    # multigrid sets up (it said "1 numeric factorization(s)" of CG + GAMG, which factors nothing)
    for extra, want in (([], "projective dynamics: 1 numeric factorization(s) of the 25 x 25 PD matrix"),
                        (["-pd_ksp_type", "cg", "-pd_pc_type", "gamg"], "projective dynamics: 1 set-up(s) of the global solve's -pd_pc_type gamg on the 25 x 25 PD matrix (no factorization)")):
        r = mt.run(MSIM, implicit + ["-msim_fix", "none", "-snes_type", "pd"] + extra)
        got = [l.strip() for l in r.stdout.splitlines() if l.strip().startswith("projective dynamics:")]
        check(r.returncode == 0 and got == [want], f"-msim_view with pd {' '.join(extra)}: {got!r}")
    # a friction lag's solves run to their own atol (the first solve's max(atol, rtol |g0|), here
    # 4.3e-11): the unconverged steps' warning names the user's -snes_atol, not the lag's
    r = mt.run(MSIM, ["-msim_cloth_n", "5", "-msim_cloth_size", "0.2", "-msim_fix", "none", "-msim_integrator", "implicit_euler",
                      "-msim_gravity", "2.899,0,-9.372", "-msim_contact_plane", "0,0,1,-0.004", "-msim_friction", "0.4", "-msim_dt", "0.02",
                      "-msim_steps", "20", "-msim_friction_lag_iterations", "10", "-snes_max_it", "3", "-snes_atol", "2e-11"])
    warned = [l for l in mt.lines(r.stderr) if "stopped at -snes_max_it 3" in l]
    check(r.returncode == 0 and len(warned) == 1 and "before |g| <= max(2e-11, 1e-08 |g0|)" in warned[0],
          f"friction lag with -snes_max_it 3 -snes_atol 2e-11: the warning names the user's tolerances ({warned!r})")
    with tempfile.TemporaryDirectory() as tmp:
        r = mt.run(MSIM, ["-msim_cloth_n", "5", "-msim_steps", "4", "-msim_output", os.path.join(tmp, "out"), "-msim_output_every", "2", "-log_view"])
        stages, events, stage = [], {}, None
        for l in r.stdout.splitlines():
            if l.startswith("--- Event Stage "):
                stage = l.split(": ", 1)[1].strip()
                stages.append(stage)
            elif stage and l.split()[:1] in (["MSimOutput"], ["MSimSetup"]):
                events.setdefault((l.split()[0], stage), 0)
                events[(l.split()[0], stage)] += int(l.split()[1])
        check(r.returncode == 0 and stages and "Unknown" not in stages and events == {("MSimOutput", "Stepping"): 3, ("MSimSetup", "Setup"): 1},
              f"-log_view: stages {sorted(set(stages))}, MSimOutput's and MSimSetup's counts by stage {events} (the 3 frames, in Stepping; the one setup, in Setup)")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
