#!/usr/bin/env python3
"""msim's benchmark suite in one command (runs/bench/run): every method on cloths of N = 32, 64,
101 (the benchmark cloth of the targets), 128 and 256, and on tet boxes of about 10^5 and 10^6
springs, at 1 and 2 ranks; the median of several runs (-log_view's MSimStep; the one-off PD
factorization MSimPDSetUp, made at set-up, is reported apart and taken out of a step only where a
solver made it there); ms per step and per nonlinear iteration; max
RSS summed over ranks (-memory_view) and bytes per spring. Each figure that has a target is printed
beside it with the ratio. Cost bound of the explicit force: the bytes it must move (28 B per spring,
see explicit.py) at the triad bandwidth of as many ranks streaming at once (stream.cpp), and the
measured force time as a multiple of it.
Writes suite.csv, suite.md (the table runs/bench/README.md shows) and suite.png.
Usage: runs/bench/run [--quick] [--ranks 1,2] [--table] (--quick: cloths only, one run each;
--table: rewrite suite.md from suite.csv)."""
import argparse
import csv
import os
import re
import statistics
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tools"))
from msimrun import ENV, MSIM, ROOT, event  # noqa: E402

H = "0.0333333333333333"
STREAM = "/tmp/msim_stream"
LOOSE = "-snes_rtol 0 -snes_atol 0 -snes_stol 0"
CLOTH_METHODS = [
    ("symplectic Euler", "-msim_integrator symplectic_euler -msim_dt 1e-5 -msim_spectrum_check 0", 200),
    ("PD, 10 iterations", f"-msim_integrator implicit_euler -msim_dt {H} -snes_type pd -snes_max_it 10 -snes_pd_fixed", 20),
    ("PD + safeguarded Anderson, 10 iterations", f"-msim_integrator implicit_euler -msim_dt {H} -snes_type pd -snes_max_it 10 -snes_pd_fixed -snes_pd_anderson 5", 20),
    ("L-BFGS (PD Hessian), 10 iterations", f"-msim_integrator implicit_euler -msim_dt {H} -snes_type qn -snes_qn_scale_type jacobian -snes_qn_m 5 {LOOSE} -snes_max_it 10", 20),
    ("Newton, |dx| < 1e-3, CG + PD factor (EW)", f"-msim_integrator implicit_euler -msim_dt {H} -snes_type newtonls -ksp_type cg -msim_pc_pd -snes_ksp_ew -msim_step_atol 1e-3 {LOOSE} -snes_max_it 20", 10),
    ("Baraff-Witkin (MUMPS Cholesky)", f"-msim_integrator implicit_euler -msim_dt {H} -snes_type ksponly -ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type mumps", 5),
]
BOX_METHODS = [
    ("symplectic Euler", "-msim_integrator symplectic_euler -msim_dt 1e-6 -msim_spectrum_check 0", 50),
    ("PD, 10 iterations (default global step)", "-msim_integrator implicit_euler -msim_dt 0.01 -snes_type pd -snes_max_it 10 -snes_pd_fixed", 5),
    ("Newton, |dx| < 1e-3, CG + GAMG (EW)", f"-msim_integrator implicit_euler -msim_dt 0.01 -snes_type newtonls -ksp_type cg -pc_type gamg -snes_ksp_ew -msim_step_atol 1e-3 {LOOSE} -snes_max_it 20", 3),
]
# (scene, method, ranks): (metric, target, where the target comes from)
TARGETS = {
    ("cloth 101", "PD, 10 iterations", 1): ("ms_per_step", 6.0, "issue: PD <= 6 ms per step, one rank"),
    ("cloth 101", "PD, 10 iterations", 2): ("ms_per_step", 4.0, "issue: PD <= 4 ms per step, two ranks"),
    ("cloth 101", "Newton, |dx| < 1e-3, CG + PD factor (EW)", 1): ("ms_per_step", 400.0, "issue: Newton with the |dx| < 1e-3 rule <= 400 ms"),
    ("box 1e6", "symplectic Euler", 1): ("bytes_per_spring", 500.0, "issue: explicit <= 500 B per spring"),
    ("box 1e6", "PD, 10 iterations (default global step)", 1): ("bytes_per_spring", 1000.0, "issue: PD with CG <= 1 KB per spring"),
}


def cloth_springs(n):
    return 2 * n * (n - 1) + 2 * (n - 1) ** 2 + 2 * n * (n - 2)


def triad(np_):
    return float(subprocess.run(["mpirun", "-n", str(np_), STREAM], capture_output=True, text=True, check=True, env=ENV).stdout)


