#!/usr/bin/env python3
"""Checkpoint and restart with a solver that carries state from one time step's solve to the next
(issue 33): SNES pd's L-BFGS (-snes_pd_lbfgs m) keeps its m pairs (s, y), their rho and the ring's
position, so a step's fixed-iteration result depends on them, not only on x and v; ntr keeps its
trust radius. Checkpoints carry that state (MSimSolverHistory). A cloth in wind, checkpointed at
step 10 and restarted to step 20, must end bit for bit where the uninterrupted run does, at the
same rank count:
- -snes_pd_lbfgs 5 with implicit Euler and with BDF2 (whose own history is carried too), with a
  fixed iteration count and run to a tolerance, and as the pd NPC of PETSc's anderson;
- ntr (its radius), and pd with -snes_pd_anderson (which starts afresh each solve: nothing to
  carry, and restarts bit for bit already).
PETSc 3.18's qn keeps its pairs across solves inside a Mat that has no way to read them: its restart
is not bit for bit, and says so in one line (the others print no such line).
The checkpoint holds the pairs: with -snes_pd_lbfgs 5 it is larger than plain PD's by the 2 m
vectors of 3 n doubles, the m + 8 scalars and the name "pd_lbfgs". At 2 ranks, a 1-rank
checkpoint restarted at 2 ranks gets the pairs redistributed as x and v are: it ends within
roundoff of the 2-rank run (the pairs dropped, it ends millimetres away).
Before the pairs were carried, every L-BFGS comparison failed (3 mm to 9 mm off).
Usage: pd_lbfgs_restart.py path/to/msim [--np N]"""
import os
import tempfile

import msimtest as mt

MSIM = mt.msim_path()
N = 13  # 13 x 13 vertices
SCENE = ["-msim_cloth_n", str(N), "-msim_dt", "0.02", "-msim_wind", "1,0,2", "-msim_drag", "0.01"]
M = 5
LBFGS = ["-snes_type", "pd", "-snes_pd_lbfgs", str(M)]
FIXED = ["-snes_max_it", "8", "-snes_pd_fixed"]
CASES = {
    "implicit Euler, L-BFGS 5, 8 iterations": ["-msim_integrator", "implicit_euler"] + LBFGS + FIXED,
    "BDF2, L-BFGS 5, 8 iterations": ["-msim_integrator", "bdf2"] + LBFGS + FIXED,
    "BDF2, L-BFGS 5 to |g| <= 1e-4 |g0|": ["-msim_integrator", "bdf2"] + LBFGS + ["-snes_max_it", "60", "-snes_rtol", "1e-4"],
    "implicit Euler, anderson with pd L-BFGS 5 as its NPC": ["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-snes_max_it", "4",
                                                             "-snes_rtol", "0", "-snes_atol", "0", "-npc_snes_type", "pd", "-npc_snes_pd_lbfgs", str(M),
                                                             "-npc_snes_max_it", "2", "-npc_snes_pd_fixed"],
    "BDF2, ntr": ["-msim_integrator", "bdf2", "-snes_type", "ntr"],
    "implicit Euler, pd Anderson 5": ["-msim_integrator", "implicit_euler", "-snes_type", "pd", "-snes_pd_anderson", "5"] + FIXED,
}
SPLIT, END = 10, 20
QN_WARNING = "-msim_restart with -snes_type qn"
check = mt.Checks()


def runs(tmp, np_ck, np_end, args, tag):
    """the uninterrupted run at np_end ranks, and the run checkpointed at SPLIT at np_ck ranks and
    restarted at np_end; (final positions of both, the checkpoint's size, the restart's stderr),
    or None"""
    ref, ck, rs = (os.path.join(tmp, f) for f in ("ref.bin", "run.ck", "rs.bin"))
    r = mt.run(MSIM, SCENE + args + ["-msim_steps", str(END), "-msim_view_final", f"binary:{ref}"], np_end, cwd=tmp)
    r1 = mt.run(MSIM, SCENE + args + ["-msim_steps", str(SPLIT), "-msim_checkpoint", ck], np_ck, cwd=tmp)
    size = os.path.getsize(ck) if r1.returncode == 0 else 0
    r2 = mt.run(MSIM, SCENE + args + ["-msim_steps", str(END), "-msim_restart", ck, "-msim_view_final", f"binary:{rs}"], np_end, cwd=tmp)
    ok = r.returncode == 0 and r1.returncode == 0 and r2.returncode == 0
    if not check(ok, f"{tag}: the three runs" + ("" if ok else f" ({(r.stderr + r1.stderr + r2.stderr).strip()[-300:]})")):
        return None
    return mt.read_binary_vec(rs), mt.read_binary_vec(ref), size, r2.stderr


