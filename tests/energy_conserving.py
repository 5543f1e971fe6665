#!/usr/bin/env python3
"""The energy-conserving discrete-gradient scheme (-msim_integrator discrete_gradient), at 1 and 2
ranks:
(its observed order 2 on the chain and the damped cloth with moving handles is checked with the
other schemes' in tests/schemes.py)
- with no damping, drag or moving handles the total energy (kinetic + springs + gravity) is
  conserved to the solver's tolerance: the scheme's energy balance is exact, so each step changes
  E by (2/h) v_m . r, r the residual left (the scheme's top comment), and |E_n - E_0| must stay
  below sum_k (2/h) |v_m,k| |r_k| (|v| <= sqrt(2 K / m) per step, |r| from the monitor) plus 1e-12 of
  the largest kinetic energy for the rounding of E itself. On the undamped chain (k = 1000 N/m,
  1 kg, 6 free masses of 0.125 kg) at 10 x its explicit limit 2/omega_max, omega_max =
  2 sqrt(k/m) sin(6 pi/14) = 174.4 rad/s (the fixed-fixed chain's top mode; msim -msim_spectrum
  reports the same), over 2000 steps; and on a 7 x 7 cloth at h = 1/30 s over 2000 steps, where
  implicit midpoint (msim's Newton) gains energy until it diverges: its energy must move by more
  than the discrete-gradient run's largest kinetic energy before it stops;
- -snes_type pd with the scheme is refused with one line naming the option (printed once);
- -snes_type ksponly (one linear solve a step) runs it linearised and says so in one note, as ts
  does for its implicit types (it ran silently, its energy no longer kept); Newton has no note.
(Its bit-identical restart with no history beyond (x, v) is checked with the other schemes' in
tests/schemes.py.)"""
import math
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

MSIM = mt.msim_path()
DG = ["-msim_integrator", "discrete_gradient"]
CHAIN = ["-msim_scene", "chain", "-msim_chain_n", "8", "-msim_fix", "corners", "-msim_spectrum_check", "0"]
TIGHT = ["-snes_rtol", "0", "-snes_atol", "1e-13", "-snes_stol", "0", "-snes_max_it", "200"]
K_CHAIN, M_CHAIN, N_CHAIN = 1000.0, 1.0, 8
check = mt.Checks()


def monitored(np_, args, csv):
    """run with a monitor CSV; returns (rows, returncode): a run that diverges keeps its rows"""
    r = mt.run(MSIM, args + ["-msim_monitor_csv", csv], np_)
    rows = mt.read_csv(csv) if os.path.exists(csv) else []
    return rows, r


def conserved(np_, label, rows, h, m_min, steps):
    e = np.array([float(r["total"]) for r in rows])
    k = np.array([float(r["kinetic"]) for r in rows])
    res = np.array([float(r["residual"]) for r in rows])
    v = np.sqrt(2 * k / m_min)                     # |v|_2 bound at each step
    per_step = (2 / h) * 0.5 * (v[:-1] + v[1:]) * res[1:]
    bound = np.concatenate(([0.0], np.cumsum(per_step))) + 1e-12 * k.max()
    dev = np.abs(e - e[0])
    worst = int(np.argmax(dev / bound))
    check(len(rows) == steps + 1 and np.all(dev <= bound),
          f"np={np_}: discrete_gradient keeps the energy of the {label} over {len(rows) - 1} steps: max |E - E0| {dev.max():.3e} J "
          f"(relative to the largest kinetic energy {k.max():.3f} J: {dev.max() / k.max():.1e}); at step {worst} {dev[worst]:.3e} J "
          f"against the solver-tolerance bound {bound[worst]:.3e} J")
    return dev.max(), k.max()


def energy(np_, tmp):
    m = M_CHAIN / N_CHAIN
    omega = 2 * math.sqrt(K_CHAIN / m) * math.sin((N_CHAIN - 2) * math.pi / (2 * (N_CHAIN - 1)))
    h = 10 * 2 / omega
    chain = CHAIN + ["-msim_stiffness", repr(K_CHAIN), "-msim_mass", repr(M_CHAIN), "-msim_dt", repr(h), "-msim_steps", "2000"]
    rows, r = monitored(np_, chain + DG + TIGHT, os.path.join(tmp, "chain.csv"))
    if r.returncode:
        sys.exit(f"msim failed on the chain:\n{r.stderr}")
    conserved(np_, f"undamped chain at h = {h:.4f} s (10 x 2/omega_max, omega_max = {omega:.2f} rad/s)", rows, h, m, 2000)
    # 7 x 7 cloth of 1 kg (49 vertices of 1/49 kg), corners fixed, default springs, h = 1/30
    h = 1 / 30
    cloth = ["-msim_cloth_n", "7", "-msim_mass", "1", "-msim_spectrum_check", "0", "-msim_dt", repr(h), "-msim_steps", "2000"]
    rows, r = monitored(np_, cloth + DG + TIGHT, os.path.join(tmp, "cloth.csv"))
    if r.returncode:
        sys.exit(f"msim failed on the cloth:\n{r.stderr}")
    _, kmax = conserved(np_, "7 x 7 cloth at h = 1/30 s", rows, h, 1 / 49, 2000)
    mid, r = monitored(np_, cloth + ["-msim_integrator", "implicit_midpoint"], os.path.join(tmp, "midpoint.csv"))
    e = np.array([float(x["total"]) for x in mid])
    drift = float(np.abs(e - e[0]).max()) if len(e) else float("nan")
    check(drift > kmax,
          f"np={np_}: implicit midpoint on the same cloth drifts: max |E - E0| {drift:.3e} J over {len(mid) - 1} steps"
          f"{' (then diverged)' if r.returncode else ''}, against discrete_gradient's largest kinetic energy {kmax:.3f} J")


def refusal(np_):
    r = mt.run(MSIM, CHAIN + DG + ["-msim_dt", "0.01", "-msim_steps", "2", "-snes_type", "pd"], np_)
    lines = [l for l in (r.stdout + r.stderr).splitlines() if "-snes_type pd" in l]
    check(r.returncode != 0 and len(lines) == 1 and "-msim_integrator discrete_gradient is not supported" in lines[0],
          f"np={np_}: -snes_type pd with discrete_gradient is refused in one line: {lines[0] if lines else (r.stdout + r.stderr)[-300:]!r}")


def linearised(np_):
    for snes, notes in (("ksponly", 1), ("newtonls", 0)):
        r = mt.run(MSIM, CHAIN + DG + ["-msim_dt", "0.01", "-msim_steps", "3", "-snes_type", snes], np_)
        noted = [l for l in mt.lines(r.stderr) if "a linearised scheme" in l]
        check(r.returncode == 0 and len(noted) == notes and all(l.startswith("msim: note: -snes_type ksponly with -msim_integrator discrete_gradient") for l in noted),
              f"np={np_}: -snes_type {snes} runs with {notes} note that the scheme is linearised ({r.returncode}, {mt.lines(r.stderr)})")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            energy(np_, tmp)
            refusal(np_)
            linearised(np_)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
