#!/usr/bin/env python3
"""PD with obstacle contact on the contact examples (issue 34, item 1): examples/cloth_sphere.opts
and examples/cloth_table.opts run with projective dynamics instead of their Newton, 10 fixed
iterations (Liu et al.'s setting, examples/cloth_pd.opts) and Anderson-accelerated to a tolerance,
and with the barrier's PD weights (-msim_contact_pd_weight 1, the default) or its force in the
right-hand side only (0). Per run: CPU seconds per step (the run's user + system time over its
steps, frames written every step), iterations per step, PD factorizations and Phi evaluations
(-log_view's MSimLLTFactor and MSimEnergy counts), the least distance of any free vertex to any
obstacle over every frame (must be > 0), and the monitor's last contact force and KE; and the
same cloth and solver without the obstacles (the cost baseline).
Usage: /usr/bin/python3 runs/contact/pd_examples.py [--msim build/msim]  (writes pd_examples.csv)"""
import argparse
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(ROOT, "tests"))
sys.path.insert(0, os.path.join(ROOT, "runs", "tools"))
import msimrun  # noqa: E402
import vtu  # noqa: E402
from contact_examples import distance, obstacles  # noqa: E402  the test's own geometry
from study import read_csv, run  # noqa: E402

SOLVERS = {"pd10": ["-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"],
           "pd_anderson_1e-5": ["-snes_type", "pd", "-snes_pd_anderson", "5", "-snes_max_it", "300", "-snes_rtol", "1e-5"]}
NEWTON_ONLY = ("-msim_psd",)  # the examples' Newton options that -snes_type pd does not read
WEIGHTS = {"weights": ["-msim_contact_pd_weight", "1"], "rhs_only": ["-msim_contact_pd_weight", "0"]}


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--msim", default=msimrun.MSIM)
    a = p.parse_args()
    tmp = tempfile.mkdtemp(prefix="msim_pd_examples_")
    rows = []
    for name in ("cloth_sphere", "cloth_table"):
        path = os.path.join(ROOT, "examples", name + ".opts")
        obs, opts = obstacles(path)
        steps = int(opts["-msim_steps"])
        # the example's options less its Newton's (-msim_psd, which pd refuses), and the same cloth
        # and solver with no obstacle (less its contact ones too: the cost baseline)
        scene = {k: v for k, v in opts.items() if k not in NEWTON_ONLY}
        own = [x for k, v in scene.items() for x in ([k, v] if v else [k])]
        free = [x for k, v in scene.items() if not k.startswith(("-msim_contact", "-msim_friction", "-msim_output")) for x in ([k, v] if v else [k])]
        for s, sopts in SOLVERS.items():
            rc, err, log, cpu = run(a.msim, free + sopts)
            rows.append(dict(example=name, solver=s, pd_matrix="no obstacle", ok=int(rc == 0), cpu_ms_per_step=1e3 * cpu / steps, its_per_step=np.nan,
                             factorizations=msimrun.event(log, "MSimLLTFactor")[0], energy_evaluations=msimrun.event(log, "MSimEnergy")[0],
                             least_distance_m=np.nan, contact_fz_end=np.nan, kinetic_end=np.nan, note=""))
            print(rows[-1], flush=True)
            for w, wopts in WEIGHTS.items():
                out, csv = os.path.join(tmp, f"{name}_{s}_{w}"), os.path.join(tmp, f"{name}_{s}_{w}.csv")
                rc, err, log, cpu = run(a.msim, own + ["-msim_output", out, "-msim_output_every", "1", "-msim_monitor_csv", csv] + sopts + wopts)
                row = dict(example=name, solver=s, pd_matrix=w, ok=int(rc == 0), cpu_ms_per_step=1e3 * cpu / steps, its_per_step=np.nan, factorizations=-1,
                           energy_evaluations=-1, least_distance_m=np.nan, contact_fz_end=np.nan, kinetic_end=np.nan, note="")
                if rc == 0:
                    mon, least = read_csv(csv), np.inf
                    for _, f in vtu.read_pvd(os.path.join(out, "series.pvd")):
                        g = vtu.read_vtu(f)
                        least = min(least, float(np.array([distance(k, v, g["points"][g["fixed"] == 0]) for k, v in obs]).min()))
                    row.update(its_per_step=np.mean([int(r["nonlinear_its"]) for r in mon[1:]]), factorizations=msimrun.event(log, "MSimLLTFactor")[0],
                               energy_evaluations=msimrun.event(log, "MSimEnergy")[0], least_distance_m=least, contact_fz_end=float(mon[-1]["contact_fz"]),
                               kinetic_end=float(mon[-1]["kinetic"]))
                else:
                    row.update(note=err.strip().splitlines()[-1][:150] if err.strip() else "failed")
                rows.append(row)
                print(row, flush=True)
    msimrun.write_csv(os.path.join(HERE, "pd_examples.csv"), rows)


if __name__ == "__main__":
    main()
