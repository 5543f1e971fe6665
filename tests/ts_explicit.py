#!/usr/bin/env python3
"""The stability guard of -msim_integrator ts's explicit types (an 8 x 8 cloth at h = 0.02, far
above every limit; omega_max is read from the warning, which prints its bound):
- every explicit Runge-Kutta type that takes -msim_dt as its step warns, from its stability
  polynomial: rk 1fe (forward Euler, as -ts_type euler) and ssp's default rks2 are unstable at every
  h without drag; rk 3 is limited to h <= sqrt(3) / omega_max (|R(iy)|^2 - 1 = y^4 (y^2 - 3) / 36)
  and ssp rks3 with 4 stages warns too (each ran silently before, 1fe diverging at step 6 of 30);
- euler and rk 4 warn as before (unstable without drag; 2 sqrt(2) / omega_max), and with -msim_drag
  rk 1fe's limit (from its polynomial) is -msim_integrator explicit_euler's gamma / omega_max^2;
- an adaptive type with an error estimate (rk 5dp) picks its own steps inside -msim_dt: no warning.
Usage: ts_explicit.py path/to/msim [--np N]"""
import math
import re
import sys

import msimtest as mt

MSIM = mt.msim_path()
BASE = ["-msim_cloth_n", "8", "-msim_dt", "0.02", "-msim_steps", "1", "-msim_integrator", "ts"]
UNSTABLE = "is unstable for every h without drag"
LIMIT = re.compile(r"exceeds the stability limit h <= (\S+) of \S+ \(omega_max <= (\S+) from")


def warnings(args, np):
    r = mt.run(MSIM, BASE + args, np)
    return [l for l in mt.lines(r.stderr) if l.startswith("msim: warning:")]


def limit(warn):
    """(h, omega_max) of the one limit warning, or None"""
    m = [LIMIT.search(w) for w in warn]
    m = [x for x in m if x]
    return (float(m[0].group(1)), float(m[0].group(2))) if len(m) == 1 else None


def main():
    check = mt.Checks()
    for np_ in mt.ranks():
        for label, args in (("rk 1fe", ["-ts_type", "rk", "-ts_rk_type", "1fe", "-ts_adapt_type", "none"]),
                            ("euler", ["-ts_type", "euler"]),
                            ("ssp rks2", ["-ts_type", "ssp"])):
            w = warnings(args, np_)
            check(len(w) == 1 and UNSTABLE in w[0], f"np={np_}: {label} warns that it is unstable at every h ({w})")
        for label, args, x in (("rk 3", ["-ts_type", "rk", "-ts_rk_type", "3"], math.sqrt(3)),
                               ("rk 4", ["-ts_type", "rk", "-ts_rk_type", "4", "-ts_adapt_type", "none"], 2 * math.sqrt(2))):
            w = warnings(args, np_)
            hw = limit(w)
            check(len(w) == 1 and hw is not None and abs(hw[0] - x / hw[1]) <= 1e-5 * hw[0], f"np={np_}: {label} warns with h <= {x:.6f} / omega_max ({w})")
        w = warnings(["-ts_type", "ssp", "-ts_ssp_type", "rks3", "-ts_ssp_nstages", "4"], np_)
        check(len(w) == 1 and limit(w) is not None, f"np={np_}: ssp rks3 (4 stages) warns with a limit ({w})")
        drag = ["-msim_drag", "0.5"]
        he = limit(warnings(["-msim_integrator", "explicit_euler"] + drag, np_))
        h1 = limit(warnings(["-ts_type", "rk", "-ts_rk_type", "1fe", "-ts_adapt_type", "none"] + drag, np_))
        check(he is not None and h1 is not None and abs(he[0] - h1[0]) <= 1e-5 * he[0], f"np={np_}: with drag, rk 1fe's limit is explicit_euler's gamma / omega_max^2 ({h1} vs {he})")
        w = warnings(["-ts_type", "rk", "-ts_rk_type", "5dp"], np_)
        check(not w, f"np={np_}: adaptive rk 5dp: no warning ({w})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