def one_count(tmp, np_):
    sizes = {}
    for name, args in CASES.items():
        got = runs(tmp, np_, np_, args, f"np {np_}, {name}")
        if not got:
            continue
        x, rx, sizes[name], err_text = got
        err = max(abs(a - b) for a, b in zip(x, rx))
        check(x == rx, f"np {np_}, {name}: restarted at step {SPLIT}, step {END} is bit for bit the uninterrupted run's (max difference {err:.3g} m)")
        check(QN_WARNING not in err_text, f"np {np_}, {name}: no warning that the restart is not bit for bit")
    # PETSc's qn keeps pairs no checkpoint reaches: the restart says so, once
    got = runs(tmp, np_, np_, ["-msim_integrator", "bdf2", "-snes_type", "qn", "-snes_qn_scale_type", "jacobian", "-snes_max_it", "30"], f"np {np_}, BDF2, qn")
    if got:
        lines = [l for l in mt.lines(got[3]) if QN_WARNING in l]
        check(len(lines) == 1, f"np {np_}, BDF2, qn: the restart warns once that it is not bit for bit ({lines})")
    # the pairs in the file: the difference to plain PD's checkpoint, from the format
    got = runs(tmp, np_, np_, ["-msim_integrator", "bdf2", "-snes_type", "pd"] + FIXED, f"np {np_}, BDF2, plain PD")
    name = "BDF2, L-BFGS 5, 8 iterations"
    if got and name in sizes:
        vec = 8 + 3 * N * N * 8  # a PETSc binary Vec: class id, size, 3 n doubles
        want = 2 * M * vec + (M + 10 + M * M) * 8 + len("pd_lbfgs")
        check(sizes[name] - got[2] == want, f"np {np_}: the L-BFGS checkpoint is {sizes[name] - got[2]} bytes larger than plain PD's ({want}: {2 * M} vectors, {M + 10 + M * M} scalars with the Gram matrix and its validity, the name)")
    # pairs made without the fused gradient keep no Gram rows: a fused restart must not read them
    ck = os.path.join(tmp, "unfused.ck")
    base = SCENE + CASES["BDF2, L-BFGS 5, 8 iterations"]
    r1 = mt.run(MSIM, base + ["-msim_steps", str(SPLIT), "-msim_checkpoint", ck, "-snes_pd_lbfgs_fused", "0"], np_, cwd=tmp)
    r2 = mt.run_info(MSIM, base + ["-msim_steps", str(SPLIT + 2), "-msim_restart", ck], np_, cwd=tmp)
    afresh = [l for l in mt.lines(r2.info) if "no Gram rows" in l]
    check(r1.returncode == 0 and r2.returncode == 0 and len(afresh) >= 1,
          f"np {np_}: a fused restart from pairs made with -snes_pd_lbfgs_fused 0 starts the history afresh ({len(afresh)} -info lines; rc {r1.returncode}, {r2.returncode})")
    if np_ > 1:
        # another rank count: the pairs follow the vertices to their new owners
        name = "BDF2, L-BFGS 5, 8 iterations"
        got = runs(tmp, 1, np_, CASES[name], f"np 1 -> {np_}, {name}")
        if got:
            err = max(abs(a - b) for a, b in zip(got[0], got[1]))
            check(err < 1e-7, f"np 1 -> {np_}, {name}: restarted at another rank count, within roundoff (grown over {END - SPLIT} steps; 1e-7 m) of the {np_}-rank run ({err:.3g} m)")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        for np_ in mt.ranks():
            one_count(tmp, np_)
    return check.exit_code()


if __name__ == "__main__":
    raise SystemExit(main())
