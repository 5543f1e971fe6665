#!/usr/bin/env python3
"""msimllt's partial refactorization in a PD drape (issue 34): PD's matrix changes between
factorizations only on the diagonal rows of the vertices near the obstacle (the barrier's
weights), and msimllt then recomputes only the supernodes those rows reach
(src/solvers/supernodal_numeric.h), which must be bit for bit the full refactorization. A 31 x 31
cloth draped on the ball with friction (PD-10, 24 steps): the run with partial refactorizations
(the default) and the run with -pd_pc_msimllt_partial 0 end at the same positions bit for bit,
with the same monitor (every column but the wall time), and every factorization after the first
is partial (-log_view's MSimLLTPartial count; on several ranks each rank's local factor is
refactored in part and the dense interface Schur complement in full). And a checkpoint at step 12 restarted to step 24
(its first factorization from scratch, later ones partial) ends where the uninterrupted run does,
bit for bit.
Usage: contact_llt_partial.py path/to/msim [--np N]"""
import os
import re
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
BASE = ["-msim_cloth_n", "31", "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.0333333333333",
        "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed", "-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_friction", "0.3"]
END, SPLIT = 24, 12
check = mt.Checks()


def count(log, event):
    """an event's count in a -log_view file, summed over its stages"""
    with open(log) as f:
        return sum(int(c) for c in re.findall(rf"^{event}\s+(\d+)", f.read(), re.M))


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            runs = {}
            for partial in ("1", "0"):
                tag = f"np {np_}, -pd_pc_msimllt_partial {partial}"
                csv, log, fin = (os.path.join(tmp, f"{k}{partial}") for k in ("m.csv", "log.txt", "x.bin"))
                r = mt.run(MSIM, BASE + ["-msim_steps", str(END), "-pd_pc_msimllt_partial", partial, "-msim_monitor_csv", csv,
                                         "-log_view", f"ascii:{log}", "-msim_view_final", f"binary:{fin}"], np_, cwd=tmp)
                if not check(r.returncode == 0, f"{tag}: the run ({r.stderr.strip()[-300:]})"):
                    return check.exit_code()
                rows = mt.read_csv(csv)
                runs[partial] = (mt.read_binary_vec(fin), [{k: v for k, v in row.items() if k != "wall_s"} for row in rows],
                                 count(log, "MSimLLTFactor"), count(log, "MSimLLTPartial"), rows[-1])
            (x1, m1, f1, p1, last), (x0, m0, f0, p0, _) = runs["1"], runs["0"]
            tag = f"np {np_}"
            check(float(last["contact_n"]) > 0, f"{tag}: {last['contact_n']} vertices in contact at step {END}")
            check(f1 >= 3 and f0 == f1, f"{tag}: {f1} and {f0} factorizations (several, the same count)")
            want = f1 - 1
            check(p1 == want and p0 == 0, f"{tag}: {p1} partial refactorizations of {f1} (expected {want}), {p0} with partial 0")
            err = max(abs(a - b) for a, b in zip(x1, x0))
            check(x1 == x0, f"{tag}: final positions bit for bit with and without partial refactorization (max difference {err:.3g} m)")
            check(m1 == m0, f"{tag}: the monitors identical but for wall time")
            # a restart factors from scratch, then partially
            ck = os.path.join(tmp, "run.ck")
            r1 = mt.run(MSIM, BASE + ["-msim_steps", str(SPLIT), "-msim_checkpoint", ck, "-msim_checkpoint_every", str(SPLIT)], np_, cwd=tmp)
            r2 = mt.run(MSIM, BASE + ["-msim_steps", str(END), "-msim_restart", ck, "-msim_view_final", f"binary:{tmp}/rs.bin",
                                      "-log_view", f"ascii:{tmp}/rs.txt"], np_, cwd=tmp)
            if check(r1.returncode == 0 and r2.returncode == 0, f"{tag}: the restart runs ({(r1.stderr + r2.stderr).strip()[-300:]})"):
                xr = mt.read_binary_vec(f"{tmp}/rs.bin")
                err = max(abs(a - b) for a, b in zip(xr, x1))
                check(xr == x1, f"{tag}: restarted at step {SPLIT}, bit for bit the uninterrupted run (max difference {err:.3g} m; "
                      f"{count(tmp + '/rs.txt', 'MSimLLTPartial')} partial refactorizations after the restart)")
    return check.exit_code()


if __name__ == "__main__":
    raise SystemExit(main())
