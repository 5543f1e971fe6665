#!/usr/bin/env python3
"""Adaptive against fixed steps in PETSc's implicit TS types on msim's analytic Jacobians
(-msim_integrator ts), on the rope of runs/speed_accuracy (a chain of 1000 vertices, one end
fixed, released horizontally) to T = 1 s. The error is the largest vertex distance at T from RK4
at h = 1e-5. Work is counted as msim counts it for the TS (-msim_view: residual evaluations of
the implicit form, and analytic Jacobian assemblies), with the wall time of the stepping.

Fixed steps: cn, bdf (order 2) and alpha2 at h = 1/30 s halved until the error is below 1e-4 m.
Adaptive: bdf (order 2) with -ts_adapt_type basic and dsp, and alpha2 with basic, at tolerances
1e-2 ... 1e-7 (atol = rtol), each -msim_dt = 1/30 s interval filled by the TS's own steps.

Writes runs/ts_adaptive/runs.csv and error_vs_work.png. Usage:
  /usr/bin/python3 runs/ts_adaptive/study.py [path/to/msim] [--only METHOD-PREFIX]
(--only reruns the methods whose name starts with the prefix, e.g. "alpha2 adaptive", and keeps
the CSV's other rows)"""
import csv
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tools"))
import msimrun  # noqa: E402

ARGS = [a for a in sys.argv[1:]]
ONLY = ARGS[ARGS.index("--only") + 1] if "--only" in ARGS else None
if ONLY:
    del ARGS[ARGS.index("--only"):ARGS.index("--only") + 2]
MSIM = os.path.abspath(ARGS[0]) if ARGS else msimrun.MSIM
ROPE = "-msim_scene chain -msim_chain_n 1000 -msim_fix edge -msim_spectrum_check 0 -msim_progress 0".split()
T = 1.0
TARGET = 1e-4
H0 = 1.0 / 30


def run(args, tag, tmp):
    out = os.path.join(tmp, tag + ".txt")
    t0 = time.time()
    r = subprocess.run([MSIM] + ROPE + args + ["-msim_view", "-msim_view_final", f"ascii:{out}:ascii_matlab"],
                       capture_output=True, text=True, env=msimrun.ENV)
    wall = time.time() - t0
    if r.returncode:
        return None
    x = [float(l) for l in open(out) if l.strip() and l.strip()[0] in "+-0123456789"]
    m = re.search(r"ts: (\d+) residual and (\d+) analytic Jacobian", r.stdout)
    s = re.search(r"ts: (\d+) internal steps, (\d+) rejected", r.stdout)
    return dict(x=x, residuals=int(m.group(1)) if m else 0, jacobians=int(m.group(2)) if m else 0,
                steps=int(s.group(1)) if s else 0, rejected=int(s.group(2)) if s else 0, wall_s=wall)


def distance(a, b):
    return max(sum((a[i + k] - b[i + k]) ** 2 for k in range(3)) ** 0.5 for i in range(0, len(a), 3))


def record(rows, r, ref, **row):
    """one CSV row for run r (None: it diverged), appended to rows and printed"""
    if r is None:
        row.update(error_m="diverged")
    else:
        row.update(error_m=f"{distance(r['x'], ref['x']):.3e}", steps=r["steps"], rejected=r["rejected"],
                   residuals=r["residuals"], jacobians=r["jacobians"], wall_s=f"{r['wall_s']:.2f}")
    rows.append(row)
    print(row, flush=True)
    return row


def wanted(method):
    return ONLY is None or method.startswith(ONLY)


def main():
    rows = []
    path = os.path.join(HERE, "runs.csv")
    if ONLY and os.path.exists(path):
        with open(path) as f:
            rows = [r for r in csv.DictReader(f) if not wanted(r["method"])]
    with tempfile.TemporaryDirectory() as tmp:
        ref = run(["-msim_integrator", "rk4", "-msim_dt", "1e-5", "-msim_steps", str(round(T / 1e-5))], "ref", tmp)
        fixed = {"cn": [], "bdf": ["-ts_bdf_order", "2"], "alpha2": []}
        for ts_type, extra in fixed.items():
            if not wanted(f"{ts_type} fixed"):
                continue
            for k in range(0, 9):
                h = H0 / 2 ** k
                r = run(["-msim_integrator", "ts", "-ts_type", ts_type, "-ts_adapt_type", "none", "-msim_dt", repr(h),
                         "-msim_steps", str(round(T / h))] + extra, f"{ts_type}_{k}", tmp)
                row = record(rows, r, ref, method=f"{ts_type} fixed", h=f"{h:.6g}", tol="")
                if r is not None and float(row["error_m"]) < TARGET:
                    break
        for ts_type, extra, adapt in (("bdf", ["-ts_bdf_order", "2"], "basic"), ("bdf", ["-ts_bdf_order", "2"], "dsp"), ("alpha2", [], "basic")):
            if not wanted(f"{ts_type} adaptive ({adapt})"):
                continue
            for tol in (1e-2, 1e-3, 1e-4, 3e-5, 1e-5, 1e-6, 1e-7):
                r = run(["-msim_integrator", "ts", "-ts_type", ts_type, "-ts_adapt_type", adapt,
                         "-ts_atol", repr(tol), "-ts_rtol", repr(tol), "-msim_dt", repr(H0), "-msim_steps", str(round(T / H0))] + extra,
                        f"{ts_type}_{adapt}_{tol}", tmp)
                row = record(rows, r, ref, method=f"{ts_type} adaptive ({adapt})", h="", tol=f"{tol:g}")
                if r is not None and float(row["error_m"]) < TARGET / 10:
                    break
    fields = ["method", "h", "tol", "error_m", "steps", "rejected", "residuals", "jacobians", "wall_s"]
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    plot(rows)


def plot(rows):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(11, 4.2))
    for method in dict.fromkeys(r["method"] for r in rows):
        pts = [(int(r["residuals"]) + int(r["jacobians"]), float(r["wall_s"]), float(r["error_m"])) for r in rows
               if r["method"] == method and r["error_m"] != "diverged"]
        if not pts:
            continue
        ax[0].loglog([p[0] for p in pts], [p[2] for p in pts], "o-", label=method)
        ax[1].loglog([p[1] for p in pts], [p[2] for p in pts], "o-", label=method)
    for a, xl in zip(ax, ("residual + Jacobian evaluations", "wall time, s (one rank)")):
        a.axhline(TARGET, color="grey", ls=":")
        a.set_xlabel(xl)
        a.set_ylabel("error at T = 1 s against RK4, m")
        a.grid(True, which="both", alpha=0.3)
    ax[0].legend(fontsize=8)
    fig.suptitle("rope, 1000 vertices: PETSc TS on msim's analytic Jacobians, fixed against adaptive steps")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "error_vs_work.png"), dpi=110)


if __name__ == "__main__":
    main()
