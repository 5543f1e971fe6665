#!/usr/bin/env python3
"""Newton-CG's linear solve with self-contact (runs/self_contact/README.md, "Newton-CG's linear solve"):
reads msim logs of the fold (study.py's fold(n) settings plus -snes_monitor -snes_converged_reason
-ksp_converged_reason -log_view and an option set), each ending with /usr/bin/time's "%U user %e wall"
line, named OPTS_nN_npP_scS.txt, and writes newton_cg.csv: CPU user time per step, Newton iterations
per step and how the steps ended, CG iterations per linear solve (mean, max), the median final |g| of
a step, and the row for cost.csv (solver newton_chol) where OPTS is chol.
Usage: newton_cg.py LOG... [--cost: also replace cost.csv's newton_chol rows with these]"""
import csv
import os
import re
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def ev(t, name):
    m = re.search(rf"^{name}\s+(\d+)\s+\S+\s+(\S+)", t, re.M)
    return (int(m.group(1)), float(m.group(2))) if m else (0, 0.0)


def parse(path):
    t = open(path).read()
    opts, n, np_, sc = re.match(r"(\w+)_n(\d+)_np(\d+)_sc(\d)\.txt", os.path.basename(path)).groups()
    n = int(n)
    cpu = float(re.findall(r"([\d.]+) user", t)[-1])
    cg = [int(k) for k in re.findall(r"Linear solve converged due to \S+ iterations (\d+)", t)]
    ends = re.findall(r"Nonlinear solve (?:converged|did not converge) due to (\S+) iterations (\d+)", t)
    fin, last = [], None
    for line in t.splitlines():
        m = re.match(r"\s*\d+ SNES Function norm (\S+)", line)
        if m:
            last = float(m.group(1))
        elif line.startswith("Nonlinear solve") and last is not None:
            fin.append(last)
    steps = len(ends)
    reasons = {}
    for r, _ in ends:
        reasons[r] = reasons.get(r, 0) + 1
    total = ev(t, "SNESSolve")[1]
    self_t = sum(ev(t, e)[1] for e in ("MSimSelfNarrow", "MSimSelfCCD", "MSimSelfHalo"))
    scale = cpu / total if total else 0.0
    per_call = lambda e: ev(t, e)[1] / max(ev(t, e)[0], 1) * scale  # noqa: E731
    return dict(opts=opts, n=n, ranks=int(np_), self_contact=int(sc), cpu_per_step=cpu / max(steps, 1), steps=steps,
                newton_per_step=sum(int(i) for _, i in ends) / max(steps, 1),
                stopped_max_it=reasons.get("DIVERGED_MAX_IT", 0), stopped_step_small=reasons.get("CONVERGED_SNORM_RELATIVE", 0),
                cg_per_solve=sum(cg) / max(len(cg), 1), cg_max=max(cg) if cg else 0,
                final_g_median=sorted(fin)[len(fin) // 2] if fin else "",
                gradients=ev(t, "MSimResidual")[0], self_share=self_t / total if total else 0.0,
                grid_builds=ev(t, "MSimSelfBroad")[0],
                floor_per_step=(per_call("MSimSelfBroad") + per_call("MSimSelfNarrow")) if int(sc) else 0.0)


def fmt(v):
    return f"{v:.5g}" if isinstance(v, float) else str(v)


def main():
    rows = sorted((parse(p) for p in sys.argv[1:] if p.endswith(".txt")), key=lambda r: (r["n"], r["ranks"], r["opts"], r["self_contact"]))
    keys = list(rows[0])
    with open(os.path.join(HERE, "newton_cg.csv"), "w") as f:
        f.write(",".join(keys) + "\n")
        for r in rows:
            f.write(",".join(fmt(r[k]) for k in keys) + "\n")
    if "--cost" in sys.argv:
        path = os.path.join(HERE, "cost.csv")
        old = list(csv.DictReader(open(path)))
        ckeys = list(old[0])
        pairs = {(r["n"], r["ranks"]) for r in rows if r["opts"] == "chol" and r["self_contact"] == 0}  # cost.csv: with/without pairs only
        new = [dict(r, vertices=r["n"] ** 2, triangles=2 * (r["n"] - 1) ** 2, solver="newton_chol", ok=1) for r in rows
               if r["opts"] == "chol" and (r["n"], r["ranks"]) in pairs]
        done = {(str(r["n"]), str(r["ranks"])) for r in new}
        keep = [r for r in old if not (r["solver"] == "newton_chol" and (r["n"], r["ranks"]) in done)]
        with open(path, "w") as f:
            f.write(",".join(ckeys) + "\n")
            for r in keep + new:
                f.write(",".join(fmt(r[k]) for k in ckeys) + "\n")


if __name__ == "__main__":
    main()
