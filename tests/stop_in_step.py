#!/usr/bin/env python3
"""A stop signal inside a step that lasts seconds (msim/signals.h):
- SIGTERM to msim at 1 rank, or to its ranks at 2 (as a batch system sends it; mpirun forwards it
  about 2 s late and kills the ranks 1 s after that), while step 2 of an implicit run is being solved: one line, "stopped by SIGTERM after step 1 ...
  step 2 given up", a non-zero exit well within the step's length, and a checkpoint that holds
  step 1's state exactly: byte for byte the checkpoint a run of one step writes at that rank count. A stop after the
  step (the old rule) named step 2 at 1 rank and was killed before its checkpoint at 2 where the
  step outlasted the 1 s;
- the same for ts, whose one interval takes thousands of internal steps (adaptive, a tight
  tolerance): stopped between them, step 1's state kept (was: a failed step, no checkpoint);
- the run restarted from that checkpoint takes step 2 and ends without a word;
- inside the run's first step (bdf2) nothing is saved, and the line says so; -snes_converged_reason
  says "Nonlinear solve stopped by SIGTERM" for the stopped solve (PETSc's own line named the
  stand-in reason DIVERGED_FUNCTION_DOMAIN, a failure that was none).
The steps' length is set by a fixed PD iteration count (ts: by the tolerance), about 3 s here;
the checks hold as long as a step lasts well over the test's 5 ms poll of the monitor file."""
import os
import re
import signal
import subprocess
import sys
import tempfile
import time

import msimtest as mt

MSIM = mt.msim_path()
check = mt.Checks()
SCENES = {
    "pd": ["-msim_cloth_n", "16", "-msim_integrator", "implicit_euler", "-msim_dt", "0.005", "-snes_type", "pd",
           "-snes_pd_fixed", "-snes_max_it", "60000"],
    "newton": ["-msim_cloth_n", "16", "-msim_integrator", "bdf2", "-msim_dt", "0.005", "-snes_type", "newtonls",
               "-snes_rtol", "0", "-snes_atol", "0", "-snes_stol", "0", "-snes_max_it", "1500", "-msim_step_atol", "0"],
    "ts": ["-msim_cloth_n", "16", "-msim_integrator", "ts", "-ts_type", "rk", "-ts_rk_type", "5f", "-ts_adapt_type", "basic", "-msim_dt", "1",
           "-ts_atol", "1e-10", "-ts_rtol", "1e-10", "-msim_ts_max_substeps", "10000000"],
}


def ranks_of(p, np):
    """the processes to signal: msim itself at 1 rank, mpirun's children (the ranks) at more, as a
    batch system signals them: mpirun's own forwarding takes about 2 s, which a step on a fast
    machine need not outlast"""
    if np == 1:
        return [p.pid]
    kids = []
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                stat = open(f"/proc/{d}/stat").read()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == p.pid:
                kids.append(int(d))
    return kids


def rows(path):
    try:
        return open(path).read().splitlines()
    except OSError:
        return []


with tempfile.TemporaryDirectory() as tmp:
    for name, scene in SCENES.items():
        for np in mt.ranks():
            # the reference: one step at the same rank count, its checkpoint
            ref = os.path.join(tmp, f"{name}{np}_ref.ck")
            t0 = time.time()
            r = mt.run(MSIM, scene + ["-msim_steps", "1", "-msim_checkpoint", ref], np, cwd=tmp)
            step_s = time.time() - t0
            check(r.returncode == 0 and os.path.exists(ref), f"{name} np={np}: one step with its checkpoint ({step_s:.1f} s; {r.stderr.strip()[:200]})")
            ck = os.path.join(tmp, f"{name}{np}.ck")
            mon = os.path.join(tmp, f"{name}{np}.csv")
            args = scene + ["-msim_steps", "4", "-msim_checkpoint", ck, "-msim_checkpoint_every", "100", "-msim_monitor_csv", mon]
            p = mt.popen(MSIM, args, np, cwd=tmp, start_new_session=False, stdin=subprocess.DEVNULL,
                         stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            t0 = time.time()
            while len(rows(mon)) < 3 and time.time() - t0 < 120 and p.poll() is None:  # header, step 0, step 1
                time.sleep(0.005)
            for pid in ranks_of(p, np):
                os.kill(pid, signal.SIGTERM)
            ts = time.time()
            err = p.communicate(timeout=120)[1]
            waited = time.time() - ts
            # msim's lines but its progress (a step of seconds prints one) and mpirun's libevent's
            lines = [l for l in mt.lines(err) if not l.startswith(("[warn] Epoll", "msim: step "))]
            said = len(lines) == 1 and "stopped by SIGTERM after step 1 of 4" in lines[0] and "step 2 given up" in lines[0]
            check(p.returncode != 0 and said, f"{name} np={np}: one line naming step 1, step 2 given up (rc {p.returncode}, {lines[:3]})")
            print(f"     {name} np={np}: stopped {waited:.2f} s after the signal; a step takes about {step_s:.1f} s")
            same = os.path.exists(ck) and open(ck, "rb").read() == open(ref, "rb").read()
            check(same, f"{name} np={np}: the checkpoint is step 1's, byte for byte the one-step run's")
            check(len(rows(mon)) == 3, f"{name} np={np}: the monitor's last row is step 1 ({len(rows(mon))} lines)")
            if os.path.exists(ck):
                r = mt.run(MSIM, scene + ["-msim_steps", "2", "-msim_restart", ck, "-msim_monitor_csv", mon], np, cwd=tmp)
                check(r.returncode == 0 and not mt.lines(r.stderr) and rows(mon)[-1].startswith("2,"),
                      f"{name} np={np}: restarted, it takes step 2 ({r.stderr.strip()[:200]})")
    # inside the run's first step: nothing to save (no step taken; BDF2's start-up history made up
    # at its BeginStep was written as history, and the restart took step 1 as a full BDF2 step)
    scene = SCENES["newton"]
    for np in mt.ranks():
        ck = os.path.join(tmp, f"first{np}.ck")
        mon = os.path.join(tmp, f"first{np}.csv")
        # with -snes_converged_reason: the stopped solve says so (PETSc's own line named the stand-in
        # reason, "did not converge due to DIVERGED_FUNCTION_DOMAIN")
        p = mt.popen(MSIM, scene + ["-msim_steps", "4", "-msim_checkpoint", ck, "-msim_monitor_csv", mon, "-snes_converged_reason"], np, cwd=tmp,
                     start_new_session=False, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        t0 = time.time()
        while len(rows(mon)) < 2 and time.time() - t0 < 120 and p.poll() is None:  # header, step 0
            time.sleep(0.005)
        for pid in ranks_of(p, np):
            os.kill(pid, signal.SIGTERM)
        out, err = p.communicate(timeout=120)
        lines = [l for l in mt.lines(err) if not l.startswith(("[warn] Epoll", "msim: step "))]
        reason = mt.lines(out)
        check(len(reason) == 1 and re.fullmatch(r"Nonlinear solve stopped by SIGTERM iterations \d+", reason[0].strip()),
              f"first step np={np}: -snes_converged_reason says the solve was stopped, in one line ({reason[:3]})")
        said = len(lines) == 1 and "after step 0 of 4" in lines[0] and "step 1 given up" in lines[0] and "nothing was saved" in lines[0]
        check(p.returncode != 0 and said and not os.path.exists(ck), f"first step np={np}: nothing saved, said in one line (rc {p.returncode}, {lines[:3]})")
sys.exit(check.exit_code())
