#!/usr/bin/env python3
"""Read what runs/device/study.sh wrote (runs.csv, each run's -log_view and monitor CSV) and write
the speed-up charts and the summary table of contact (issue 34) and self-contact (issue 35) against
the same runs without them.

Usage: /usr/bin/python3 runs/device/report.py OUT [DEST]   (DEST: where to write, default OUT)
Writes DEST/summary.csv (one row per run, case, variant and rank count: the fastest of its
repetitions), DEST/summary.md (the tables and the targets), DEST/speedup.png. A run is named by the
date line of OUT/machine.txt (its `run` column); the rows of other runs already in DEST/summary.csv
are kept, with their machine header from DEST/machine_<run>.txt, so that calls on other days or
machines stay beside the new one (latest first).

Time per step is the Stepping stage of -log_view over the steps made (setup, i.e. the Read,
Partition, Distribution, Refinement and Setup stages, apart); "steady" is the same from the
monitor's wall clock without each run's first step (the Jacobian's pattern, PC set-up, the first
candidate lists). The explicit box is compared with runs/scaling's model of the explicit step
(runs/scaling/study.py's predict(), METIS partitions of the same box: runs/device/partitions_box52.csv),
its per-spring and per-vertex costs taken from this machine's own one-rank run."""
import csv
import importlib.util
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, os.path.join(ROOT, "runs", "tools"))
from msimrun import event, write_csv  # noqa: E402

# (case, the variant with the feature, without it, the 2-rank target: relative difference)
CASES = [("box", "contact", "free", 0.10, "issue 34: tet box on a plane, implicit Euler + Newton-CG"),
         ("box_jacobi", "contact", "free", 0.10, "issue 34: the same box, CG with point Jacobi (iterations independent of the partition)"),
         ("fold", "self", "noself", 0.15, "issue 35: folding cloth, self-contact, implicit Euler + Newton-CG"),
         ("box_explicit", "contact", "free", None, "explicit box (symplectic Euler), penalty on a plane")]
EVENTS = ["KSPSolve", "MSimJacobian", "MSimResidual", "MSimEnergy", "MSimForce", "MSimSelfBroad", "MSimSelfNarrow", "MSimSelfCCD", "MSimSelfHalo"]


