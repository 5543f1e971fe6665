#!/usr/bin/env python3
"""BDF2's start-up step before and after issue 33's fix (src/implicit/schemes/bdf2.cpp's comment
derives both).

Before: the first step used a past state made by Taylor expansion with a_0 = M^-1 f(x_0, v_0),
which multiplies a mode the step does not resolve (theta = h omega >> 1) by about theta / 4.
After: the first step is x_1 = x_0 + h v_0 + 4/9 h^2 a_1, v_1 = v_0 + h a_1 (the same beta and
gamma, so the same PD factor), whose amplification is below 5/4 for every theta.

Scenes: tests/order.py's chain (8 vertices, corners fixed, k = 1000 N/m, 1 kg, undamped, omega_max
= 174.40 rad/s, explicit limit 2/omega_max = 11.47 ms), at rest (smooth start, the order test) and
with every free vertex displaced by up to 1 cm (-msim_perturb 0.01), so that every mode starts
excited, without gravity (the exact motion keeps E_0; the chain at rest has E_0 = 0, so its energy
ratios are meaningless). For each h: the energy after step 1 over E_0, the largest over the run,
and the error at T = 0.3 s against RK4 at h = 1e-5 (largest vertex distance).

Usage: /usr/bin/python3 runs/speed_accuracy/bdf2_startup.py OLD_MSIM NEW_MSIM
(OLD: a build of 4cf9abf or earlier; NEW: this tree's). Writes bdf2_startup.csv."""
import csv
import math
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "tests"))
import msimtest as mt  # noqa: E402

CHAIN = ["-msim_scene", "chain", "-msim_chain_n", "8", "-msim_fix", "corners", "-msim_spectrum_check", "0"]
EXACT = ["-ksp_type", "preonly", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps", "-snes_rtol", "1e-14", "-snes_atol", "1e-15", "-snes_max_it", "200"]
T = 0.3
LIMIT = 2 / 174.40


def run(exe, args, tmp, name):
    out, mon = os.path.join(tmp, name + ".txt"), os.path.join(tmp, name + ".csv")
    r = subprocess.run(["nice", exe] + args + ["-msim_view_final", mt.view_ascii(out), "-msim_monitor_csv", mon], capture_output=True, text=True)
    rows = mt.read_csv(mon) if os.path.exists(mon) else []
    e = [float(r_["total"]) for r_ in rows]
    x = np.array(mt.read_view(out)) if r.returncode == 0 and os.path.exists(out) else None
    return x, e, r.returncode


def main():
    old, new = sys.argv[1], sys.argv[2]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scene, extra in (("chain at rest", []), ("perturbed chain", ["-msim_perturb", "0.01", "-msim_gravity", "0,0,0"])):
            ref, _, _ = run(new, CHAIN + extra + ["-msim_integrator", "rk4", "-msim_dt", "1e-5", "-msim_steps", str(round(T / 1e-5))], tmp, "ref")
            hs = [2e-3, 1e-3, 5e-4] + [f * LIMIT for f in (1, 3, 10, 25)]
            for h in hs:
                n = max(1, round(T / h))
                for label, exe in (("before", old), ("after", new)):
                    x, e, rc = run(exe, CHAIN + extra + EXACT + ["-msim_integrator", "bdf2", "-msim_dt", repr(T / n), "-msim_steps", str(n)], tmp, f"{label}_{h}")
                    err = float(np.abs(x - ref).max()) if x is not None else float("nan")
                    e0 = e[0] if e and abs(e[0]) > 1e-12 else float("nan")  # the chain at rest starts at E = 0: no ratio
                    row = dict(scene=scene, version=label, h=T / n, h_omega_max=174.40 * T / n, steps=n, exit=rc,
                               E0=e0, E1_over_E0=(e[1] / e0 if len(e) > 1 else float("nan")),
                               Emax_over_E0=(max(e) / e0 if e else float("nan")), error_at_T=err)
                    rows.append(row)
                    print(", ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in row.items()), flush=True)
    with open(os.path.join(HERE, "bdf2_startup.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    # observed orders on the smooth sizes
    for scene in ("chain at rest", "perturbed chain"):
        for label in ("before", "after"):
            err = [r["error_at_T"] for r in rows if r["scene"] == scene and r["version"] == label][:3]
            print(f"{scene}, {label}: errors {err}, orders {[round(math.log2(err[i] / err[i + 1]), 3) for i in range(2)]}")


if __name__ == "__main__":
    main()
