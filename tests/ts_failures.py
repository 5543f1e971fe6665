#!/usr/bin/env python3
"""How -msim_integrator ts reports what stopped it (an 8 x 8 cloth, h = 0.02):
- a fixed-step stage solve capped by -snes_max_it 1 fails, is retried at a quarter step, which a
  fixed-step TS keeps for the rest of the interval, and the run runs out of internal steps: the one
  error line names -snes_max_it 1 and says to raise it (it said "stage solves kept failing ...:
  lower -msim_dt");
- an adaptive beuler at -ts_atol 1e-4 warns of a -snes_atol above a hundredth of it (1e-2), in one
  line, as of a loose -snes_rtol (-snes_atol 1e-2 ran silently); -snes_atol 1e-7 says nothing.
Usage: ts_failures.py path/to/msim [--np N]"""
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
        adaptive = CLOTH + ["-msim_steps", "2", "-ts_type", "beuler", "-ts_adapt_type", "basic", "-ts_atol", "1e-4"]
        r = mt.run(MSIM, adaptive + ["-snes_atol", "1e-2"], np_)
        lines = mt.lines(r.stderr)
        check(r.returncode == 0 and len(lines) == 1 and lines[0].startswith("msim: warning: adaptive -ts_type beuler: the stage solves stop at |F| <= -snes_atol 0.01")
              and "lower -snes_atol" in lines[0], f"np={np_}: a loose -snes_atol under an adaptive TS is warned about ({lines})")
        r = mt.run(MSIM, adaptive + ["-snes_atol", "1e-7"], np_)
        check(r.returncode == 0 and not mt.lines(r.stderr), f"np={np_}: -snes_atol 1e-7 at -ts_atol 1e-4: no warning ({mt.lines(r.stderr)})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
