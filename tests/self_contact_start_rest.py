#!/usr/bin/env python3
"""A self-contact start within the contact distance (-msim_self_contact_start_gap 0), at the rank
count given. The mesh of tests/self_contact_start.py: a unit square (triangles (0, 1, 2), (0, 2, 3)
in z = 0) and a vertical triangle (4, 5, 6) whose lowest vertex 4 sits 0.1 m above the middle of
triangle (0, 1, 2), with dhat = 0.2 m. The barrier holds energy there (its weight scales as a
vertex's mass over h^2, h = 2e-4 s here), which the first step releases as kinetic energy: the
run used to stop at step 1 as "diverged", msim's divergence check not counting that energy. Now the
start's energy includes it, and msim warns once how much the barriers held. Checked:
- the 40 steps run (the unfixed build stopped at step 1), with one warning line naming the energy
  held, E_b > 0;
- energy balance: no step's kinetic + potential energy exceeds the start's plus E_b (the barrier's
  store is the only source, and implicit Euler only dissipates), and step 1 gained energy (the
  release happened);
- the same balance with BDF2, whose Phi weights the barrier by 1 / (4/9 h^2): the store it
  reports is 9/4 of implicit Euler's;
- vertex 4 is pushed away from the square, upwards (z grows from 0.1 m), beyond dhat by step 40;
- at 2 ranks: the same E_b (to the 6 digits the warning prints) and the same monitor (to 1e-9 of the energy scale)
  as at 1 rank;
- with dhat = 0.05 m the start is outside the barrier's reach: no warning.
Usage: self_contact_start_rest.py path/to/msim [--np N]"""
import os
import re
import sys
import tempfile

import msimtest as mt

sys.path.insert(0, os.path.join(mt.ROOT, "runs", "tools"))
import vtu  # noqa: E402

SQUARE = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
STEPS = 40
HELD = re.compile(r"the contact barriers held (\S+) J at the start")


def write_off(path, z0):
    """the square and the vertical triangle, its lowest vertex 4 at height z0"""
    pts = SQUARE + [(0.7, 0.3, z0), (0.7, 0.3, z0 + 1), (0.9, 0.25, z0 + 1)]
    with open(path, "w") as f:
        f.write(f"OFF\n{len(pts)} 3 0\n")
        f.writelines(f"{p[0]:.17g} {p[1]:.17g} {p[2]:.17g}\n" for p in pts)
        f.write("3 0 1 2\n3 0 2 3\n3 4 5 6\n")


def run(exe, tmp, off, dhat, np_, tag, scheme="implicit_euler"):
    """the run's return code, its warning lines about held energy, monitor rows, last frame"""
    out, csv = os.path.join(tmp, f"{tag}_{np_}"), os.path.join(tmp, f"{tag}_{np_}.csv")
    r = mt.run(exe, ["-msim_scene", "mesh", "-msim_mesh_file", off, "-msim_integrator", scheme, "-msim_self_contact",
                     "-msim_self_contact_distance", str(dhat), "-msim_self_contact_start_gap", "0", "-msim_steps", str(STEPS),
                     "-msim_monitor_csv", csv, "-msim_output", out], np_)
    held = [l for l in mt.lines(r.stderr) if HELD.search(l)]
    rows = mt.read_csv(csv) if r.returncode == 0 else []
    last = vtu.read_vtu(os.path.join(out, mt.frames(out)[-1]))["points"] if r.returncode == 0 else None
    return r, held, rows, last


def main():
    exe = mt.msim_path()
    check = mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_self_contact_start_rest_")
    off = os.path.join(tmp, "touch.off")
    write_off(off, 0.1)
    for np_ in mt.ranks():
        r, held, rows, last = run(exe, tmp, off, 0.2, np_, "rest")
        check(r.returncode == 0 and len(rows) == STEPS + 1, f"np {np_}: vertex 4 starting 0.1 m from triangle (0, 1, 2), dhat 0.2 m: {STEPS} steps run ({r.stderr.strip()[-300:]})")
        if r.returncode:
            continue
        eb = float(HELD.search(held[0]).group(1)) if len(held) == 1 else 0.0
        check(len(held) == 1 and eb > 0, f"np {np_}: one warning names the energy the barriers held at the start ({held})")
        total = [float(row["kinetic"]) + float(row["potential"]) for row in rows]
        e0 = total[0]
        check(max(total) <= e0 + eb * (1 + 1e-9), f"np {np_}: no step's energy exceeds the start's plus the barrier's store (max {max(total):.6g} J <= {e0:.6g} + {eb:.6g} J)")
        check(total[1] > e0, f"np {np_}: step 1 released energy ({e0:.6g} -> {total[1]:.6g} J)")
        check(last[4][2] > 0.2, f"np {np_}: vertex 4 pushed up beyond dhat by step {STEPS} (z = {last[4][2]:.6g} m)")
        if np_ > 1:
            r1, held1, rows1, _ = run(exe, tmp, off, 0.2, 1, "rest_ref")
            eb1 = float(HELD.search(held1[0]).group(1)) if len(held1) == 1 else 0.0
            check(abs(eb - eb1) <= 1e-6 * eb1, f"np {np_}: the barrier's store as at 1 rank ({eb} vs {eb1} J, to the warning's 6 digits)")
            diff = max(abs(float(a[k]) - float(b[k])) for a, b in zip(rows, rows1) for k in ("kinetic", "potential"))
            check(len(rows1) == len(rows) and diff <= 1e-9 * (e0 + eb), f"np {np_}: the monitor as at 1 rank (largest energy difference {diff:.3g} J)")
        # BDF2 weights the barrier by 9 / 4 of implicit Euler's (its Phi's h2 is 4/9 h^2) and
        # dissipates less: the store it reports is 9 / 4 of Euler's, and the balance holds
        r, held2, rows2, _ = run(exe, tmp, off, 0.2, np_, "bdf2", "bdf2")
        eb2 = float(HELD.search(held2[0]).group(1)) if len(held2) == 1 else 0.0
        total2 = [float(row["kinetic"]) + float(row["potential"]) for row in rows2] or [float("inf")]
        check(r.returncode == 0 and abs(eb2 - 2.25 * eb) <= 1e-5 * eb2 and max(total2) <= e0 + eb2 * (1 + 1e-9),
              f"np {np_}: bdf2: the store is 9/4 of Euler's ({eb2} vs {eb}) and no step exceeds the start's energy plus it (max {max(total2):.6g} J)")
        r, held, rows, _ = run(exe, tmp, off, 0.05, np_, "apart")
        check(r.returncode == 0 and not held, f"np {np_}: with dhat 0.05 m (< 0.1 m) the barrier holds nothing at the start: no warning ({held})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