def measure(scene_opts, opts, steps, np_, reps):
    """median over reps of per-step ms (PD setup taken out), plus iterations, RSS, force time"""
    log, mon = "/tmp/msim_suite_log.txt", "/tmp/msim_suite_mon.csv"
    cmd = ["mpirun", "-n", str(np_), MSIM] + scene_opts.split() + opts.split() + ["-msim_steps", str(steps), "-msim_monitor_csv", mon,
                                                                                     "-log_view", f":{log}", "-memory_view"]
    runs = []
    for _ in range(reps):
        r = subprocess.run(cmd, capture_output=True, text=True, env=ENV, cwd=ROOT)
        if r.returncode:
            print("  failed:", r.stderr.strip()[-300:], flush=True)
            return None
        text = open(log).read()
        nstep, tstep = event(text, "MSimStep")
        _, tsetup = event(text, "MSimPDSetUp", "Stepping")  # a PD set up inside a step, taken out of it
        _, tfactor = event(text, "MSimPDSetUp")
        nf, tf = event(text, "MSimForce")
        with open(mon) as f:
            m = list(csv.DictReader(f))[1:]
        mem = re.search(r"Maximum \(over computational time\) process memory:\s+total\s+(\S+)", r.stdout)
        ng, tg = event(text, "MSimPDGlobal")
        nl, tl = event(text, "MSimPDLocal")
        ns, ts = event(text, "MSimLLTSweep")
        fl = re.search(r"^MSimLLTSweep\s+\d+\s+\S+\s+\S+\s+\S+\s+(\S+)", text, re.M)
        runs.append(dict(ms_per_step=(tstep - tsetup) / nstep * 1e3, setup_ms=tfactor * 1e3, its=sum(int(x["nonlinear_its"]) for x in m) / len(m),
                         rss=float(mem.group(1)), force_ms=tf / nf * 1e3 if nf else 0.0,
                         global_ms=tg / ng * 1e3 if ng else 0.0, local_ms=tl / nl * 1e3 if nl else 0.0, sweep_ms=ts / ns * 1e3 if ns else 0.0,
                         factor_entries=float(fl.group(1)) / (12.0 * ns) if ns and fl else 0.0))
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
    return med


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--ranks", default="1,2")
    ap.add_argument("--table", action="store_true", help="only rewrite suite.md from suite.csv")
    a = ap.parse_args()
    if a.table:
        with open(os.path.join(HERE, "suite.csv")) as f:
            write_table(list(csv.DictReader(f)))
        return
    ranks = [int(x) for x in a.ranks.split(",")]
    reps = 1 if a.quick else 3
    subprocess.run(["mpicxx", "-O3", "-march=x86-64-v2", os.path.join(HERE, "stream.cpp"), "-o", STREAM], check=True)
    bandwidth = {np_: triad(np_) for np_ in ranks}
    scenes = [(f"cloth {n}", f"-msim_cloth_n {n}", cloth_springs(n), CLOTH_METHODS) for n in (32, 64, 101, 128, 256)]
    if not a.quick:
        # Kuhn boxes: 7 springs per cube plus the boundary's edges; fixed on their top face
        scenes += [(f"box {tag}", f"-msim_scene box -msim_box_n {n},{n},{n} -msim_fix_plane z_max", None, BOX_METHODS) for tag, n in (("1e5", 24), ("1e6", 52))]
    rows = []
    for scene, scene_opts, springs, methods in scenes:
        if springs is None:
            r = subprocess.run([MSIM] + scene_opts.split() + ["-msim_steps", "1", "-msim_dt", "1e-9", "-msim_scene_view"], capture_output=True, text=True, env=ENV, cwd=ROOT)
            springs = int(re.search(r"(\d+) springs", r.stdout).group(1))
        for name, opts, steps in methods:
            for np_ in ranks:
                med = measure(scene_opts, opts, steps, np_, 1 if scene.startswith("box 1e6") else reps)
                if med is None:
                    continue
                row = dict(scene=scene, springs=springs, method=name, ranks=np_, steps=steps, ms_per_step=round(med["ms_per_step"], 3),
                           iterations_per_step=round(med["its"], 1),
                           ms_per_iteration=round(med["ms_per_step"] / med["its"], 3) if med["its"] > 0 else "",
                           pd_setup_ms=round(med["setup_ms"], 1), max_rss_mb=round(med["rss"] / 2**20, 1), bytes_per_spring=round(med["rss"] / springs, 1))
                if name == "symplectic Euler":
                    bound_ms = 28.0 * springs / (bandwidth[np_] * 1e9) * 1e3
                    row.update(force_ms=round(med["force_ms"], 4), force_bound_ms=round(bound_ms, 4), force_over_bound=round(med["force_ms"] / bound_ms, 2),
                               triad_gb_s=round(bandwidth[np_], 1))
                if name == "PD, 10 iterations" and med["sweep_ms"] > 0:
                    # the PD iteration's yardsticks: the local step's bytes as the force's (28 B per
                    # spring) at the triad bandwidth; the global step against the bare forward and
                    # backward sweeps of its factor (MSimLLTSweep, three columns in one pass), and
                    # those sweeps against reading the factor's values twice at the triad bandwidth
                    sweep_bound_ms = 16.0 * med["factor_entries"] / (bandwidth[np_] * 1e9) * 1e3
                    local_bound_ms = 28.0 * springs / (bandwidth[np_] * 1e9) * 1e3
                    row.update(factor_entries=int(med["factor_entries"]), global_ms=round(med["global_ms"], 4), sweep_ms=round(med["sweep_ms"], 4),
                               global_over_sweep=round(med["global_ms"] / med["sweep_ms"], 2), sweep_bound_ms=round(sweep_bound_ms, 4),
                               sweep_over_bound=round(med["sweep_ms"] / sweep_bound_ms, 2), local_ms=round(med["local_ms"], 4),
                               local_bound_ms=round(local_bound_ms, 4), local_over_bound=round(med["local_ms"] / local_bound_ms, 2), triad_gb_s=round(bandwidth[np_], 1))
                t = TARGETS.get((scene, name, np_))
                if t:
                    row.update(target_metric=t[0], target=t[1], ratio_to_target=round(row[t[0]] / t[1], 2), target_source=t[2])
                rows.append(row)
                tgt = f"   target {t[0]} <= {t[1]:g}: ratio {row['ratio_to_target']} ({'met' if row['ratio_to_target'] <= 1 else 'MISSED'})" if t else ""
                bound = f"   force {row['force_ms']:.3f} ms = {row['force_over_bound']}x its bound" if "force_ms" in row else ""
                if "global_over_sweep" in row:
                    bound = (f"   global step {row['global_ms']:.3f} ms = {row['global_over_sweep']}x the bare sweep ({row['sweep_ms']:.3f} ms, "
                             f"{row['sweep_over_bound']}x its bytes); local step {row['local_over_bound']}x its bytes")
                print(f"{scene:10s} {np_}r {name:45s} {row['ms_per_step']:10.3f} ms/step {row['iterations_per_step']:6.1f} its "
                      f"{row['bytes_per_spring']:8.1f} B/spring{bound}{tgt}", flush=True)
                write_csv(rows)  # after every row, so an interrupted suite keeps what it measured
    write_table(rows)
    plot(rows, ranks)


