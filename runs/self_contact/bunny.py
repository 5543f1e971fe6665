#!/usr/bin/env python3
"""The bunny (examples/bunny.opts, a tet solid hanging from its ears, 150 steps, a frame every 3)
with and without self-contact on its boundary faces, with and without the volume term: per frame
the intersecting pairs of vertex-disjoint boundary triangles (runs/tools/intersections.py) and the
inverted tets (signed volumes against frame 0's, volume/tetcheck.py), both computed here from the
frames' positions (numpy, independent of msim), and the CPU user time of each run (1 rank).
Writes bunny.csv (one row per case and frame) and bunny.png.
Usage: /usr/bin/python3 runs/self_contact/bunny.py build/msim [--out DIR]
  (--out keeps the runs there; a case whose DIR/CASE/series.pvd and DIR/CASE.time exist is read,
  not rerun)"""
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


def run(exe, out, name, vol, sc):
    series, timef = os.path.join(out, name), os.path.join(out, name + ".time")
    if not (os.path.exists(os.path.join(series, "series.pvd")) and os.path.exists(timef)):
        before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime
        subprocess.run([exe, "-options_file", "examples/bunny.opts", "-msim_volume", vol, "-msim_self_contact", sc,
                        "-msim_output", series], cwd=ROOT, check=True, stdout=subprocess.DEVNULL)
        with open(timef, "w") as f:
            f.write(f"{resource.getrusage(resource.RUSAGE_CHILDREN).ru_utime - before:.2f}\n")
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
