#!/usr/bin/env python3
"""Adaptive TS on one mass on a spring: msim against PETSc's TS alone (oscillator.cpp), and the final
error against -ts_atol/-ts_rtol. The scene: chain of 2 vertices, one fixed, the free one 1 kg on
k = 1 N/m (omega = 1), released 0.1 m from rest: x = 1 + 0.1 cos t exactly. 120 frames of
-msim_dt 0.1 s to T = 12 s, -ts_adapt_type basic, atol = rtol = tol. The error is |x(T) - exact|.
oscillator.cpp is built here (mpicxx, pkg-config PETSc) and run on the same 6 unknowns (-dim 3 -rest 1)
with the same TS options, TSStep from frame to frame as msim steps.

Prints Markdown tables for runs/ts_adaptive/README.md: the types at tol 1e-6, 1e-8, 1e-10 (bdf1,
alpha and alpha2 not at 1e-10: over 10^5 steps), then bdf2 at 1e-8 under variants (TSSolve to T
with the last step matched or interpolated, other frames, a start step, tight stage solves, and
the fixed step of the adaptive run's mean). Usage:
  /usr/bin/python3 runs/ts_adaptive/spring.py [path/to/msim]"""
import math
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tools"))
import msimrun  # noqa: E402

MSIM = os.path.abspath(sys.argv[1]) if len(sys.argv) > 1 else msimrun.MSIM
SPRING = ("-msim_scene chain -msim_chain_n 2 -msim_fix edge -msim_gravity 0,0,0 -msim_mass 2 -msim_stiffness 1 "
          "-msim_prestretch 1.1 -msim_spectrum_check 0 -msim_progress 0 -msim_integrator ts").split()
FRAMES = ["-msim_dt", "0.1", "-msim_steps", "120"]
EXACT = 1 + 0.1 * math.cos(12.0)


def build(tmp):
    flags = subprocess.run(["pkg-config", "--cflags", "--libs", "PETSc"], capture_output=True, text=True, check=True).stdout.split()
    exe = os.path.join(tmp, "oscillator")
    subprocess.run(["mpicxx", "-O2", os.path.join(HERE, "oscillator.cpp")] + flags + ["-lm", "-o", exe], check=True)
    return exe


def msim(args, frames, tmp):
    """final x of the free vertex, internal steps, rejections"""
    out = os.path.join(tmp, "final.txt")
    r = subprocess.run([MSIM] + SPRING + frames + args + ["-msim_view", "-msim_view_final", f"ascii:{out}:ascii_matlab"],
                       capture_output=True, text=True, env=msimrun.ENV, check=True)
    x = [float(l) for l in open(out) if l.strip() and l.strip()[0] in "+-0123456789"]
    s = re.search(r"ts: (\d+) internal steps, (\d+) rejected", r.stdout)
    return x[3], int(s.group(1)), int(s.group(2))


def alone(exe, args):
    """final x, steps, rejections of oscillator.cpp"""
    r = subprocess.run([exe, "-dim", "3", "-rest", "1"] + args, capture_output=True, text=True, env=msimrun.ENV, check=True)
    m = re.search(r"x (\S+) .* steps (\d+) rejected (\d+)", r.stdout)
    return float(m.group(1)), int(m.group(2)), int(m.group(3))


def adaptive(tol):
    return ["-ts_adapt_type", "basic", "-ts_atol", repr(tol), "-ts_rtol", repr(tol)]


def main():
    with tempfile.TemporaryDirectory() as tmp:
        exe = build(tmp)
        print("| -ts_type | tol | msim: error at 12 s, m | error / tol | steps (rejected) | PETSc alone: error, m | steps (rejected) | x apart, m |")
        print("|---|---|---|---|---|---|---|---|")
        cases = [(f"bdf, -ts_bdf_order {o}", ["-ts_type", "bdf", "-ts_bdf_order", str(o)]) for o in (1, 2, 3, 4)]
        cases += [(t, ["-ts_type", t]) for t in ("rosw", "arkimex", "alpha", "alpha2")]
        for name, args in cases:
            for tol in (1e-6, 1e-8, 1e-10):
                if tol < 1e-9 and name in ("bdf, -ts_bdf_order 1", "alpha", "alpha2"):
                    continue
                x, n, rej = msim(args + adaptive(tol), FRAMES, tmp)
                row = f"| {name} | {tol:g} | {abs(x - EXACT):.3e} | {abs(x - EXACT) / tol:.3g} | {n:,} ({rej}) |"
                if name == "alpha2":  # second order in x and v: oscillator.cpp has only the first-order form
                    row += " - | - | - |"
                else:
                    xa, na, reja = alone(exe, args + adaptive(tol))
                    row += f" {abs(xa - EXACT):.3e} | {na:,} ({reja}) | {abs(xa - x):.1e} |"
                print(row, flush=True)

        bdf2 = ["-ts_type", "bdf", "-ts_bdf_order", "2"]
        print("\n| bdf2, tol 1e-8 | error at 12 s, m | steps (rejected) |")
        print("|---|---|---|")
        x, n, rej = msim(bdf2 + adaptive(1e-8), FRAMES, tmp)
        print(f"| msim, as above | {abs(x - EXACT):.3e} | {n:,} ({rej}) |")
        mean = n
        for what, args in (("msim, 30 frames of 0.4 s", ["-msim_dt", "0.4", "-msim_steps", "30"]),
                           ("msim, first step -ts_dt 1e-5", FRAMES + ["-ts_dt", "1e-5"]),
                           ("msim, stage solves to -snes_atol 1e-15 -snes_rtol 1e-14", FRAMES + ["-snes_atol", "1e-15", "-snes_rtol", "1e-14"])):
            x, n, rej = msim(bdf2 + adaptive(1e-8), args, tmp)
            print(f"| {what} | {abs(x - EXACT):.3e} | {n:,} ({rej}) |")
        for what, args in (("alone, TSSolve to 12 s, last step matched", ["-mode", "match"]),
                           ("alone, TSSolve past 12 s, interpolated back", ["-mode", "interp"])):
            xa, na, reja = alone(exe, bdf2 + adaptive(1e-8) + args)
            print(f"| {what} | {abs(xa - EXACT):.3e} | {na:,} ({reja}) |")
        h = 12.0 / mean
        x, n, rej = msim(bdf2 + ["-ts_adapt_type", "none"], ["-msim_dt", repr(h), "-msim_steps", str(mean)], tmp)
        print(f"| msim, fixed step 12 s / {mean:,} (the adaptive run's mean) | {abs(x - EXACT):.3e} | {n:,} ({rej}) |")


if __name__ == "__main__":
    main()