def scaling_model():
    """runs/scaling/study.py as a module (its predict() and the node's assumptions), or None"""
    path = os.path.join(ROOT, "runs", "scaling", "study.py")
    try:
        spec = importlib.util.spec_from_file_location("scaling_study", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod
    except Exception as e:  # the chart is still useful without the model
        print(f"report.py: scaling model not loaded ({e})")
        return None


def monitor_steady(path):
    """(s per step without the run's first step, steps in that) from the monitor's wall_s column"""
    try:
        rows = [r for r in csv.DictReader(open(path)) if int(r["step"]) > 0]
    except (OSError, KeyError, ValueError):
        return None, 0
    if len(rows) < 2:
        return None, 0
    return (float(rows[-1]["wall_s"]) - float(rows[0]["wall_s"])) / (len(rows) - 1), len(rows) - 1


def monitor_its(path):
    """(steps made, Newton iterations, linear iterations, vertices in contact at the end) from the
    monitor CSV; a fresh run's first row is its initial state (step 0), a restarted run's its first step"""
    try:
        rows = [r for r in csv.DictReader(open(path)) if int(r["step"]) > 0]
    except (OSError, KeyError, ValueError):
        return 0, 0, 0, 0
    return (len(rows), sum(int(r["nonlinear_its"]) for r in rows), sum(int(r["linear_its"]) for r in rows),
            int(rows[-1]["contact_n"]) if rows else 0)


def read_runs(out):
    rows = []
    for r in csv.DictReader(open(os.path.join(out, "runs.csv"))):
        if r["status"] != "ok" or r["variant"] == "prefold":
            continue
        d = os.path.join(out, r["case"], f"{r['variant']}_np{r['ranks']}" + (f"_rep{r['rep']}" if int(r["rep"]) > 1 else ""))
        log = open(os.path.join(d, "log_view.txt")).read() if os.path.exists(os.path.join(d, "log_view.txt")) else ""
        # from the files themselves (runs.csv's copies were made with awk on the machine)
        stage = re.search(r"^\s*\d+:\s+Stepping:\s+(\S+)", log, re.M)
        stepping = float(stage.group(1)) if stage else 0.0
        setup = sum(float(m.group(1)) for m in re.finditer(r"^\s*\d+:\s+(?:Read|Partition|Distribution|Refinement|Setup):\s+(\S+)", log, re.M))
        its = monitor_its(os.path.join(d, "monitor.csv"))
        steps = its[0] if its[0] else int(re.search(r"-msim_steps (\d+)", r["cmd"]).group(1))
        if not log or steps == 0 or stepping == 0:
            continue
        springs = re.search(r"(\d+) springs", open(os.path.join(d, "stdout.txt")).read())
        steady, nsteady = monitor_steady(os.path.join(d, "monitor.csv"))
        row = dict(case=r["case"], variant=r["variant"], ranks=int(r["ranks"]), rep=int(r["rep"]), steps=steps,
                   setup_s=setup, step_s=stepping / steps, steady_step_s=steady if steady else "",
                   nonlinear_its=its[1], linear_its=its[2], contact_n_last=its[3], wall_s=float(r["wall_s"] or 0))
        for name in EVENTS:
            row[f"{name}_s_per_step"] = event(log, name, "Stepping")[1] / steps
        row["springs"] = int(springs.group(1)) if springs else ""
        rows.append(row)
    return rows


def fastest(rows):
    """per (case, variant, ranks) the repetition with the least time per step, with how many there were"""
    best = {}
    for r in rows:
        k = (r["case"], r["variant"], r["ranks"])
        if k not in best or r["step_s"] < best[k]["step_s"]:
            best[k] = dict(r, repetitions=sum(1 for q in rows if (q["case"], q["variant"], q["ranks"]) == k))
    out = sorted(best.values(), key=case_order)
    for r in out:
        one = best.get((r["case"], r["variant"], min(q["ranks"] for q in out if (q["case"], q["variant"]) == (r["case"], r["variant"]))))
        r["speedup"] = one["step_s"] * one["ranks"] / r["step_s"]
        r["efficiency"] = r["speedup"] / r["ranks"]
        if r["steady_step_s"] and one["steady_step_s"]:
            r["steady_speedup"] = one["steady_step_s"] * one["ranks"] / r["steady_step_s"]
        else:
            r["steady_speedup"] = ""
    return out, best


def case_order(r):
    names = [c[0] for c in CASES]
    return (names.index(r["case"]) if r["case"] in names else 9, r["variant"], int(r["ranks"]))


def run_name(machine):
    """a run's name: the date line of its machine.txt (the call's start, UTC)"""
    m = re.search(r"^date (\S+)", machine, re.M)
    return m.group(1) if m else "unnamed"


def machine_file(dest, run):
    return os.path.join(dest, "machine_" + re.sub(r"[^0-9A-Za-z]", "", run) + ".txt")


def earlier_runs(dest, run):
    """{run: rows} of DEST/summary.csv's other runs, numbers as numbers (rows without a run column
    belong to 'earlier')"""
    path = os.path.join(dest, "summary.csv")
    runs = {}
    if not os.path.exists(path):
        return runs
    for r in csv.DictReader(open(path)):
        name = r.get("run") or "earlier"
        if name == run:
            continue
        for k, v in r.items():
            if k in ("case", "variant", "run") or v in ("", None):
                continue
            try:
                r[k] = int(v) if re.fullmatch(r"-?\d+", v) else float(v)
            except ValueError:
                pass
        runs.setdefault(name, []).append(r)
    return runs


def model_rows(best, out):
    """the scaling model's explicit step for the explicit box at each rank count measured"""
    one = best.get(("box_explicit", "free", 1))
    if not one or not one["springs"]:
        return []
    n = round(((one["springs"]) / 7.0) ** (1 / 3))
    pfile = next((p for p in (os.path.join(out, f"partitions_box{n}.csv"), os.path.join(HERE, f"partitions_box{n}.csv")) if os.path.exists(p)), None)
    mod = scaling_model()
    if not pfile or not mod:
        print(f"report.py: no model for the explicit box (partitions of box {n}: {pfile}; make them with "
              f"msim_partition_model -msim_scene box -msim_box_n {n},{n},{n} -parts 2,4,8,16)")
        return []
    parts = [p for p in csv.DictReader(open(pfile)) if p["partition"] == "metis"]
    pp = list(csv.DictReader(open(os.path.join(ROOT, "runs", "scaling", "pingpong.csv"))))
    lat = float(pp[0]["half_round_trip_s"])
    bw = float(pp[-1]["bytes"]) / (float(pp[-1]["half_round_trip_s"]) - lat)
    steps = one["steps"]
    force = one["MSimForce_s_per_step"]  # one force evaluation per symplectic Euler step
    t_spring = force / one["springs"]
    nvert = float(parts[0]["vertices"])
    t_vertex = max(one["step_s"] - force, 0.0) / nvert
    rows = [dict(ranks=1, predicted_step_s=one["step_s"], predicted_speedup=1.0, t_spring_ns=t_spring * 1e9, t_vertex_ns=t_vertex * 1e9, steps=steps)]
    for p in parts:
        P = int(p["parts"])
        t = mod.predict(p, t_spring, t_vertex, lat, bw, mod.NODE_BW / P, mod.CACHE_PER_CORE)
        rows.append(dict(ranks=P, predicted_step_s=t, predicted_speedup=one["step_s"] / t, t_spring_ns=t_spring * 1e9, t_vertex_ns=t_vertex * 1e9, steps=steps))
    return rows


def sized(rows, case):
    springs = next((r["springs"] for r in rows if r["case"] == case and r["springs"]), None)
    return f"{springs:,} springs" if springs else ""


def chart(runs, models, dest):
    """one panel per run and case, the latest run first; runs: [(name, rows)]"""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    panels = [(name, rows, c) for name, rows in runs for c in CASES if any(r["case"] == c[0] for r in rows)]
    if not panels:
        return
    ncol = min(3, len(panels))
    nrow = (len(panels) + ncol - 1) // ncol
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.2 * ncol, 4.4 * nrow), squeeze=False)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax, (name, best_rows, (case, on, off, _, title)) in zip(axes.flat, panels):
        ps = sorted({r["ranks"] for r in best_rows if r["case"] == case})
        ax.plot(ps, ps, color="0.7", ls=":", label="ideal")
        for variant, style in ((off, "o-"), (on, "s--")):
            rs = sorted((r for r in best_rows if r["case"] == case and r["variant"] == variant), key=lambda r: r["ranks"])
            if rs:
                ax.plot([r["ranks"] for r in rs], [r["speedup"] for r in rs], style, label=f"{variant} ({rs[0]['step_s']:.3g} s/step at {rs[0]['ranks']})")
        model = models.get(name)
        if case == "box_explicit" and model:
            ax.plot([m["ranks"] for m in model], [m["predicted_speedup"] for m in model], "k-", lw=0.8, label="scaling model (explicit step)")
        ax.set_xscale("log", base=2)
        ax.set_yscale("log", base=2)
        ax.set_xticks(ps)
        ax.set_xticklabels([str(p) for p in ps])
        ax.set_xlabel("ranks")
        ax.set_ylabel("speed-up of the time per step (Stepping stage)")
        ax.set_title(f"{title}\n{sized(best_rows, case)}, run {name}", fontsize=8)
        ax.legend(fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(dest, "speedup.png"), dpi=110)


