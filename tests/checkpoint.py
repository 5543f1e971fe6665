#!/usr/bin/env python3
"""Checkpoint and restart (-msim_checkpoint, -msim_restart):
- a run stopped at step 30 with a checkpoint and restarted to step 60 ends bit for bit where the
  uninterrupted run does at the same rank count (1 and 2), to roundoff at another (1 -> 2), with
  the same frames in series.pvd and the same monitor rows (all but the wall time), rows left
  after the checkpoint by a run that died (one half written) dropped;
- a run killed with SIGKILL at a random moment and restarted from its last checkpoint ends the same,
  with the same complete frames and monitor rows, and no .tmp left behind;
- SIGTERM stops a run after a whole step with one line and a checkpoint of that step (1 and 2
  ranks), from which it goes on to the same end;
- a checkpoint of another scene, a damaged or foreign file, a missing one and one with nothing
  left to run are refused with one line, and no output directory is made;
- the mesh file is compared by content, not by path: its copy under another name restarts bit for
  bit, the file scaled by 1.01 in place (the same counts and options) is refused;
- BDF2 restarted at another -msim_dt starts up again, saying so once;
- the clock through a restart at another -msim_dt and a second restart from that run's
  checkpoint: the monitor's t runs on, and moving handles end at x0 + v T;
- a restart's monitor file written by another run is refused and left as it was."""
import os
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

import msimtest as mt

MSIM = mt.msim_path()
SCENE = ["-msim_cloth_n", "16", "-msim_integrator", "implicit_euler", "-msim_dt", "0.005", "-snes_type", "pd", "-snes_pd_anderson", "5",
         "-snes_max_it", "8", "-snes_pd_fixed", "-msim_output_every", "10", "-msim_wind", "1,0,2", "-msim_drag", "0.01"]
check = mt.Checks()


def run(np, args, cwd):
    return mt.run(MSIM, args, np, cwd=cwd)


final = mt.read_binary_vec  # positions written by -msim_view_final binary:PATH


def frames(out):
    listed = mt.frames(out)
    return listed, {f: open(os.path.join(out, f), "rb").read() for f in listed}


def monitor(path):
    rows = open(path).read().splitlines()
    return [",".join(r.split(",")[:-1]) for r in rows]  # all but wall_s


def whole(tmp, np, name, steps, extra=()):
    out = os.path.join(tmp, name)
    r = run(np, SCENE + ["-msim_steps", str(steps), "-msim_output", out, "-msim_monitor_csv", out + ".csv",
                         "-msim_view_final", f"binary:{out}.bin"] + list(extra), tmp)
    if r.returncode:
        print(r.stderr[-2000:])
    return out, r


