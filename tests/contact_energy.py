#!/usr/bin/env python3
"""-msim_monitor_csv's contact_energy, the obstacles' stored energy that potential leaves out,
against values derived here, at each rank count. A flat cloth of N x N vertices of equal mass
m_v = MASS / N^2, none fixed, over a horizontal plane: gravity alone acts across it, so every vertex
moves alike and every one is at the same distance d from the plane.
- the barrier (implicit Euler): a cloth that starts at d = 0.005 within dhat = 0.02 holds at step 0
  kappa MASS b(d), b(d) = -(d - dhat)^2 log(d / dhat), kappa = 1/(h^2 b''(dhat/2)) (the default);
- the penalty (symplectic Euler, kc given): in each row with vertices in contact (d < 0), each
  pushed with kc |d|, N^2 kc d^2 / 2 = contact_fz^2 / (2 kc N^2), from the row's own force; 0 in
  rows without contact;
- the landing's energy: while the cloth dropped 5 cm is in the penalty, total (kinetic + potential)
  dips by the energy stored there (half or more of what the drop gave, m g 0.05), and total plus
  contact_energy stays within 1% of that stored energy of its start (rk4: the energy the
  integrator loses is of order (omega h)^4, omega = sqrt(kc / m_v)).
- a restart whose monitor file has another header (an older msim's columns, without
  contact_energy) is refused in one line, the file left as it was (rows of this layout appended
  to it would not fit its header).
Usage: contact_energy.py path/to/msim [--np N]"""
import os
import sys
import tempfile

import numpy as np

import msimtest as mt

G, MASS, N = 9.81, 2.0, 5


def barrier(d, dhat):
    """b(d) and b''(d) of IPC's barrier"""
    lg = np.log(d / dhat)
    return -(d - dhat) ** 2 * lg, -2 * lg - 4 * (d - dhat) / d + (d - dhat) ** 2 / d ** 2


def main():
    exe, check = mt.msim_path(), mt.Checks()
    tmp = tempfile.mkdtemp(prefix="msim_contact_energy_")
    cloth = ["-msim_cloth_n", str(N), "-msim_fix", "none", "-msim_mass", str(MASS)]
    for np_ in mt.ranks():
        # the barrier at the start
        h, d, dhat = 0.01, 0.005, 0.02
        csv = os.path.join(tmp, f"barrier_{np_}.csv")
        r = mt.run(exe, cloth + ["-msim_integrator", "implicit_euler", "-msim_contact_plane", f"0,0,1,{-d}", "-msim_contact_distance", str(dhat),
                                 "-msim_dt", str(h), "-msim_steps", "1", "-msim_monitor_csv", csv], np_)
        if check(r.returncode == 0, f"np {np_}: barrier: runs ({r.stderr.strip()[-300:]})"):
            b, _ = barrier(d, dhat)
            kappa = 1 / (h * h * barrier(dhat / 2, dhat)[1])
            want, got = kappa * MASS * b, float(mt.read_csv(csv)[0].get("contact_energy", "nan"))
            check(abs(got - want) <= 1e-9 * want, f"np {np_}: barrier: step 0's contact_energy is kappa MASS b(d) = {want!r} J (got {got!r})")
        # the penalty through a landing
        kc = 2000.0
        for integ, dt, steps in (("symplectic_euler", "0.0005", "600"), ("rk4", "0.0005", "600")):
            csv = os.path.join(tmp, f"penalty_{integ}_{np_}.csv")
            r = mt.run(exe, cloth + ["-msim_integrator", integ, "-msim_contact_plane", "0,0,1,-0.05", "-msim_contact_stiffness", str(kc),
                                     "-msim_dt", dt, "-msim_steps", steps, "-msim_monitor_csv", csv], np_)
            if not check(r.returncode == 0, f"np {np_}: penalty, {integ}: runs ({r.stderr.strip()[-300:]})"):
                continue
            rows = mt.read_csv(csv)
            if not check(rows and "contact_energy" in rows[0], f"np {np_}: penalty, {integ}: the monitor has a contact_energy column ({list(rows[0]) if rows else []})"):
                continue
            ec = np.array([float(w["contact_energy"]) for w in rows])
            n = np.array([int(w["contact_n"]) for w in rows])
            fz = np.array([float(w["contact_fz"]) for w in rows])
            total = np.array([float(w["total"]) for w in rows])
            touching = n > 0
            want = np.where(touching, fz ** 2 / (2 * kc * np.maximum(n, 1)), 0.0)
            # contact_fz is printed to 10 digits (5e-10 relative), so its square to 1e-9
            check(touching.sum() > 10 and (n[touching] == N * N).all() and (np.abs(ec - want) <= 2e-9 * want).all(),
                  f"np {np_}: penalty, {integ}: contact_energy is fz^2 / (2 kc n) in the {touching.sum()} rows with the {N * N} vertices in contact, 0 elsewhere "
                  f"(worst {(np.abs(ec - want) / np.maximum(want, 1e-300)).max():.3g} relative; up to {ec.max():.3g} J)")
            if integ == "rk4":
                stored, drop = ec.max(), MASS * G * 0.05
                dip = total[0] - total.min()
                drift = np.abs(total + ec - total[0]).max()
                check(stored >= 0.5 * drop and dip >= 0.5 * stored and drift <= 1e-2 * stored,
                      f"np {np_}: penalty, rk4: total dips {dip:.4g} J while the penalty stores up to {stored:.4g} J (the drop gave {drop:.4g} J); total + contact_energy stays within {drift:.3g} J of its start")
        # a restart onto a monitor file of other columns
        ck, csv = os.path.join(tmp, f"old_{np_}.ck"), os.path.join(tmp, f"old_{np_}.csv")
        base = cloth + ["-msim_integrator", "symplectic_euler", "-msim_contact_plane", "0,0,1,-0.05", "-msim_dt", "0.0005"]
        r = mt.run(exe, base + ["-msim_steps", "4", "-msim_checkpoint", ck, "-msim_checkpoint_every", "2", "-msim_monitor_csv", csv], np_)
        if check(r.returncode == 0, f"np {np_}: restart: the first run runs ({r.stderr.strip()[-300:]})"):
            text = open(csv).read().splitlines()
            older = "\n".join([text[0].replace(",contact_energy", "")] + [",".join(v for i, v in enumerate(row.split(",")) if i != 13) for row in text[1:]]) + "\n"
            open(csv, "w").write(older)
            r = mt.run(exe, base + ["-msim_steps", "6", "-msim_restart", ck, "-msim_monitor_csv", csv], np_)
            err = mt.lines(r.stderr)
            check(r.returncode != 0 and len(err) == 1 and "-msim_monitor_csv" in err[0] and "its header is not this msim's columns" in err[0] and open(csv).read() == older,
                  f"np {np_}: restart onto a monitor file without contact_energy: refused in one line, the file untouched ({err})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