def summary_md(runs, models, dest):
    """runs: [(name, rows, machine text)], the latest first"""
    lines = ["# Contact and self-contact at scale: the device runs", "",
             "Each run's tables under its heading, the latest first; a run is one device call, named by its start (UTC).", ""]
    for k, (name, best_rows, machine) in enumerate(runs):
        best = {(r["case"], r["variant"], r["ranks"]): r for r in best_rows}
        lines += [f"# Run {name}" + (" (latest)" if k == 0 else ""), "", "```", machine.strip() or "(machine header not kept)", "```", ""]
        lines += run_tables(best_rows, best, models.get(name))
    open(os.path.join(dest, "summary.md"), "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))


def run_tables(best_rows, best, model):
    lines = []
    for case, on, off, target, title in CASES:
        rs = [r for r in best_rows if r["case"] == case]
        if not rs:
            continue
        lines += [f"## {title} ({sized(best_rows, case)})", "", "| variant | ranks | s per step | steady s per step | speed-up | efficiency | Newton its | CG its | setup s | repetitions |",
                  "|---|---|---|---|---|---|---|---|---|---|"]
        for r in rs:
            steady = f"{r['steady_step_s']:.4g}" if r["steady_step_s"] else "-"
            lines.append(f"| {r['variant']} | {r['ranks']} | {r['step_s']:.4g} | {steady} | {r['speedup']:.2f} | {r['efficiency']:.2f} | "
                         f"{r['nonlinear_its']} | {r['linear_its']} | {r['setup_s']:.3g} | {r['repetitions']} |")
        lines.append("")
        lines.append(f"Speed-up with {on} against without ({off}), and their relative difference:")
        lines.append("")
        for p in sorted({r["ranks"] for r in rs}):
            a, b = best.get((case, on, p)), best.get((case, off, p))
            if not (a and b) or p == 1:
                continue
            sa = next(r for r in rs if r["variant"] == on and r["ranks"] == p)["speedup"]
            sb = next(r for r in rs if r["variant"] == off and r["ranks"] == p)["speedup"]
            diff = sa / sb - 1
            verdict = ""
            if target is not None and p == 2:
                verdict = f" -> target (within {target:.0%}): **{'met' if abs(diff) <= target else 'missed'}**"
            lines.append(f"- {p} ranks: {sa:.2f}x with, {sb:.2f}x without ({diff:+.1%}); cost of the feature per step {a['step_s'] / b['step_s']:.2f}x{verdict}")
        lines.append("")
    if model:
        lines += ["## The scaling model against the explicit box", "",
                  f"t_spring = {model[0]['t_spring_ns']:.3f} ns, t_vertex = {model[0]['t_vertex_ns']:.3f} ns from the one-rank run here; "
                  "the node's assumptions of runs/scaling (150 GB/s shared, 2.5 MB of cache per core, the ping-pong of runs/scaling).", "",
                  "| ranks | predicted s per step | predicted speed-up | measured (free) | measured (contact) |", "|---|---|---|---|---|"]
        for m in model:
            f, c = best.get(("box_explicit", "free", m["ranks"])), best.get(("box_explicit", "contact", m["ranks"]))
            sf = next((r["speedup"] for r in best_rows if r["case"] == "box_explicit" and r["variant"] == "free" and r["ranks"] == m["ranks"]), None) if f else None
            sc = next((r["speedup"] for r in best_rows if r["case"] == "box_explicit" and r["variant"] == "contact" and r["ranks"] == m["ranks"]), None) if c else None
            lines.append(f"| {m['ranks']} | {m['predicted_step_s']:.4g} | {m['predicted_speedup']:.2f} | {'-' if sf is None else f'{sf:.2f}'} | {'-' if sc is None else f'{sc:.2f}'} |")
        lines.append("")
    return lines


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__.split("\n\n")[1])
    out = sys.argv[1]
    dest = sys.argv[2] if len(sys.argv) > 2 else out
    os.makedirs(dest, exist_ok=True)
    rows = read_runs(out)
    if not rows:
        sys.exit(f"report.py: no finished run in {out}/runs.csv")
    best_rows, best = fastest(rows)
    machine = open(os.path.join(out, "machine.txt")).read() if os.path.exists(os.path.join(out, "machine.txt")) else ""
    run = run_name(machine)
    earlier = earlier_runs(dest, run)
    for r in best_rows:
        r["run"] = run
    open(machine_file(dest, run), "w").write(machine)
    runs = [(run, best_rows, machine)]
    for name in sorted(earlier, reverse=True):
        mf = machine_file(dest, name)
        runs.append((name, sorted(earlier[name], key=case_order), open(mf).read() if os.path.exists(mf) else ""))
    write_csv(os.path.join(dest, "summary.csv"), [r for _, rs, _ in runs for r in rs])
    # the explicit box's model belongs to the run that measured it: this one, or else the earlier
    # run whose model_box_explicit.csv is kept
    models = {}
    model = model_rows(best, out)
    mpath = os.path.join(dest, "model_box_explicit.csv")
    if model:
        write_csv(mpath, model)
        models[run] = model
    elif os.path.exists(mpath):
        owner = next((n for n, rs, _ in runs[1:] if any(r["case"] == "box_explicit" for r in rs)), None)
        if owner:
            models[owner] = [{k: float(v) for k, v in m.items()} for m in csv.DictReader(open(mpath))]
            for m in models[owner]:
                m["ranks"] = int(m["ranks"])
    summary_md(runs, models, dest)
    chart([(n, rs) for n, rs, _ in runs], models, dest)


if __name__ == "__main__":
    main()
