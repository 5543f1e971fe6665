#!/usr/bin/env python3
"""examples/bunny_drop.opts gains no energy at its landing. The bunny (0.21 kg) falls 5 cm onto a
static plane with friction: the drop releases m g 0.05 = 0.10 J into kinetic energy, and from the
landing on, friction, the barrier's elastic bounce and BDF2 can only keep or lose it, so the
energy (kinetic + potential, -msim_monitor_csv's total) of every step from the landing on stays at
or below that of the last step before it. TOL: in flight BDF2's step moves the energy by ~4e-6 J;
converged Newton (MUMPS, -snes_max_it 300) lands at 0.0104 J from 0.0712 J the step before and
stays at or below that through step 16 (its largest rise, 1.3e-3 to 5.1e-3 J in steps 13-16, is
the bounce's exchange under BDF2, far below the step before the landing); 1e-3 J is 1% of m g
0.05. With Anderson's 30 fixed iterations starting the landing step from the clamped guess (Phi
1.405e-5, above Phi(x_n) 1.134e-5) the energy rose to 0.19 J and 0.25 J (the bunny left
compressed): the start is now compared with x_n as plain PD's is (src/implicit/pd_steps.cpp).
The same with L-BFGS in Anderson's place (-snes_pd_anderson 0 -snes_pd_lbfgs 5, its fused
gradient): without the comparison at its first gradient the energy rose to 0.187 J and 0.200 J;
with it the landing drops it to -0.028 J and the bounce keeps it below 0.032 J (-0.024 J and
0.053 J at 2 ranks).
16 steps: the landing is step 11, the bounce's lowest point step 13.
Usage: bunny_drop_energy.py path/to/msim [--np N] [--no-tetgen]"""
import os
import sys
import tempfile

import msimtest as mt

TOL = 1e-3  # J
LANDED = 0.1  # N: contact_fy past this is the landing (m g = 2.10 N; step 10 touches with 7e-4 N)
SOLVERS = (("Anderson", []), ("L-BFGS", ["-snes_pd_anderson", "0", "-snes_pd_lbfgs", "5"]))  # the example's, then L-BFGS's fused gradient


def main():
    exe, check = mt.msim_path(), mt.Checks()
    if mt.without_tetgen("bunny_drop_energy"):
        return 0
    tmp = tempfile.mkdtemp(prefix="msim_bunny_drop_energy_")
    for np_, (name, opts) in ((n, c) for n in mt.ranks() for c in SOLVERS):
        mon = os.path.join(tmp, f"monitor_{np_}_{name}.csv")
        r = mt.run(exe, ["-options_file", os.path.join("examples", "bunny_drop.opts"), "-msim_steps", "16",
                         "-msim_output", "", "-msim_monitor_csv", mon] + opts, np_, cwd=mt.ROOT)
        check(r.returncode == 0, f"np {np_} {name}: runs" + ("" if r.returncode == 0 else f": {r.stderr[-800:]}"))
        if r.returncode:
            continue
        rows = mt.read_csv(mon)
        land = next((i for i, x in enumerate(rows) if float(x["contact_fy"]) > LANDED), None)
        check(land is not None and land > 0, f"np {np_} {name}: the bunny lands (contact_fy > {LANDED} N) after the first step")
        if not land:
            continue
        before = float(rows[land - 1]["total"])
        worst = max(rows[land:], key=lambda x: float(x["total"]))
        rise = float(worst["total"]) - before
        check(rise <= TOL, f"np {np_} {name}: energy from the landing (step {rows[land]['step']}) on at most the step before's "
              f"{before:.4g} J + {TOL:g} J: highest {float(worst['total']):.4g} J at step {worst['step']} (rise {rise:.3g} J)")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
