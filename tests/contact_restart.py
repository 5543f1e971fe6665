#!/usr/bin/env python3
"""Checkpoint and restart of a PD run on an obstacle (issue 34): the factor of PD's matrix holds the
barrier's weights of the vertices near the obstacle, kept over many steps by the lazy rule
(-msim_contact_pd_refactor), so a fixed-iteration PD step depends on the weights the factor was
made with, not only on x and v. A checkpoint carries them; a cloth landing on a plane (and one on a
ball), checkpointed at step 24 while resting in contact and restarted to step 36, must end bit for bit
where the uninterrupted run does, at 1 and 2 ranks, under both refactorization rules. Before the
weights were carried, the restarted run refactored at its first step with that step's weights and
ended 2e-12 m away.
PD + L-BFGS with its fused gradient (-snes_pd_lbfgs 5, run to its tolerance) on a ball, checkpointed
at step 13 in contact and restarted to step 30, likewise: the restart must put the weights into A
before its first step. Assembled at that step's first gradient, A changed there where the run's did
not, so the fused gradient took it for a new A, computed that step by the product and dropped its
pairs: the restarted run ended 1.9e-4 m away.
The explicit penalty on a shell (an open sheet with -msim_contact_thickness: a heavy cloth lands
on it with symplectic Euler, its vertices sinking past the sheet's mid-surface), checkpointed at
step 150 with vertices past the surface and restarted to step 300, likewise: the checkpoint must
carry each vertex's side. Before it did, the restarted vertices past the surface took the nearer
side, were pushed out below, and the cloth fell through the sheet (1.5 m away at step 600).
Usage: contact_restart.py path/to/msim [--np N]"""
import tempfile
import os

import msimtest as mt

MSIM = mt.msim_path()
BASE = ["-msim_cloth_n", "13", "-msim_fix", "none", "-msim_integrator", "implicit_euler", "-msim_dt", "0.02",
        "-snes_type", "pd", "-snes_max_it", "20", "-snes_pd_fixed"]
OBSTACLES = {"plane": ["-msim_contact_plane", "0,0,1,-0.3"],
             "ball": ["-msim_contact_sphere", "0.5,0.5,-0.5,0.3", "-msim_friction", "0.3"]}
SPLIT, END = 24, 36
LBFGS = ["-msim_cloth_n", "11", "-msim_fix", "none", "-msim_dt", "0.02", "-msim_integrator", "implicit_euler",
         "-snes_type", "pd", "-snes_pd_lbfgs", "5", "-msim_contact_sphere", "0.5,0.5,-0.3,0.2"]
LBFGS_SPLIT, LBFGS_END = 13, 30
SHEET_Z = -0.1
SHELL = ["-msim_cloth_n", "11", "-msim_fix", "none", "-msim_mass", "300", "-msim_integrator", "symplectic_euler", "-msim_dt", "1e-3",
         "-msim_contact_thickness", "0.01", "-msim_progress", "0"]
SHELL_SPLIT, SHELL_END = 150, 300
check = mt.Checks()


final = mt.read_binary_vec  # positions written by -msim_view_final binary:PATH


def restart_matches(tmp, np_, scene, split, end, tag):
    """the uninterrupted run to end, and the run checkpointed at split (in contact there) and
    restarted to end: their final positions bit for bit"""
    ref, ck = os.path.join(tmp, "ref.bin"), os.path.join(tmp, "run.ck")
    r = mt.run(MSIM, scene + ["-msim_steps", str(end), "-msim_view_final", f"binary:{ref}"], np_, cwd=tmp)
    r1 = mt.run(MSIM, scene + ["-msim_steps", str(split), "-msim_checkpoint", ck, "-msim_checkpoint_every", "6",
                               "-msim_monitor_csv", os.path.join(tmp, "m.csv")], np_, cwd=tmp)
    r2 = mt.run(MSIM, scene + ["-msim_steps", str(end), "-msim_restart", ck, "-msim_view_final", f"binary:{tmp}/rs.bin"], np_, cwd=tmp)
    if not check(r.returncode == 0 and r1.returncode == 0 and r2.returncode == 0,
                 f"{tag}: the three runs ({(r.stderr + r1.stderr + r2.stderr).strip()[-300:]})"):
        return
    # in contact at the checkpoint (the weights are then in the factor): the monitor's count
    rows = mt.read_csv(os.path.join(tmp, "m.csv"))
    check(float(rows[-1]["contact_n"]) > 0, f"{tag}: {rows[-1]['contact_n']} vertices in contact at the checkpoint")
    x, rx = final(f"{tmp}/rs.bin"), final(ref)
    err = max(abs(a - b) for a, b in zip(x, rx))
    check(x == rx, f"{tag}: restarted run bit for bit equal to the uninterrupted one (max difference {err:.3g} m)")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        sheet = os.path.join(tmp, "sheet.obj")
        with open(sheet, "w") as f:
            f.write(f"v -1 -1 {SHEET_Z}\nv 2 -1 {SHEET_Z}\nv 2 2 {SHEET_Z}\nv -1 2 {SHEET_Z}\nf 1 2 3\nf 1 3 4\n")
        for np_ in mt.ranks():
            for name, obstacle in OBSTACLES.items():
                for rule in ("4", "0"):
                    restart_matches(tmp, np_, BASE + obstacle + ["-msim_contact_pd_refactor", rule], SPLIT, END,
                                    f"np {np_}, {name}, -msim_contact_pd_refactor {rule}")
            restart_matches(tmp, np_, LBFGS, LBFGS_SPLIT, LBFGS_END, f"np {np_}, ball, -snes_pd_lbfgs 5 (fused gradient)")
            shell = SHELL + ["-msim_contact_mesh", sheet]
            # the premise: at the checkpoint some vertex is past the sheet's surface
            r = mt.run(MSIM, shell + ["-msim_steps", str(SHELL_SPLIT), "-msim_view_final", f"binary:{tmp}/split.bin"], np_, cwd=tmp)
            if check(r.returncode == 0, f"np {np_}: the shell run to step {SHELL_SPLIT} ({r.stderr.strip()[-300:]})"):
                low = min(final(f"{tmp}/split.bin")[2::3])
                check(low < SHEET_Z, f"np {np_}: shell: a vertex past the surface z = {SHEET_Z} at step {SHELL_SPLIT} (lowest z {low:.4g})")
            restart_matches(tmp, np_, shell, SHELL_SPLIT, SHELL_END, f"np {np_}, shell, symplectic_euler's penalty")
    return check.exit_code()


if __name__ == "__main__":
    raise SystemExit(main())