def write_table(rows):
    """suite.md: one line per scene and method, the rank counts side by side, targets with ratios"""
    def num(x):
        return "" if x in ("", None) else f"{float(x):,.3g}" if float(x) < 100 else f"{float(x):,.0f}"
    by = {}
    for r in rows:
        by.setdefault((r["scene"], r["method"]), {})[int(r["ranks"])] = r
    lines = ["| scene (springs) | method | ms/step 1 rank | 2 ranks | speedup | its/step | ms/it (1 rank) | B/spring 1 / 2 ranks | target: ratio |",
             "|---|---|---|---|---|---|---|---|---|"]
    for (scene, method), rk in by.items():
        one, two = rk.get(1), rk.get(2)
        first = one or two
        speed = f"{float(one['ms_per_step']) / float(two['ms_per_step']):.2f}x" if one and two else ""
        tgt = "; ".join(f"{r['target_metric'].replace('_', ' ')} <= {num(r['target'])} ({n} rank{'s' if n > 1 else ''}): {r['ratio_to_target']}"
                        for n, r in sorted(rk.items()) if r.get("target_metric"))
        cell = method.replace("|", "\\|")  # a bar in a name would end the table's cell
        lines.append(f"| {scene} ({int(first['springs']):,}) | {cell} | {num(one['ms_per_step']) if one else ''} | {num(two['ms_per_step']) if two else ''} | "
                     f"{speed} | {first['iterations_per_step']} | {num(one['ms_per_iteration']) if one else ''} | "
                     f"{num(one['bytes_per_spring']) if one else ''} / {num(two['bytes_per_spring']) if two else ''} | {tgt} |")
    with open(os.path.join(HERE, "suite.md"), "w") as f:
        f.write("\n".join(lines) + "\n")


def write_csv(rows):
    fields = []
    for r in rows:
        fields += [k for k in r if k not in fields]
    tmp = os.path.join(HERE, "suite.csv.tmp")
    with open(tmp, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=fields)
        w.writeheader()
        w.writerows(rows)
    os.replace(tmp, os.path.join(HERE, "suite.csv"))


def plot(rows, ranks):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.8))
    for ax, np_ in zip(axes, ranks):
        for name, _, _ in CLOTH_METHODS:
            pts = sorted((r["springs"], r["ms_per_step"]) for r in rows if r["method"] == name and r["ranks"] == np_ and r["scene"].startswith("cloth"))
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=name)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("springs (cloth N = 32 ... 256)")
        ax.set_ylabel("ms per step (median)")
        ax.set_title(f"{np_} rank(s)")
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "suite.png"), dpi=100)


if __name__ == "__main__":
    main()