def main():
    with tempfile.TemporaryDirectory() as tmp:
        ref = {}
        for np in (1, 2):
            out, r = whole(tmp, np, f"ref{np}", 60)
            check(r.returncode == 0, f"np={np}: the uninterrupted run")
            ref[np] = (final(out + ".bin"), frames(out), monitor(out + ".csv"))

        # stop at 30 with a checkpoint, go on to 60: at the same rank count and at another
        for np1, np2 in ((1, 1), (2, 2), (1, 2)):
            name = f"split{np1}{np2}"
            out = os.path.join(tmp, name)
            ck = os.path.join(tmp, name + ".ck")
            base = SCENE + ["-msim_output", out, "-msim_monitor_csv", out + ".csv", "-msim_checkpoint", ck, "-msim_checkpoint_every", "10"]
            r1 = run(np1, base + ["-msim_steps", "30"], tmp)
            # rows a run made after its checkpoint before it died, the last one half written:
            # the restart drops them (the rows must then be the uninterrupted run's)
            with open(out + ".csv", "a") as f:
                f.write("31,0.155,1,2,3,0,0,0,0,0\n32,0.16,1,2,3,0,0,0,0,0\n33,0.1")
            r2 = run(np2, base + ["-msim_steps", "60", "-msim_restart", ck, "-msim_view_final", f"binary:{out}.bin"], tmp)
            check(r1.returncode == 0 and r2.returncode == 0 and r2.stderr.strip() == "", f"{np1} -> {np2} ranks: both parts run ({r1.stderr.strip()[:200]} {r2.stderr.strip()[:200]})")
            if r1.returncode or r2.returncode:
                continue
            x, (listed, files), mon = final(out + ".bin"), frames(out), monitor(out + ".csv")
            rx, (rlisted, rfiles), rmon = ref[np1]
            if np1 == np2:
                check(x == rx, f"{np1} -> {np2} ranks: final positions bit for bit equal to the uninterrupted run")
                check(listed == rlisted and files == rfiles, f"{np1} -> {np2} ranks: the same frames, byte for byte ({len(listed)})")
            else:
                err = max(abs(a - b) for a, b in zip(x, rx))
                check(err < 1e-10, f"{np1} -> {np2} ranks: final positions equal to roundoff (max difference {err:.2e} m)")
                check(listed == rlisted, f"{np1} -> {np2} ranks: the same frames listed ({len(listed)})")
            check(mon == rmon if np1 == np2 else len(mon) == len(rmon), f"{np1} -> {np2} ranks: the monitor rows of the uninterrupted run ({len(mon)} lines)")

        # both series formats go on too, the first part stopped off the frame schedule (35, frames
        # every 10): the index is the uninterrupted run's, without the first part's end frame
        for fmt, index, entry in (("hdf5", "series.xdmf", '<Grid Name="frame_'), ("vtu", "series.pvd", "<DataSet ")):
            for name, parts in (("ref", [("60", [])]), ("split", [("35", []), ("60", ["-msim_restart"])])):
                out = os.path.join(tmp, fmt + name)
                for steps, extra in parts:
                    args = SCENE + ["-msim_output", out, "-msim_output_format", fmt, "-msim_checkpoint", out + ".ck", "-msim_steps", steps]
                    r = run(2, args + (extra + [out + ".ck"] if extra else []), tmp)
                    check(r.returncode == 0, f"{fmt} series, {name} to step {steps} ({r.stderr.strip()[:200]})")
            text = [open(os.path.join(tmp, fmt + n, index)).read() for n in ("ref", "split")]
            check(text[0] == text[1] and text[0].count(entry) == 7, f"{fmt} series: {index} after a restart at step 35 lists the uninterrupted run's 7 frames")

        # a restarted run's warnings count the steps it ran: 17 + 13, each stopped at one iteration
        small = ["-msim_cloth_n", "5", "-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-snes_max_it", "1", "-msim_checkpoint", "few.ck"]
        r1, r2 = (run(1, small + ["-msim_steps", n] + extra, tmp) for n, extra in (("17", []), ("30", ["-msim_restart", "few.ck"])))
        check(r1.returncode == 0 and "in 17 of 17 steps" in r1.stderr and r2.returncode == 0 and "in 13 of 13 steps" in r2.stderr,
              f"the unconverged-steps warning counts each part's own steps ({r1.stderr.strip()[:120]} | {r2.stderr.strip()[:120]})")

        # killed at a random moment, restarted from the last checkpoint
        random.seed(7)
        for np in (1, 2):
            name = f"kill{np}"
            out = os.path.join(tmp, name)
            ck = os.path.join(tmp, name + ".ck")
            args = SCENE + ["-msim_steps", "400", "-msim_output", out, "-msim_monitor_csv", out + ".csv", "-msim_checkpoint", ck, "-msim_checkpoint_every", "7",
                            "-msim_view_final", f"binary:{out}.bin"]
            refout, r = whole(tmp, np, f"kref{np}", 400)
            p = mt.popen(MSIM, args, np, cwd=tmp, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            # a random moment: after a random number of steps, somewhere between two checkpoints
            target, t0 = random.randint(20, 300), time.time()
            while (not os.path.exists(out + ".csv") or sum(1 for _ in open(out + ".csv")) < target) and time.time() - t0 < 60:
                time.sleep(0.005)
            mt.kill_all(p)
            r = run(np, args + ["-msim_restart", ck], tmp)
            check(r.returncode == 0, f"np={np}: restarted after SIGKILL ({r.stderr.strip()[:200]})")
            if r.returncode:
                continue
            leftovers = [f for f in os.listdir(out) + os.listdir(tmp) if f.endswith(".tmp")]
            check(final(out + ".bin") == final(refout + ".bin"), f"np={np}: killed and resumed ends bit for bit where the uninterrupted run does")
            check(frames(out) == frames(refout), f"np={np}: the same complete frames ({len(frames(out)[0])})")
            check(monitor(out + ".csv") == monitor(refout + ".csv"), f"np={np}: the same monitor rows")
            check(not leftovers, f"np={np}: no temporary file left ({leftovers})")

        # SIGTERM: one line, a checkpoint of the last whole step, and the run goes on from it (mpirun
        # forwards the signal to its ranks a few seconds late: the run is made long enough)
        for np in (1, 2):
            name = f"term{np}"
            out = os.path.join(tmp, name)
            ck = os.path.join(tmp, name + ".ck")
            args = SCENE + ["-msim_output", out, "-msim_checkpoint", ck, "-msim_checkpoint_every", "100000", "-msim_monitor_csv", out + ".csv"]
            p = mt.popen(MSIM, args + ["-msim_steps", "100000"], np, cwd=tmp, start_new_session=False,
                         stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            t0 = time.time()
            while (not os.path.exists(out + ".csv") or sum(1 for _ in open(out + ".csv")) < 20) and time.time() - t0 < 60:
                time.sleep(0.01)
            p.send_signal(signal.SIGTERM)
            err = p.communicate(timeout=120)[1]
            # msim's lines (mpirun's libevent may add a "[warn] Epoll ..." line of its own on a signal)
            lines = [l for l in mt.lines(err) if not l.startswith("[warn] Epoll")]
            stopped = len(lines) == 1 and "stopped by SIGTERM after step" in lines[0] and "-msim_restart" in lines[0]
            check(p.returncode != 0 and stopped and os.path.exists(ck), f"np={np}: SIGTERM stops with one line and a checkpoint (rc {p.returncode}, {lines[:3]})")
            if stopped:
                step = int(lines[0].split("after step ")[1].split()[0])
                rows = monitor(out + ".csv")
                check(rows[-1].startswith(f"{step},"), f"np={np}: the monitor's last row is the step named ({step})")
                r = run(np, args + ["-msim_steps", str(step + 10), "-msim_restart", ck], tmp)
                rows = monitor(out + ".csv")
                check(r.returncode == 0 and rows[-1].startswith(f"{step + 10},") and len(rows) == step + 12,
                      f"np={np}: resumed after SIGTERM to step {step + 10}, the monitor's rows continuing ({len(rows)} lines)")

        # refusals: one line, non-zero exit, no output directory
        ck = os.path.join(tmp, "split11.ck")
        shutil.copy(ck, os.path.join(tmp, "cut.ck"))
        with open(os.path.join(tmp, "cut.ck"), "r+b") as f:
            f.truncate(os.path.getsize(ck) - 100)
        with open(os.path.join(tmp, "junk.ck"), "wb") as f:
            f.write(os.urandom(4096))
        cases = [(["-msim_cloth_n", "17", "-msim_restart", ck], "a checkpoint of another scene (-msim_cloth_n 16 there, 17 here)"),
                 (["-msim_fix", "edge", "-msim_restart", ck], "a checkpoint of another scene (-msim_fix edge here, not there)"),
                 (["-msim_restart", os.path.join(tmp, "cut.ck")], "damaged checkpoint"),
                 (["-msim_restart", os.path.join(tmp, "junk.ck")], "not an msim checkpoint"),
                 (["-msim_restart", os.path.join(tmp, "none.ck")], "cannot open it"),
                 (["-msim_restart", ck, "-msim_steps", "50"], "the checkpoint is at step 60 and -msim_steps is 50: nothing left to run")]
        for np in (1, 2):
            for extra, message in cases:
                out = os.path.join(tmp, "refused")
                args = SCENE + ["-msim_steps", "60", "-msim_output", out]
                for k in range(0, len(extra), 2):  # later values win
                    args += extra[k:k + 2]
                r = run(np, args, tmp)
                lines = mt.lines(r.stderr)
                check(r.returncode != 0 and len(lines) == 1 and message in lines[0] and not os.path.exists(out),
                      f"np={np}: refused: {message} ({lines[:2]})")
        # the mesh file by content: a copy elsewhere is the same scene, the file scaled in place
        # another (restarted on it, the energy jumped from 1.86 to 2.02 J in one step)
        beam = ["-msim_scene", "tet", "-msim_fix_plane", "x_min", "-msim_density", "1000", "-msim_young", "5e5", "-msim_integrator", "implicit_euler",
                "-msim_dt", "0.005", "-snes_type", "pd", "-snes_max_it", "10", "-snes_pd_fixed"]
        for np in (1, 2):
            mesh, moved, ck, ref, xf = (os.path.join(tmp, f"beam_{np}{e}") for e in (".msh", "_moved.msh", ".ck", "_ref.bin", ".bin"))
            shutil.copy(os.path.join(mt.ROOT, "examples", "meshes", "beam.msh"), mesh)
            shutil.copy(mesh, moved)
            rs = [run(np, beam + ["-msim_mesh_file", mesh, "-msim_steps", "7", "-msim_view_final", f"binary:{ref}"], tmp),
                  run(np, beam + ["-msim_mesh_file", mesh, "-msim_steps", "5", "-msim_checkpoint", ck], tmp),
                  run(np, beam + ["-msim_mesh_file", moved, "-msim_steps", "7", "-msim_restart", ck, "-msim_view_final", f"binary:{xf}"], tmp)]
            ok = all(r.returncode == 0 for r in rs)
            check(ok and final(xf) == final(ref), f"np={np}: restarted on a copy of the mesh file under another name, bit for bit ({[r.stderr.strip()[:200] for r in rs]})")
            text = open(mesh).read().split("\n")
            at = text.index("$Nodes") + 1  # Gmsh 4.1: blocks of a header, the tags, the coordinates
            for _ in range(int(text[at].split()[0])):
                n = int(text[at + 1].split()[3])
                at += 1 + n
                for k in range(at + 1, at + 1 + n):
                    text[k] = " ".join(repr(1.01 * float(c)) for c in text[k].split()[:3])
                at += n
            open(mesh, "w").write("\n".join(text))
            r = run(np, beam + ["-msim_mesh_file", mesh, "-msim_steps", "7", "-msim_restart", ck], tmp)
            lines = mt.lines(r.stderr)
            check(r.returncode != 0 and len(lines) == 1 and f"a checkpoint of another scene (-msim_mesh_file {mesh}: the rest state differs: free vertices' mass" in lines[0],
                  f"np={np}: the mesh file scaled by 1.01 in place is refused ({lines[:2]})")
        # BDF2 restarted at another -msim_dt: its history (x_{n-1}, v_{n-1}) is one old step back,
        # so it starts up again, saying so once; BDF2 damps, so the undamped chain's energy does not
        # rise after the restart (taking the old history as one new step back, it rose from
        # -1.7e-3 J to +2.5e-3 J)
        chain = ["-msim_scene", "chain", "-msim_chain_n", "12", "-msim_fix", "corners", "-msim_integrator", "bdf2"]
        for np in (1, 2):
            ck, mon = os.path.join(tmp, f"bdf2_{np}.ck"), os.path.join(tmp, f"bdf2_{np}.csv")
            r0 = run(np, chain + ["-msim_dt", "0.01", "-msim_steps", "10", "-msim_checkpoint", ck, "-msim_monitor_csv", mon], tmp)
            e_ck = float(mt.read_csv(mon)[-1]["total"]) if r0.returncode == 0 else float("nan")
            r = run(np, chain + ["-msim_dt", "0.005", "-msim_steps", "16", "-msim_restart", ck, "-msim_monitor_csv", mon], tmp)
            lines = mt.lines(r.stderr)
            total = [float(row["total"]) for row in mt.read_csv(mon) if int(row["step"]) > 10] if r.returncode == 0 else []
            check(r.returncode == 0 and len(lines) == 1 and "starts up again" in lines[0] and total and max(total) <= e_ck + 1e-9,
                  f"np={np}: bdf2 restarted at half the step: one warning ({lines[:2]}), energy {e_ck:.6g} J at the checkpoint, at most {max(total) if total else float('nan'):.6g} J after")
        # the clock through two restarts, the first with another -msim_dt: 10 steps of 0.01 s, 10 of
        # 0.005 s to t = 0.15, then 10 more of 0.005 s from that run's checkpoint to t = 0.2 (were
        # restarted at 20 x 0.005 = 0.1 s: the monitor's t went back and the handles jumped back
        # along their path). The handles (the chain's ends, at x = 0 and 1 m) move at v = (0.5, 0,
        # 1) m/s: at T = 0.2 s they are v T from there, whatever the solver did
        chain = ["-msim_scene", "chain", "-msim_chain_n", "6", "-msim_fix", "corners", "-msim_integrator", "implicit_euler", "-msim_fix_velocity", "0.5,0,1"]
        for np in (1, 2):
            ck, mon, xf = (os.path.join(tmp, f"clock_{np}.{e}") for e in ("ck", "csv", "txt"))
            rs = [run(np, chain + ["-msim_dt", dt, "-msim_steps", n, "-msim_checkpoint", ck, "-msim_monitor_csv", mon] + extra, tmp)
                  for dt, n, extra in (("0.01", "10", []), ("0.005", "20", ["-msim_restart", ck]), ("0.005", "30", ["-msim_restart", ck, "-msim_view_final", mt.view_ascii(xf)]))]
            ok = all(r.returncode == 0 for r in rs)
            t = [float(row["t"]) for row in mt.read_csv(mon)] if ok else []
            want = [0.01 * k for k in range(11)] + [0.1 + 0.005 * k for k in range(1, 21)]
            check(ok and len(t) == len(want) and max(abs(a - b) for a, b in zip(t, want)) < 1e-12,
                  f"np={np}: restarted with -msim_dt 0.005 after 10 steps of 0.01, then again: the monitor's t runs on to 0.2 s ({t[19:23] if t else [r.stderr.strip()[:200] for r in rs]})")
            x = mt.positions(xf) if ok else None
            ends = [[0.1, 0, 0.2], [1.1, 0, 0.2]]
            err = max(abs(x[i][j] - ends[k][j]) for k, i in enumerate((0, 5)) for j in range(3)) if ok else float("nan")
            check(err < 1e-12, f"np={np}: the handles end at x0 + v T, T = 0.2 s (off by {err:.2e} m)")
        # a restart's -msim_monitor_csv that another run wrote (here a cloth's, at 0.01 s a step,
        # or a chain's that stopped before the checkpoint's step) is refused and left as it is;
        # its rows were kept and the restart's appended to them (rows of t = 0.01 k, then 0.55 s)
        chain = ["-msim_scene", "chain", "-msim_chain_n", "5", "-msim_integrator", "implicit_euler", "-msim_dt", "0.05"]
        ck = os.path.join(tmp, "foreign.ck")
        run(1, chain + ["-msim_steps", "10", "-msim_checkpoint", ck], tmp)
        for np, first in ((1, ["-msim_cloth_n", "6", "-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "20"]),
                          (2, chain + ["-msim_steps", "5"])):
            mon, out = os.path.join(tmp, f"foreign_{np}.csv"), os.path.join(tmp, f"foreign_{np}")
            run(1, first + ["-msim_monitor_csv", mon], tmp)
            before = open(mon, "rb").read() if os.path.exists(mon) else None
            r = run(np, chain + ["-msim_steps", "20", "-msim_restart", ck, "-msim_monitor_csv", mon, "-msim_output", out], tmp)
            lines = mt.lines(r.stderr)
            check(before is not None and r.returncode != 0 and len(lines) == 1 and "another run's monitor" in lines[0]
                  and open(mon, "rb").read() == before and not os.path.exists(out),
                  f"np={np}: a restart onto another run's monitor file is refused, the file untouched ({lines[:2]})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
