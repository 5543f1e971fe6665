#!/usr/bin/env python3
"""Self-contact evidence (runs/self_contact/README.md): a cloth standing on its edge on a plane
(friction 0.5) falls under gravity -y and crumples onto itself.
- frames.csv: intersecting triangle pairs per frame (runs/tools/intersections.py, independent of
  msim) without and with -msim_self_contact, Newton (default PSD Hessian, CG/ICC), 21 x 21, 1 rank;
- cost.csv: CPU time (user, all ranks; the machine is shared, so not wall time) per step without and
  with self-contact, for Newton-CG and PD (50 iterations), N x N cloths, 1 and 2 ranks, with the
  gradient evaluations (MSimResidual) and the self-contact events' share of -log_view's time;
- self_contact.png: both.
  cpu_per_step divides by the steps msim completed (-log_view's MSimStep count: PD without
  self-contact diverges once the cloth has passed through itself, from 51 x 51 on); floor_per_step
  estimates the least a step's broad and narrow phase can cost (one grid build and one pass of
  distances over the candidates: MSimSelfBroad's and MSimSelfNarrow's time per call, scaled from
  -log_view's wall time to CPU time by the run's CPU / SNESSolve ratio).
Usage: study.py path/to/msim [--sizes 21,31,41] [--ranks 1,2] [--solvers newton_cg,pd] [--append: add
these sizes and ranks to cost.csv, no frames] | --plot"""
import os
import re
import resource
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "tools"))
sys.path.insert(0, os.path.join(HERE, "..", "..", "tests"))
import intersections  # noqa: E402
from plots import pyplot, save, style  # noqa: E402
import msimtest as mt  # noqa: E402
import vtu  # noqa: E402


def fold(n, steps=35):
    # the perturbation (in all three directions) a fifth of an edge (1 cm at 21 x 21, as
    # examples/cloth_fold.opts): a fixed 1 cm on finer cloths folds triangles over at the start (41 x
    # 41: 10 edge-triangle crossings), which msim now refuses in one line (the start check, README);
    # before, Newton stalled under the barrier from step 1 with the cloth frozen
    perturb = 0.2 / (n - 1)
    return ["-msim_cloth_n", str(n), "-msim_fix", "none", "-msim_gravity", "0,-9.81,0", "-msim_perturb", f"{perturb:g}",
            "-msim_integrator", "implicit_euler", "-msim_dt", "0.02", "-msim_steps", str(steps),
            "-msim_contact_plane", "0,1,0,-0.01", "-msim_friction", "0.5"]


# newton_chol: Newton-CG preconditioned by a MUMPS Cholesky factor of each iteration's Hessian (one CG
# iteration): CG/ICC(0) needs 5 x the iterations on the barrier's stiff blocks (README, "Newton-CG's
# linear solve"); at 1 and 2 ranks alike
SOLVERS = {"newton_cg": [], "pd": ["-snes_type", "pd", "-snes_max_it", "50"],
           "newton_chol": ["-ksp_type", "cg", "-pc_type", "cholesky", "-pc_factor_mat_solver_type", "mumps"]}


def run_cpu(exe, args, np_):
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    r = subprocess.run(mt.command(exe, args, np_), capture_output=True, text=True)
    return r, resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before


def log_time(text, event):
    m = re.search(rf"^{event}\s+\d+\s+\S+\s+(\S+)", text, re.M)
    return float(m.group(1)) if m else 0.0


def log_count(text, event):
    m = re.search(rf"^{event}\s+(\d+)", text, re.M)
    return int(m.group(1)) if m else 0


