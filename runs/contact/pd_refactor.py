#!/usr/bin/env python3
"""PD's factor with contact weights, refactored lazily (issue 34, the cost of contact): the
benchmark cloth (101 x 101, h = 1/30 s) dropped on the analytic ball with friction 0.3, 24 steps,
PD-10 under each -msim_contact_pd_refactor policy (0: refactor whenever the set of vertices within
dhat changes, the old rule; r: keep the factor until some vertex's wanted diagonal is off the
factored one by more than a factor r), PD-10 halving on Phi where a step raised it (-msim_contact_pd_bound 0, the rule before the bound),
PD-10 without the obstacle (the baseline of "contact adds"), and Newton-CG (examples/cloth_newton_fast.opts's
options) with the contact-free PD factor as CG's preconditioner or with the contact weights in it
(-msim_contact_pc_pd_weight). Per configuration: CPU user ms per step over steps 5-24 = (min over
3 alternated rounds of the 24-step run's user time - the same for the 4-step run) / 20;
factorizations (-log_view's MSimLLTFactor count, set-up included), Phi evaluations (MSimEnergy),
PD local steps (MSimPDLocal), halvings on Phi (MSimPDHalving) and rejected steps whose length the
contact bound set (MSimPDBound, -msim_contact_pd_bound) over the 24 steps,
CG iterations per step; the monitor's last step (contact force fz, KE, vertices within dhat, |g|)
and the mean |g| and Phi over steps 5-24; the least distance of any vertex to the ball over every
frame of a separate run with frames (must be > 0).
Usage: /usr/bin/python3 runs/contact/pd_refactor.py [--msim build/msim] [--n 101] [--rounds 3]
       [--configs name,name]   (writes pd_refactor_n<N>.csv; with --configs, replaces those rows)"""
import argparse
import os
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tools"))
import msimrun  # noqa: E402
import vtu  # noqa: E402
from study import read_csv, run  # noqa: E402

CENTRE, RADIUS = np.array([0.5, 0.5, -0.4]), 0.3
PD = ["-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"]
NEWTON = ["-snes_type", "newtonls", "-ksp_type", "cg", "-msim_pc_pd", "-snes_ksp_ew", "-msim_step_atol", "1e-3", "-snes_rtol", "0",
          "-snes_atol", "0", "-snes_max_it", "20"]
BALL = ["-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_friction", "0.3"]
CONFIGS = {  # name: (solver options, contact options); BALL is added to all but "no obstacle"
    "pd10 no obstacle": (PD, []),
    "pd10 refactor on set change": (PD, ["-msim_contact_pd_refactor", "0"]),
    "pd10 refactor 2": (PD, ["-msim_contact_pd_refactor", "2"]),
    "pd10 refactor 4 (default)": (PD, ["-msim_contact_pd_refactor", "4"]),
    "pd10 refactor 10": (PD, ["-msim_contact_pd_refactor", "10"]),
    "pd10 refactor 30": (PD, ["-msim_contact_pd_refactor", "30"]),
    "pd10 refactor 4 halving on Phi": (PD, ["-msim_contact_pd_refactor", "4", "-msim_contact_pd_bound", "0"]),
    "newton_cg pc contact-free": (NEWTON, ["-msim_contact_pc_pd_weight", "0"]),
    "newton_cg pc weights refactor 4": (NEWTON, ["-msim_contact_pc_pd_weight", "1", "-msim_contact_pd_refactor", "4"]),
    "newton_cg pc weights refactor 30": (NEWTON, ["-msim_contact_pc_pd_weight", "1", "-msim_contact_pd_refactor", "30"]),
}


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--msim", default=msimrun.MSIM)
    p.add_argument("--n", default="101")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--configs", help="comma-separated names (default all)")
    a = p.parse_args()
    tmp = tempfile.mkdtemp(prefix="msim_pd_refactor_")
    names = [c for c in CONFIGS if not a.configs or c in a.configs.split(",")]
    cloth = ["-msim_cloth_n", a.n, "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", 1 / 30]
    ball = {c: [] if c == "pd10 no obstacle" else BALL for c in CONFIGS}
    cpu = {(c, s): [] for c in names for s in (4, 24)}
    logs, mons = {}, {}
    for r in range(a.rounds):  # alternated: every configuration once per round
        for c in names:
            sopts, copts = CONFIGS[c]
            for s in (24, 4):
                csv = os.path.join(tmp, "m.csv")
                rc, err, log, t = run(a.msim, cloth + ball[c] + sopts + copts + ["-msim_steps", s, "-msim_monitor_csv", csv])
                if rc:
                    sys.exit(f"{c}, {s} steps failed: {err.strip()[-300:]}")
                cpu[(c, s)].append(t)
                if s == 24 and r == 0:
                    logs[c], mons[c] = log, read_csv(csv)
            print(c, "round", r, cpu[(c, 24)][-1], cpu[(c, 4)][-1], flush=True)
    rows = []
    for c in names:
        sopts, copts = CONFIGS[c]
        out = os.path.join(tmp, "frames")
        rc, err, _, _ = run(a.msim, cloth + ball[c] + sopts + copts + ["-msim_steps", 24, "-msim_output", out, "-msim_output_every", 1])
        least = np.inf if ball[c] else ""  # no obstacle: no distance to report
        for _, f in vtu.read_pvd(os.path.join(out, "series.pvd")) if ball[c] else ():
            g = vtu.read_vtu(f)
            least = min(least, float((np.linalg.norm(g["points"] - CENTRE, axis=1) - RADIUS).min()))
        mon, log = mons[c], logs[c]
        tail = mon[5:]
        rows.append(dict(config=c, options=" ".join(sopts + copts), n=a.n, cpu_ms_per_step=1e3 * (min(cpu[(c, 24)]) - min(cpu[(c, 4)])) / 20,
                         cpu24_s=" ".join(f"{x:.2f}" for x in cpu[(c, 24)]), cpu4_s=" ".join(f"{x:.2f}" for x in cpu[(c, 4)]),
                         factorizations=msimrun.event(log, "MSimLLTFactor")[0], phi_evaluations=msimrun.event(log, "MSimEnergy")[0],
                         local_steps=msimrun.event(log, "MSimPDLocal")[0], halvings=msimrun.event(log, "MSimPDHalving")[0], bound_retries=msimrun.event(log, "MSimPDBound")[0],
                         nonlinear_its_per_step=np.mean([int(m["nonlinear_its"]) for m in tail]), linear_its_per_step=np.mean([int(m["linear_its"]) for m in tail]),
                         mean_residual=np.mean([float(m["residual"]) for m in tail]), mean_phi=np.mean([float(m["phi"]) for m in tail]),
                         contact_fz_end=float(mon[-1]["contact_fz"]), kinetic_end=float(mon[-1]["kinetic"]), contact_n_end=int(mon[-1]["contact_n"]),
                         residual_end=float(mon[-1]["residual"]), least_distance_m=least))
        print(rows[-1], flush=True)
    path = os.path.join(HERE, f"pd_refactor_n{a.n}.csv")
    if a.configs and os.path.exists(path):  # the others' rows kept, in CONFIGS's order
        new = {r["config"]: r for r in rows}
        old = {r["config"]: r for r in read_csv(path)}
        rows = [new.get(c, old.get(c)) for c in CONFIGS if c in new or c in old]
    msimrun.write_csv(path, rows)


if __name__ == "__main__":
    main()
