#!/usr/bin/env python3
"""The bunny (examples/bunny.opts, a tet solid hanging from its ears, 150 steps, a frame every 3)
with and without self-contact on its boundary faces, with and without the volume term: per frame
the intersecting pairs of vertex-disjoint boundary triangles (runs/tools/intersections.py) and the
inverted tets (signed volumes against frame 0's, volume/tetcheck.py), both computed here from the
frames' positions (numpy, independent of msim), and the CPU user time of each run (1 rank).
Writes bunny.csv (one row per case and frame) and bunny.png.
Usage: /usr/bin/python3 runs/self_contact/bunny.py build/msim [--out DIR] [--against REF --rounds R [--append]]
  (--out keeps the runs there; a case whose DIR/CASE/series.pvd and DIR/CASE.time exist is read,
  not rerun)
--against REF: first times the four cases and examples/bunny_drop.opts with and without self-contact
  R times (3 by default), alternating msim and the msim REF (another build) and swapping which goes
  first each round, since a single run's CPU time on a shared host moves by tens of percent; each
  figure is the least of its R runs. Writes bunny_cost.csv (every run) and DIR/CASE.time (msim's
  least), so the frames read afterwards are msim's last run of each case. --append adds R more
  rounds to those in bunny_cost.csv and takes the least over all of them."""
import csv
import os
import resource
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.join(HERE, "..", "..")
sys.path.insert(0, os.path.join(HERE, "..", "tools"))
sys.path.insert(0, os.path.join(HERE, "volume"))
import intersections  # noqa: E402
import tetcheck  # noqa: E402

CASES = {  # name: (volume term, self-contact)
    "springs": ("0", "0"),
    "springs_self": ("0", "1"),
    "volume": ("1", "0"),
    "volume_self": ("1", "1"),  # the example as shipped
}


DROP = {"drop": "0", "drop_self": "1"}  # examples/bunny_drop.opts: name: self-contact


def cpu_of(cmd):
    before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
    subprocess.run(cmd, cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before


def cost(exes, out, rounds, append):
    """CPU user time of every run, builds alternated; least per build and case into DIR/CASE.time"""
    path = os.path.join(HERE, "bunny_cost.csv")
    rows = []
    if append:
        with open(path) as f:
            rows = [(r["build"], r["msim"], r["options_file"], r["case"], int(r["round"]), float(r["cpu_user_s"])) for r in csv.DictReader(f)]
    first = max((r[4] for r in rows), default=-1) + 1
    runs = [(name, "examples/bunny.opts", ["-msim_volume", vol, "-msim_self_contact", sc]) for name, (vol, sc) in CASES.items()]
    runs += [(name, "examples/bunny_drop.opts", ["-msim_self_contact", sc]) for name, sc in DROP.items()]
    for r in range(first, first + rounds):
        for name, opts, flags in runs:
            for label, exe in (exes if r % 2 == 0 else exes[::-1]):
                series = os.path.join(out, name) if label == "msim" else os.path.join(out, label, name)
                t = cpu_of([exe, "-options_file", opts, *flags, "-msim_output", series])
                rows.append((label, exe, opts, name, r, t))
                print(f"round {r} {label:5s} {name:12s} CPU {t:6.2f} s", flush=True)
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["build", "msim", "options_file", "case", "round", "cpu_user_s"])
        w.writerows([(lb, exe, opts, name, r, f"{t:.2f}") for lb, exe, opts, name, r, t in rows])
    least = {}
    for lb, _, _, name, _, t in rows:
        least[lb, name] = min(t, least.get((lb, name), t))
    for name in CASES:
        with open(os.path.join(out, name + ".time"), "w") as f:
            f.write(f"{least['msim', name]:.2f}\n")
    for lb, _ in exes:
        print(f"{lb}: least CPU " + ", ".join(f"{n} {least[lb, n]:.2f} s" for n in [*CASES, *DROP]) +
              f"; self-contact x{least[lb, 'volume_self'] / least[lb, 'volume']:.2f} with the volume term,"
              f" x{least[lb, 'springs_self'] / least[lb, 'springs']:.2f} springs alone, x{least[lb, 'drop_self'] / least[lb, 'drop']:.2f} drop")


def run(exe, out, name, vol, sc):
    series, timef = os.path.join(out, name), os.path.join(out, name + ".time")
    if not (os.path.exists(os.path.join(series, "series.pvd")) and os.path.exists(timef)):
        t = cpu_of([exe, "-options_file", "examples/bunny.opts", "-msim_volume", vol, "-msim_self_contact", sc, "-msim_output", series])
        with open(timef, "w") as f:
            f.write(f"{t:.2f}\n")
    with open(timef) as f:
        cpu = float(f.read())
    frames = tetcheck.tet_frames(os.path.join(series, "series.pvd"))
    V0 = tetcheck.signed_volumes(frames[0][1], frames[0][2])
    surf = intersections.surface_triangles(frames[0][2])
    rows = [(t, intersections.intersecting_pairs(x, surf), int((tetcheck.signed_volumes(x, c) / V0 <= 0).sum())) for t, x, c in frames]
    return cpu, rows


def main():
    exe = os.path.abspath(sys.argv[1])
    out = sys.argv[sys.argv.index("--out") + 1] if "--out" in sys.argv else os.path.join("/tmp", "msim_bunny_self")
    os.makedirs(out, exist_ok=True)
    if "--against" in sys.argv:
        ref = os.path.abspath(sys.argv[sys.argv.index("--against") + 1])
        rounds = int(sys.argv[sys.argv.index("--rounds") + 1]) if "--rounds" in sys.argv else 3
        cost([("msim", exe), ("ref", ref)], out, rounds, "--append" in sys.argv)
    res = {name: run(exe, out, name, *flags) for name, flags in CASES.items()}
    with open(os.path.join(HERE, "bunny.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "volume", "self_contact", "cpu_user_s", "t", "pairs", "inverted"])
        for name, (cpu, rows) in res.items():
            for t, p, inv in rows:
                w.writerow([name, *CASES[name], f"{cpu:.2f}", f"{t:.3f}", p, inv])
    for name, (cpu, rows) in res.items():
        print(f"{name:13s} CPU {cpu:6.1f} s  pairs {max(p for _, p, _ in rows)} max  inverted {max(i for _, _, i in rows)} max  "
              f"pairs per frame {[p for _, p, _ in rows]}")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 3, figsize=(14, 4))
    labels = {"springs": "springs alone", "springs_self": "springs + self-contact", "volume": "volume term",
              "volume_self": "volume + self-contact (the example)"}
    for name, (cpu, rows) in res.items():
        t = [r[0] for r in rows]
        ax[0].plot(t, [r[1] for r in rows], "o-", ms=3, label=labels[name])
        ax[1].plot(t, [r[2] for r in rows], "o-", ms=3, label=labels[name])
    ax[0].set(xlabel="t (s)", ylabel="intersecting triangle pairs", title="boundary self-intersections per frame")
    ax[1].set(xlabel="t (s)", ylabel="inverted tets", title="inverted tets per frame")
    ax[0].legend(fontsize=8)
    names = list(res)
    ax[2].bar(range(len(names)), [res[n][0] for n in names])
    ax[2].set_xticks(range(len(names)), [labels[n].replace(" + ", "\n+ ") for n in names], fontsize=7)
    ax[2].set(ylabel="CPU user time, 150 steps (s)", title="cost (1 rank)")
    fig.tight_layout()
    fig.savefig(os.path.join(HERE, "bunny.png"), dpi=110)


if __name__ == "__main__":
    main()
