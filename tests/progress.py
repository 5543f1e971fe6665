#!/usr/bin/env python3
"""A long run says how far it is: with -msim_progress s, lines 'msim: step n of N (p%), t = ..., wall
..., ... steps/s, ETA ...' on stderr, from rank 0 only (no line twice at two ranks), steps rising,
the percentage and simulated time matching the step; -msim_progress 0 prints none. A run restarted
half way reports its own rate (steps since the restart over its wall time), not one inflated by the
steps of the first run."""
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
    for np in (1, 2):
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
    # a restart from step STEPS / 2: the same work per step, so about the same rate (the old rate
    # counted every step from 0: twice or more at the restart's first lines)
    with tempfile.TemporaryDirectory() as tmp:
        ck = os.path.join(tmp, "state.ck")
        first = run(1, ["-msim_progress", "0", "-msim_checkpoint", ck, "-msim_steps", str(STEPS // 2)])
        fresh = [float(LINE.match(l).group(5)) for l in run(1, ["-msim_progress", "0.05"]).stderr.splitlines() if LINE.match(l)]
        again = [float(LINE.match(l).group(5)) for l in run(1, ["-msim_progress", "0.05", "-msim_restart", ck]).stderr.splitlines() if LINE.match(l)]
        ratio = max(again) / (sum(fresh) / len(fresh)) if fresh and again else 0
        check(first.returncode == 0 and 0.3 < ratio < 1.7,
              f"restart at step {STEPS // 2}: fastest reported rate {ratio:.2f}x the fresh run's mean (rc {first.returncode}, fresh {fresh[:3]}, restarted {again[:3]})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