def main():
    exe = mt.msim_path()
    sizes = [21, 31, 41]
    ranks = [1, 2]
    if "--sizes" in sys.argv:
        sizes = [int(v) for v in sys.argv[sys.argv.index("--sizes") + 1].split(",")]
    if "--ranks" in sys.argv:
        ranks = [int(v) for v in sys.argv[sys.argv.index("--ranks") + 1].split(",")]
    solvers = list(SOLVERS)
    if "--solvers" in sys.argv:
        solvers = sys.argv[sys.argv.index("--solvers") + 1].split(",")
    tmp = tempfile.mkdtemp(prefix="msim_self_contact_study_")
    # 1. intersections per frame
    counts = {}
    for on in ((0, 1) if "--append" not in sys.argv else ()):
        out = os.path.join(tmp, f"frames_{on}")
        r = subprocess.run(mt.command(exe, fold(21, 50) + ["-msim_self_contact", str(on), "-msim_output", out, "-msim_output_every", "2"]), capture_output=True, text=True)
        assert r.returncode == 0, r.stderr[-500:]
        counts[on] = [(t, intersections.intersecting_pairs(vtu.read_vtu(p)["points"], intersections.cloth_triangles(441)))
                      for t, p in vtu.read_pvd(os.path.join(out, "series.pvd"))]
    if counts:
        with open(os.path.join(HERE, "frames.csv"), "w") as f:
            f.write("t,pairs_without,pairs_with\n")
            for (t, a), (_, b) in zip(counts[0], counts[1]):
                f.write(f"{t:.4f},{a},{b}\n")
    # 2. cost per step
    rows = []
    for n in sizes:
        for np_ in ranks:
            for sname in solvers:
                sargs = SOLVERS[sname]
                for on in (0, 1):
                    steps = 35
                    # several ranks: ICC on the Jacobi blocks, with and without (the default ILU(0) met a
                    # negative pivot on the contact blocks: DIVERGED_INDEFINITE_PC)
                    sub = ["-sub_pc_type", "icc"] if np_ > 1 and sname == "newton_cg" else []
                    r, cpu = run_cpu(exe, fold(n, steps) + sargs + sub + ["-msim_self_contact", str(on), "-log_view"], np_)
                    ok = r.returncode == 0
                    total = log_time(r.stdout, "SNESSolve")
                    self_t = sum(log_time(r.stdout, e) for e in ("MSimSelfNarrow", "MSimSelfCCD", "MSimSelfHalo"))
                    done = log_count(r.stdout, "MSimStep") or steps
                    scale = cpu / total if total > 0 else 0.0  # -log_view's wall seconds -> CPU seconds
                    per_call = lambda e: log_time(r.stdout, e) / max(log_count(r.stdout, e), 1) * scale  # noqa: E731
                    row = dict(n=n, vertices=n * n, triangles=2 * (n - 1) ** 2, ranks=np_, solver=sname, self_contact=on, ok=int(ok),
                               cpu_per_step=cpu / done, gradients=log_count(r.stdout, "MSimResidual"),
                               self_share=self_t / total if total > 0 else 0.0, steps=done,
                               grid_builds=log_count(r.stdout, "MSimSelfBroad"),
                               floor_per_step=(per_call("MSimSelfBroad") + per_call("MSimSelfNarrow")) if on else 0.0)
                    rows.append(row)
                    print(row, flush=True)
    keys = list(rows[0].keys())
    if "--append" in sys.argv and os.path.exists(os.path.join(HERE, "cost.csv")):  # keep other runs' rows
        import csv
        old = list(csv.DictReader(open(os.path.join(HERE, "cost.csv"))))
        done = {(r["n"], r["ranks"], r["solver"]) for r in rows}
        rows = [r for r in old if (int(r["n"]), int(r["ranks"]), r["solver"]) not in done] + rows
    with open(os.path.join(HERE, "cost.csv"), "w") as f:
        f.write(",".join(keys) + "\n")
        for row in rows:
            f.write(",".join(f"{row.get(k, '')}" if not isinstance(row.get(k), float) else f"{row[k]:.5g}" for k in keys) + "\n")
    plot()


def plot():
    import csv
    plt = pyplot()
    fr = list(csv.DictReader(open(os.path.join(HERE, "frames.csv"))))
    path = os.path.join(HERE, "cost.csv")
    cost = list(csv.DictReader(open(path))) if os.path.exists(path) else []
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    t = [float(r["t"]) for r in fr]
    ax[0].plot(t, [int(r["pairs_without"]) for r in fr], "o-", label="without")
    ax[0].plot(t, [int(r["pairs_with"]) for r in fr], "s-", label="-msim_self_contact")
    style(ax[0], "t (s)", "intersecting triangle pairs", "21 x 21 cloth crumpling on a plane (Newton)", grid=False, legend={})
    for solver in SOLVERS:
        for np_ in sorted({int(r["ranks"]) for r in cost}):
            pts = []
            for r in cost:
                if r["solver"] == solver and int(r["ranks"]) == np_ and r["self_contact"] == "1":
                    off = [q for q in cost if q["solver"] == solver and q["ranks"] == r["ranks"] and q["n"] == r["n"] and q["self_contact"] == "0"]
                    if off and float(off[0]["cpu_per_step"]) > 0:
                        pts.append((int(r["triangles"]), float(r["cpu_per_step"]) / float(off[0]["cpu_per_step"])))
            if pts:
                ax[1].plot(*zip(*sorted(pts)), "o-", label=f"{solver}, {np_} rank(s)")
    ax[1].axhline(3, color="gray", ls="--", label="target 3x")
    style(ax[1], "surface triangles", "CPU per step, with / without", "cost of self-contact", xlog=True, grid=False, legend=dict(fontsize=8))
    save(fig, os.path.join(HERE, "self_contact.png"))


if __name__ == "__main__":
    if "--plot" in sys.argv:
        plot()
    else:
        main()
