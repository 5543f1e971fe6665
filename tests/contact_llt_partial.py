#!/usr/bin/env python3
"""msimllt's partial refactorization in a PD drape (issue 34): PD's matrix changes between
factorizations only on the diagonal rows of the vertices near the obstacle (the barrier's
weights), and msimllt then recomputes only the supernodes those rows reach
(src/solvers/supernodal_numeric.h), which must be bit for bit the full refactorization. A 31 x 31
cloth draped on the ball with friction (PD-10, 24 steps): the run with partial refactorizations
(the default) and the run with -pd_pc_msimllt_partial 0 end at the same positions bit for bit,
with the same monitor (every column but the wall time), and every factorization after the first
is partial (-log_view's MSimLLTPartial count; on several ranks each rank's local factor is
refactored in part and the dense interface Schur complement in full). Both with
-pd_pc_msimllt_update 0: the low-rank update (src/solvers/llt_update.h), on by default, keeps the
base's factor while few diagonal entries changed and corrects the solves instead, which is not the
refactorization's bits. A run with updates of rank at most 12 (UPDATE: so that it both updates
and refactors, and the base is not the first matrix) must then take updates on one rank (never on
several) and end near the refactoring run: its solves differ by roundoff (test_llt_update: 1e-12
relative), but roundoff can flip the lazy rule's per-vertex decisions, and a flipped weight moves a
fixed-iteration PD step by up to its own iteration error, so the yardstick is that error: the
refactoring run with one more PD iteration a step (-snes_max_it 11) must be at least 10 times
further from it. And a checkpoint at step 12 of that run restarted to step 24 (the
restart factors the checkpoint's base, then updates as the uninterrupted run did) ends where the
uninterrupted run does, bit for bit.
Usage: contact_llt_partial.py path/to/msim [--np N]"""
import os
import re
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
BASE = ["-msim_cloth_n", "31", "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.0333333333333",
        "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed", "-msim_contact_sphere", "0.5,0.5,-0.4,0.3", "-msim_friction", "0.3"]
UPDATE = ["-pd_pc_msimllt_update_max_rank", "12"]
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
            for partial, extra in (("1", ["-pd_pc_msimllt_update", "0"]), ("0", ["-pd_pc_msimllt_update", "0"]),
                                   ("r", ["-pd_pc_msimllt_update", "0", "-snes_max_it", "11"]), ("u", UPDATE)):
                tag = f"np {np_}, {' '.join(extra)}"
                if partial in "01":
                    extra = extra + ["-pd_pc_msimllt_partial", partial]
                csv, log, fin = (os.path.join(tmp, f"{k}{partial}") for k in ("m.csv", "log.txt", "x.bin"))
                r = mt.run(MSIM, BASE + ["-msim_steps", str(END), *extra, "-msim_monitor_csv", csv,
                                         "-log_view", f"ascii:{log}", "-msim_view_final", f"binary:{fin}"], np_, cwd=tmp)
                if not check(r.returncode == 0, f"{tag}: the run ({r.stderr.strip()[-300:]})"):
                    return check.exit_code()
                rows = mt.read_csv(csv)
                runs[partial] = (mt.read_binary_vec(fin), [{k: v for k, v in row.items() if k != "wall_s"} for row in rows],
                                 count(log, "MSimLLTFactor"), count(log, "MSimLLTPartial"), rows[-1], count(log, "MSimLLTUpdate"))
            (x1, m1, f1, p1, last, _), (x0, m0, f0, p0, _, _) = runs["1"], runs["0"]
            tag = f"np {np_}"
            check(float(last["contact_n"]) > 0, f"{tag}: {last['contact_n']} vertices in contact at step {END}")
            check(f1 >= 3 and f0 == f1, f"{tag}: {f1} and {f0} factorizations (several, the same count)")
            want = f1 - 1
            check(p1 == want and p0 == 0, f"{tag}: {p1} partial refactorizations of {f1} (expected {want}), {p0} with partial 0")
            err = max(abs(a - b) for a, b in zip(x1, x0))
            check(x1 == x0, f"{tag}: final positions bit for bit with and without partial refactorization (max difference {err:.3g} m)")
            check(m1 == m0, f"{tag}: the monitors identical but for wall time")
            xr, xu, nu = runs["r"][0], runs["u"][0], runs["u"][5]
            yard = max(abs(a - b) for a, b in zip(xr, x1))
            err = max(abs(a - b) for a, b in zip(xu, x1))
            check(nu >= 1 if np_ == 1 else nu == 0, f"{tag}: {nu} low-rank updates (some on one rank, none on several)")
            check(err <= 0.1 * yard, f"{tag}: the run with updates ends {err:.3g} m from the refactoring run's positions "
                  f"(PD-10's iteration error, the refactoring run with -snes_max_it 11: {yard:.3g} m away)")
            x1 = xu  # the restart repeats the run with updates
            ck = os.path.join(tmp, "run.ck")
            r1 = mt.run(MSIM, BASE + UPDATE + ["-msim_steps", str(SPLIT), "-msim_checkpoint", ck, "-msim_checkpoint_every", str(SPLIT)], np_, cwd=tmp)
            r2 = mt.run(MSIM, BASE + UPDATE + ["-msim_steps", str(END), "-msim_restart", ck, "-msim_view_final", f"binary:{tmp}/rs.bin",
                                      "-log_view", f"ascii:{tmp}/rs.txt"], np_, cwd=tmp)
            if check(r1.returncode == 0 and r2.returncode == 0, f"{tag}: the restart runs ({(r1.stderr + r2.stderr).strip()[-300:]})"):
                xr = mt.read_binary_vec(f"{tmp}/rs.bin")
                err = max(abs(a - b) for a, b in zip(xr, x1))
                check(xr == x1, f"{tag}: restarted at step {SPLIT}, bit for bit the uninterrupted run (max difference {err:.3g} m; "
                      f"{count(tmp + '/rs.txt', 'MSimLLTPartial')} partial refactorizations after the restart)")
    return check.exit_code()


if __name__ == "__main__":
    raise SystemExit(main())
