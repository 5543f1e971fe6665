#!/usr/bin/env python3
"""The divergence test stops blow-ups, not physics. Runs that lose energy or take it from what the
options drive go to their end: a cloth dropped 15 m onto a floor (the energy lost landing is
over 10 x the scene's old energy scale, m g times its diagonal: the test compared |E - E0| and
stopped it at step 88), one falling at its terminal velocity in air drag (stopped at step 182),
one lifted 20 m by its handles (their work, 196 J, stopped it at step 180). Explicit Euler past
its stability limit still stops at step 16, as it did, its line naming the test and its numbers
(the energy's rise, the factor and the scale), and a misspelled option is named after that line.
At 1 and 2 ranks, or with `--np N` at N alone."""
import os
import re
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
PD = ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_max_it", "20", "-snes_pd_fixed"]
PHYSICAL = {
    "dropped 15 m onto a floor": ["-msim_cloth_n", "5", "-msim_fix", "none", "-msim_contact_plane", "0,0,1,-15", "-msim_dt", "0.02", "-msim_steps", "150"] + PD,
    "falling in air drag": ["-msim_cloth_n", "2", "-msim_fix", "none", "-msim_drag", "0.5", "-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-msim_steps", "250"],
    "lifted 20 m by its handles": ["-msim_cloth_n", "5", "-msim_fix_velocity", "0,0,2", "-msim_dt", "0.05", "-msim_steps", "200"] + PD,
}
LINE = re.compile(r"^msim: error: diverged at step (\d+) \(t = \S+ s\): the total energy rose by (\S+) J \(\S+ -> \S+ J\), "
                  r"more than -msim_divergence_factor 10 x the energy scale (\S+) J; explicit_euler, h = 0.002; last finite state is step (\d+)$")


def main():
    check = mt.Checks()
    for np in mt.ranks():
        for what, args in PHYSICAL.items():
            r = mt.run(MSIM, args + ["-msim_monitor"], np)
            check(r.returncode == 0 and not r.stderr.strip(), f"np={np}: a cloth {what} runs to its end (rc {r.returncode}, {mt.lines(r.stderr)[-1:]!r})")
        # the blow-up, checked every step (the monitor on): stopped where the old test stopped it
        r = mt.run(MSIM, ["-msim_integrator", "explicit_euler", "-msim_dt", "2e-3", "-msim_steps", "400", "-msim_spectrum_check", "0", "-msim_monitor"], np)
        lines = mt.lines(r.stderr)
        m = LINE.match(lines[0]) if len(lines) == 1 else None
        check(r.returncode != 0 and m is not None and int(m.group(1)) == 16 and int(m.group(4)) == int(m.group(1)) - 1
              and float(m.group(2)) > 10 * float(m.group(3)),
              f"np={np}: explicit Euler past its limit stops early, its line naming the test ({lines!r})")
        # a misspelled option, which may be the failure's cause, is named after the error line as a
        # finished run names it (a failing run said nothing of it)
        r = mt.run(MSIM, ["-msim_integrator", "explicit_euler", "-msim_dt", "2e-3", "-msim_steps", "400", "-msim_spectrum_check", "0", "-msim_stifness", "3"], np)
        lines = mt.lines(r.stderr)
        check(r.returncode != 0 and len(lines) == 2 and lines[0].startswith("msim: error: diverged at step") and lines[1].startswith("msim: warning: -msim_stifness was set but never used"),
              f"np={np}: the blow-up with a misspelled option names both, the error first ({lines!r})")
        # the last finite state that cannot be written (a directory in its file's place): the
        # divergence is still the line, the write's failure added to it (it was the line alone)
        with tempfile.TemporaryDirectory() as tmp:
            os.makedirs(os.path.join(tmp, "last_finite.vtu.tmp"))
            r = mt.run(MSIM, ["-msim_integrator", "explicit_euler", "-msim_dt", "2e-3", "-msim_steps", "400", "-msim_spectrum_check", "0", "-msim_output", tmp, "-msim_output_every", "100"], np)
            lines = mt.lines(r.stderr)
            check(r.returncode != 0 and len(lines) == 1 and lines[0].startswith("msim: error: diverged at step") and "; writing the last finite state failed: cannot write" in lines[0],
                  f"np={np}: a blow-up whose last finite state cannot be written says both in one line ({lines!r})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
