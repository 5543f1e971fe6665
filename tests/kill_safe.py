#!/usr/bin/env python3
"""Nothing written is lost to a kill: a run killed with SIGKILL mid-way (one rank, and all processes
of a two-rank run at once) keeps its -msim_monitor_csv and -msim_monitor_convergence files with
every row made before the kill: the header, then complete rows of consecutive steps (the last line
may be cut), and every frame it listed in series.pvd complete."""
import os
import subprocess
import sys
import tempfile
import time

import msimtest as mt

MSIM = mt.msim_path()
ARGS = ["-msim_cloth_n", "30", "-msim_integrator", "implicit_euler", "-msim_dt", "0.01", "-msim_steps", "100000",
        "-snes_type", "pd", "-snes_max_it", "5", "-snes_pd_fixed", "-msim_output_every", "5"]


def rows_ok(path, header, fields, step_col):
    with open(path) as f:
        lines = f.read().split("\n")
    if not lines or lines[0] != header:
        return f"{path}: header {lines[:1]!r}"
    body = [l for l in lines[1:] if l]
    complete = [l for l in body[:-1]] + ([body[-1]] if body and len(body[-1].split(",")) == fields and lines[-1] == "" else [])
    if len(complete) < 3:
        return f"{path}: {len(complete)} complete rows"
    steps = [int(l.split(",")[step_col]) for l in complete]
    if any(len(l.split(",")) != fields for l in complete) or steps != sorted(steps) or steps[-1] - steps[0] + 1 < len(set(steps)):
        return f"{path}: rows out of order or cut: {complete[:2]} ... {complete[-2:]}"
    return None


def main():
    check = mt.Checks()
    with tempfile.TemporaryDirectory() as tmp:
        for np in (1, 2):
            csv = os.path.join(tmp, f"mon{np}.csv")
            hist = os.path.join(tmp, f"conv{np}.csv")
            out = os.path.join(tmp, f"out{np}")
            p = mt.popen(MSIM, ARGS + ["-msim_monitor_csv", csv, "-msim_monitor_convergence", hist, "-msim_output", out], np,
                         stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            deadline = time.time() + 60
            while time.time() < deadline:
                time.sleep(0.2)
                if os.path.exists(csv) and sum(1 for _ in open(csv)) > 20:
                    break
            mt.kill_all(p)
            problems = [m for m in (rows_ok(csv, "step,t,kinetic,potential,total,nonlinear_its,linear_its,residual,phi,contact_fx,contact_fy,contact_fz,contact_n,contact_energy,wall_s", 15, 0),
                                     rows_ok(hist, "step,iteration,wall_s,phi,gnorm", 5, 0)) if m]
            listed = mt.frames(out) if os.path.exists(os.path.join(out, "series.pvd")) else []
            for name in listed:
                data = open(os.path.join(out, name), "rb").read()
                if not data.rstrip().endswith(b"</VTKFile>"):
                    problems.append(f"frame {name} is cut")
            if not listed:
                problems.append("no frame listed in series.pvd")
            check(not problems, f"np={np}: killed after {sum(1 for _ in open(csv)) - 1 if os.path.exists(csv) else 0} monitor rows; "
                                f"{len(listed)} frames complete" + "".join("; " + m for m in problems))
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
