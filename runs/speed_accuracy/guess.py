#!/usr/bin/env python3
"""The first iterate of each implicit step (-msim_implicit_guess) against PD-10's error (issue 33).

For each scene (rope, the 21 x 21 cloth, the tet beam; the benchmark cloth with --scenes cloth),
each scheme and each guess (constant_velocity: x_n + h v_n; extrapolate: the scheme's position at
v_{n+1} = 2 v_n - v_{n-1}; inertial: the scheme's y), one run of PD-10 at h = 1/30 s (the issue's
cost budget: 10 fixed PD iterations per step, so the guess is the only change) to T, and its
largest vertex distance from the RK4 reference of schemes.py (the same scenes and references,
kept in /tmp/msim_schemes; made here when missing) at every frame. Cost: the run's CPU user
seconds (one rank, the whole run, setup included: both guesses take the same PD iterations); with
--instructions also the instructions per simulated second (valgrind callgrind's Ir of the run to
T less that of its first step alone, over T - h: deterministic, unlike CPU time on this loaded
host) and their ratio to PD-10 implicit Euler's at h = 1/30 s, the issue's budget (--solver PD-k
and --h choose other operating points: k fixed PD iterations at another step).
Writes guess.csv. Usage: /usr/bin/python3 runs/speed_accuracy/guess.py [--msim PATH]
[--scenes rope,cloth21,solid] [--schemes implicit_euler,...] [--guesses constant_velocity,extrapolate,inertial]
[--solver PD-10|PD-k|Newton|...] [--h 0.0333333333333333] [--instructions] [--out guess.csv]"""
import argparse
import os
import re
import subprocess
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import schemes as S  # noqa: E402

SCENES = {  # name: (scene of schemes.py, its size arguments)
    "rope": ("rope", {}),
    "cloth21": ("cloth", {"cloth_n": 21}),
    "cloth": ("cloth", {"cloth_n": 101}),
    "solid": ("solid", {}),
}


def instructions(msim, args, h, T):
    """valgrind callgrind's instruction count (Ir) per simulated second: the run to T less its first
    step alone (setup, PD factor, step 1), over T - h"""
    def ir(n):
        r = subprocess.run(["valgrind", "--tool=callgrind", "--callgrind-out-file=/dev/null", msim] + args.split() + ["-msim_steps", str(n)],
                           capture_output=True, text=True, env=S.ENV, cwd=S.ROOT)
        m = re.search(r"Collected : (\d+)", r.stderr)
        return int(m.group(1)) if m else float("nan")
    n = round(T / h)
    return (ir(n) - ir(1)) / ((n - 1) * h)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--msim", default=os.path.join(S.ROOT, "build", "msim"))
    p.add_argument("--scenes", default="rope,cloth21,solid")
    p.add_argument("--schemes", default=",".join(S.SCHEMES[:4]))
    p.add_argument("--guesses", default="constant_velocity,extrapolate,inertial")
    p.add_argument("--solver", default="PD-10", help="a solver of schemes.py, or PD-k: k fixed PD iterations")
    p.add_argument("--h", default=S.H30, help="the step (default 1/30 s)")
    p.add_argument("--out", default=os.path.join(HERE, "guess.csv"))
    p.add_argument("--instructions", action="store_true", help="also count instructions per simulated second (valgrind; slow on the benchmark cloth)")
    a = p.parse_args()
    msim = os.path.abspath(a.msim)
    os.makedirs(S.TMP, exist_ok=True)
    rows = []
    for name in a.scenes.split(","):
        scene, size = SCENES[name]
        sa = argparse.Namespace(cloth_n=101, rope_n=1000, beam="24,6,6")
        for k, v in size.items():
            setattr(sa, k, v)
        base = S.scene_opts(sa)[scene]
        T, dT, href = S.T_END[scene], S.T_FRAME[scene], S.H_REF[scene]
        nref = round(T / float(href))
        out = f"{S.TMP}/{name}_ref"
        if not os.path.exists(f"{out}/frame_{nref:06d}.vtu"):
            rc, err, *_ = S.run_timed(msim, f"{base} -msim_integrator rk4 -msim_dt {href} -msim_steps {nref} -msim_output_every {round(dT / float(href))}", f"{name}_ref")
            if rc:
                sys.exit(f"reference failed: {err[-400:]}")
        ref = {round(k * float(href), 6): x for k, x in S.frames(out).items()}
        h = a.h
        steps, every = round(T / float(h)), round(dT / float(h))
        budget = instructions(msim, f"{base} -msim_spectrum_check 0 -msim_output_every 100000 -msim_dt {S.H30} -msim_integrator implicit_euler {S.SOLVERS['PD-10']}", float(S.H30), T) if a.instructions else None
        for scheme in a.schemes.split(","):
            opts = S.SOLVERS.get(a.solver, f"-snes_type pd -snes_pd_fixed -snes_max_it {a.solver[3:]}") if scheme != "discrete_gradient" else S.DG_NEWTON
            for guess in a.guesses.split(","):
                cmd = f"{base} -msim_dt {h} -msim_integrator {scheme} {opts} -msim_implicit_guess {guess} -msim_steps {steps} -msim_output_every {every}"
                rc, err, step_s, mon, fout, user = S.run_timed(msim, cmd, f"guess_{name}")
                ins = instructions(msim, f"{base} -msim_spectrum_check 0 -msim_output_every 100000 -msim_dt {h} -msim_integrator {scheme} {opts} -msim_implicit_guess {guess}", float(h), T) if a.instructions else None
                errs = {round(k * float(h), 6): float(np.max(np.linalg.norm(x - ref[round(k * float(h), 6)], axis=1)))
                        for k, x in S.frames(fout).items() if k > 0 and round(k * float(h), 6) in ref}
                note = (err.strip().splitlines() or [""])[-1][:160] if rc else ""
                cost = f" instructions {ins:.4g} per simulated s = {ins / budget:.2f} x PD-10 implicit Euler's at 1/30 s" if ins else ""
                print(f"{name} {scheme} {guess} {a.solver} h={float(h):.4g}: {' '.join(f'{t:g}:{e:.3e}' for t, e in sorted(errs.items()))} user {user:.2f} s{cost} {note}", flush=True)
                for t, e in sorted(errs.items()):
                    rows.append(dict(scene=name, size=base, scheme=scheme, solver=a.solver, h=h, guess=guess, T=t, error_vs_rk4_m=f"{e:.4e}",
                                     run_user_s=f"{user:.3f}", steps=steps, failed=note,
                                     instructions_per_sim_s=f"{ins:.4g}" if ins else "", instructions_vs_budget=f"{ins / budget:.3f}" if ins else ""))
    old = []
    if os.path.exists(a.out):  # rows of other scenes, schemes or guesses stay
        import csv
        keys = {(r["scene"], r["scheme"], r["solver"], r["h"], r["guess"]) for r in rows}
        old = [r for r in csv.DictReader(open(a.out)) if (r["scene"], r["scheme"], r["solver"], r["h"], r["guess"]) not in keys]
    S.write_csv(a.out, old + rows)


if __name__ == "__main__":
    main()
