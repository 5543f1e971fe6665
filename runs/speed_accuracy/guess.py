#!/usr/bin/env python3
"""The first iterate of each implicit step (-msim_implicit_guess) against PD-10's error (issue 33).

For each scene (rope, the 21 x 21 cloth, the tet beam; the benchmark cloth with --scenes cloth),
each scheme and each guess (constant_velocity: x_n + h v_n; extrapolate: the scheme's position at
v_{n+1} = 2 v_n - v_{n-1}; inertial: the scheme's y), one run of PD-10 at h = 1/30 s (the issue's
cost budget: 10 fixed PD iterations per step, so the guess is the only change) to T, and its
largest vertex distance from the RK4 reference of schemes.py (the same scenes and references,
kept in /tmp/msim_schemes; made here when missing) at every frame. Cost: the run's CPU user
seconds (one rank, the whole run, setup included: both guesses take the same PD iterations).
Writes guess.csv. Usage: /usr/bin/python3 runs/speed_accuracy/guess.py [--msim PATH]
[--scenes rope,cloth21,solid] [--schemes implicit_euler,...] [--guesses constant_velocity,extrapolate,inertial]
[--solver PD-10]"""
import argparse
import os
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


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--msim", default=os.path.join(S.ROOT, "build", "msim"))
    p.add_argument("--scenes", default="rope,cloth21,solid")
    p.add_argument("--schemes", default=",".join(S.SCHEMES[:4]))
    p.add_argument("--guesses", default="constant_velocity,extrapolate,inertial")
    p.add_argument("--solver", default="PD-10")
    p.add_argument("--out", default=os.path.join(HERE, "guess.csv"))
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
        h = S.H30
        steps, every = round(T / float(h)), round(dT / float(h))
        for scheme in a.schemes.split(","):
            opts = S.SOLVERS[a.solver] if scheme != "discrete_gradient" else S.DG_NEWTON
            for guess in a.guesses.split(","):
                cmd = f"{base} -msim_dt {h} -msim_integrator {scheme} {opts} -msim_implicit_guess {guess} -msim_steps {steps} -msim_output_every {every}"
                rc, err, step_s, mon, fout, user = S.run_timed(msim, cmd, f"guess_{name}")
                errs = {round(k * float(h), 6): float(np.max(np.linalg.norm(x - ref[round(k * float(h), 6)], axis=1)))
                        for k, x in S.frames(fout).items() if k > 0 and round(k * float(h), 6) in ref}
                note = (err.strip().splitlines() or [""])[-1][:160] if rc else ""
                print(f"{name} {scheme} {guess}: {' '.join(f'{t:g}:{e:.3e}' for t, e in sorted(errs.items()))} user {user:.2f} s {note}", flush=True)
                for t, e in sorted(errs.items()):
                    rows.append(dict(scene=name, size=base, scheme=scheme, solver=a.solver, h=h, guess=guess, T=t, error_vs_rk4_m=f"{e:.4e}",
                                     run_user_s=f"{user:.3f}", steps=steps, failed=note))
    old = []
    if os.path.exists(a.out):  # rows of other scenes, schemes or guesses stay
        import csv
        keys = {(r["scene"], r["scheme"], r["solver"], r["guess"]) for r in rows}
        old = [r for r in csv.DictReader(open(a.out)) if (r["scene"], r["scheme"], r["solver"], r["guess"]) not in keys]
    S.write_csv(a.out, old + rows)


if __name__ == "__main__":
    main()
