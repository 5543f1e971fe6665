#!/usr/bin/env python3
"""A long run says how far it is: with -msim_progress s, lines 'msim: step n of N (p%), t = ..., wall
..., ... steps/s, ETA ...' on stderr, from rank 0 only (no line twice at two ranks), steps rising,
the percentage and simulated time matching the step; -msim_progress 0 prints none. A run restarted
a quarter of the way reports its own rate (steps since the restart over its wall time), not one
inflated by the steps of the first run: checked from each line's printed numbers, not by timing.
At 1 and 2 ranks (the restart at 1), or with `--np N` at N alone (ctest's progress_np1 and _np2: the
1-rank half runs beside other tests)."""
import os
import re
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
STEPS = 4000
ARGS = ["-msim_cloth_n", "40", "-msim_integrator", "implicit_euler", "-msim_dt", "0.001", "-msim_steps", str(STEPS),
        "-snes_type", "pd", "-snes_max_it", "3", "-snes_pd_fixed"]
LINE = re.compile(r"^msim: step (\d+) of (\d+) \((\d+)%\), t = (\S+) s, wall \S+, (\S+) steps/s, ETA \S+$")


def run(np, extra):
    return mt.run(MSIM, ARGS + extra, np)


def main():
    check = mt.Checks()
    for np in mt.ranks():
        r = run(np, ["-msim_progress", "0.05"])
        lines = mt.lines(r.stderr)
        found = [LINE.match(l) for l in lines]
        steps = [int(m.group(1)) for m in found if m]
        ok = (r.returncode == 0 and len(lines) >= 2 and all(found) and steps == sorted(set(steps))
              and all(int(m.group(2)) == STEPS and abs(int(m.group(3)) - 100 * int(m.group(1)) / STEPS) <= 0.5
                      and abs(float(m.group(4)) - 0.001 * int(m.group(1))) < 1e-9 for m in found))
        quiet = run(np, ["-msim_progress", "0"])
        ok = ok and quiet.returncode == 0 and quiet.stderr.strip() == ""
        check(ok, f"np={np}: {len(lines)} progress lines (steps {steps[:3]}...{steps[-1:]}), rc {r.returncode}, first {lines[:4]!r}; "
                  f"quiet run stderr {quiet.stderr.strip()[:100]!r}")
    if 1 not in mt.ranks():  # the restart is checked at 1 rank
        return check.exit_code()
    # a restart from step STEPS / 4 reports its own rate: rate x wall = the steps since the restart
    # (the old rate counted every step from 0, off by STEPS / 4 steps). From the printed numbers:
    # wall to 0.05 s, the rate to 3 digits; lines from 0.3 s on, where an off-by-STEPS/4 rate is
    # outside that rounding
    first_step = STEPS // 4
    with tempfile.TemporaryDirectory() as tmp:
        ck = os.path.join(tmp, "state.ck")
        first = run(1, ["-msim_progress", "0", "-msim_checkpoint", ck, "-msim_steps", str(first_step)])
        again = run(1, ["-msim_progress", "0.05", "-msim_restart", ck])
        got = []
        for l in again.stderr.splitlines():
            m, w = LINE.match(l), re.search(r"wall (\d+(?:\.\d+)?)s,", l)
            if m and w and float(w.group(1)) >= 0.3:
                step, rate, wall = int(m.group(1)), float(m.group(5)), float(w.group(1))
                got.append((step, rate, wall, abs(rate * wall - (step - first_step)) <= 0.05 * rate + 0.005 * rate * wall + 1))
        check(first.returncode == 0 and again.returncode == 0 and got and all(ok for *_, ok in got),
              f"restart at step {first_step}: rate x wall = the steps since the restart on every line from 0.3 s (step, rate, wall, ok: {got[:4]})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
