#!/usr/bin/env python3
"""How -msim_integrator ts reports what stopped it (an 8 x 8 cloth, h = 0.02):
- a fixed-step stage solve capped by -snes_max_it 1 fails, is retried at a quarter step, which a
  fixed-step TS keeps for the rest of the interval, and the run runs out of internal steps: the one
  error line names -snes_max_it 1 and says to raise it (it said "stage solves kept failing ...:
  lower -msim_dt").
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
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
