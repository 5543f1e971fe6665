#!/usr/bin/env python3
"""How -msim_integrator ts reports what stopped it (an 8 x 8 cloth, h = 0.02):
- a fixed-step stage solve capped by -snes_max_it 1 fails, is retried at a quarter step, which a
  fixed-step TS keeps for the rest of the interval, and the run runs out of internal steps: the one
  error line names -snes_max_it 1 and says to raise it (it said "stage solves kept failing ...:
  lower -msim_dt");
- an adaptive beuler at -ts_atol 1e-4 warns of a -snes_atol above a hundredth of it (1e-2), in one
  line, as of a loose -snes_rtol (-snes_atol 1e-2 ran silently); -snes_atol 1e-7 says nothing;
- the failed step's line says where the TS stopped within it, the time its failure text reached
  (it said "at step 1 (t = 0.02 s)" after the TS reached 0.0015625 s);
- rk4 (ts's default) on a 10 x 10 cloth at 10 x its limit, checked every 10th step, stops at its
  last step, 5: the line says that steps 1 to 3 were not checked and step 4 was finite but past the
  bound, where it said "last finite state is step 0" alone; checked every step it names step 2;
- a fixed-step rosw with an obstacle warns (one line) that its linear stages meet a landing
  unresolved (a cloth dropped 5 cm on a plane diverged at h = 0.01); an adaptive one does not.
Usage: ts_failures.py path/to/msim [--np N]"""
import re
import sys

import msimtest as mt

MSIM = mt.msim_path()
CLOTH = ["-msim_cloth_n", "8", "-msim_dt", "0.02", "-msim_integrator", "ts"]


def main():
    check = mt.Checks()
    for np_ in mt.ranks():
        r = mt.run(MSIM, CLOTH + ["-msim_steps", "3", "-ts_type", "beuler", "-snes_max_it", "1"], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode != 0 and len(lines) == 1 and "stopped at -snes_max_it 1" in lines[0] and "raise -snes_max_it" in lines[0],
              f"np={np_}: a fixed-step run whose stage solves stop at -snes_max_it names it ({lines})")
        reached = re.search(r"reached t = (\S+) of 0.02,", lines[0]) if len(lines) == 1 else None
        stopped = re.search(r" at step 1 \(stopped at t = (\S+) s, within 0 -> 0.02 s\);", lines[0]) if len(lines) == 1 else None
        check(reached and stopped and reached.group(1) == stopped.group(1) and 0 < float(stopped.group(1)) < 0.02,
              f"np={np_}: the failed step's line says where within the step the TS stopped ({lines})")
        blowup = ["-msim_cloth_n", "10", "-msim_dt", "0.02", "-msim_integrator", "ts", "-msim_steps", "5"]
        r = mt.run(MSIM, blowup, np_)
        err = [l for l in mt.lines(r.stderr) if l.startswith("msim: error:")]
        check(r.returncode != 0 and len(err) == 1 and err[0].startswith("msim: error: diverged at step 5 ")
              and err[0].endswith("last state that passed the divergence test is step 0, kept as the last finite state (steps 1 to 3 not checked at -msim_divergence_check_every 10, step 4 finite but already past its energy bound)"),
              f"np={np_}: an unchecked blow-up says which steps were not checked ({err})")
        r = mt.run(MSIM, blowup + ["-msim_divergence_check_every", "1"], np_)
        err = [l for l in mt.lines(r.stderr) if l.startswith("msim: error:")]
        check(r.returncode != 0 and len(err) == 1 and err[0].startswith("msim: error: diverged at step 3 ") and err[0].endswith("last finite state is step 2"),
              f"np={np_}: checked every step, the same blow-up names step 2 ({err})")
        adaptive = CLOTH + ["-msim_steps", "2", "-ts_type", "beuler", "-ts_adapt_type", "basic", "-ts_atol", "1e-4"]
        r = mt.run(MSIM, adaptive + ["-snes_atol", "1e-2"], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode == 0 and len(lines) == 1 and lines[0].startswith("msim: warning: adaptive -ts_type beuler: the stage solves stop at |F| <= -snes_atol 0.01")
              and "lower -snes_atol" in lines[0], f"np={np_}: a loose -snes_atol under an adaptive TS is warned about ({lines})")
        r = mt.run(MSIM, adaptive + ["-snes_atol", "1e-7"], np_)
        check(r.returncode == 0 and not mt.lines(r.stderr), f"np={np_}: -snes_atol 1e-7 at -ts_atol 1e-4: no warning ({mt.lines(r.stderr)})")
        plane = CLOTH + ["-msim_steps", "1", "-msim_fix", "none", "-msim_contact_plane", "0,0,1,-0.05", "-ts_type", "rosw"]
        r = mt.run(MSIM, plane + ["-ts_adapt_type", "none"], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode == 0 and len(lines) == 1 and lines[0].startswith("msim: warning: -ts_type rosw with a fixed step and an obstacle"),
              f"np={np_}: a fixed-step rosw with an obstacle is warned about ({lines})")
        r = mt.run(MSIM, plane, np_)
        check(r.returncode == 0 and not mt.lines(r.stderr), f"np={np_}: an adaptive rosw with an obstacle: no warning ({mt.lines(r.stderr)})")
        # -ts_max_snes_failures -1 is PETSc's "unlimited", msim's own setting: accepted (any other
        # value is refused, bad_input.py)
        r = mt.run(MSIM, CLOTH + ["-msim_steps", "1", "-ts_type", "beuler", "-ts_max_snes_failures", "-1"], np_)
        check(r.returncode == 0 and not mt.lines(r.stderr), f"np={np_}: -ts_max_snes_failures -1 runs without a word ({mt.lines(r.stderr)})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
