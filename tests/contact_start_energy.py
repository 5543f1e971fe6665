#!/usr/bin/env python3
"""A cloth laid inside an obstacle's contact distance: the barrier's stored energy at the start is
named when it could throw the cloth clear of that distance, with the obstacle's option.

A 5 x 5 cloth of 0.2 m (1 kg, dhat by default 1e-2 of the 0.283 m diagonal) 1 mm above a floor,
implicit Euler at h = 1e-3: the default kappa (~ 1/h^2) stores 0.54 J, which hopped the cloth
1.8 cm with no line (under the scene's energy scale of 2.8 J). Checked, at each rank count:
- one warning line naming the energy, obstacle 0's 25 vertices within dhat at 1 mm, and
  -msim_contact_distance as the remedy (not self-contact's -msim_self_contact_distance);
- the same cloth 2 dhat above the floor (no barrier energy): no warning at all.

Usage: contact_start_energy.py path/to/msim [--np N]"""
import re
import sys

import msimtest as mt

HELD = re.compile(r"the contact barriers held (\S+) J at the start")
DHAT = 0.01 * 0.2 * 2 ** 0.5


def run(exe, height, np_):
    """the run's return code and its warning lines"""
    r = mt.run(exe, ["-msim_cloth_n", "5", "-msim_cloth_size", "0.2", "-msim_fix", "none", "-msim_contact_plane", f"0,0,1,{-height:.17g}",
                     "-msim_integrator", "implicit_euler", "-msim_dt", "0.001", "-msim_steps", "5"], np_)
    return r, [l for l in mt.lines(r.stderr) if "warning" in l]


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    for np_ in mt.ranks():
        r, warn = run(exe, 0.001, np_)
        check(r.returncode == 0, f"np {np_}: 1 mm above the floor: the run ends ({r.stderr.strip()[-300:]})")
        held = [l for l in warn if HELD.search(l)]
        check(len(held) == 1 and float(HELD.search(held[0]).group(1)) > 0, f"np {np_}: 1 mm above the floor, h = 1e-3: one warning names the barrier's energy at the start ({warn})")
        if len(held) == 1:
            check("obstacle 0: 25 vertices within it, the nearest at 0.001 m" in held[0], f"np {np_}: the warning says where: ({held[0]})")
            check("a smaller -msim_contact_distance" in held[0] and "-msim_self_contact_distance" not in held[0], f"np {np_}: the remedy is the obstacles' option ({held[0]})")
        r, warn = run(exe, 2 * DHAT, np_)
        check(r.returncode == 0 and not warn, f"np {np_}: 2 dhat above the floor: no warning ({warn}, {r.stderr.strip()[-300:]})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
