#!/usr/bin/python3
"""The series' collection against the number of frames: the bytes written to series.pvd or
series.xdmf over a run (strace: every write and pwrite64 to it and to its temporary file), and the
output's time (-log_view's MSimOutput event, frames and collection together, best of 2 runs) and
the run's wall time, on a 5 x 5 cloth written at every step, in both formats, for this msim and,
given --old, an earlier build (one that rewrote the collection whole at every frame).
Usage: /usr/bin/python3 runs/output_scaling/study.py [--msim build/msim] [--old PATH] [--frames 500,2000]
Writes runs/output_scaling/scaling.csv and prints it."""
import argparse
import os
import re
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import msimrun  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def written(exe, args, coll, tmp):
    """bytes written to the collection (and its .tmp) by a run, from strace -y"""
    trace = os.path.join(tmp, "trace")
    subprocess.run(["strace", "-f", "-y", "-e", "trace=write,pwrite64", "-o", trace, exe] + args,
                   env=msimrun.ENV, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    total = 0
    for line in open(trace, errors="replace"):
        m = re.search(r"(?:write|pwrite64)\(\d+<([^>]*)>.*\) += (\d+)$", line)
        if m and os.path.basename(m.group(1)) in (coll, coll + ".tmp"):
            total += int(m.group(2))
    return total


def timed(exe, args):
    """(MSimOutput event s, wall s) of a run with -log_view"""
    t0 = time.perf_counter()
    r = subprocess.run([exe] + args + ["-log_view"], env=msimrun.ENV, check=True, capture_output=True, text=True)
    return msimrun.event(r.stdout, "MSimOutput")[1], time.perf_counter() - t0


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--msim", default=msimrun.MSIM)
    p.add_argument("--old")
    p.add_argument("--frames", default="500,2000")
    a = p.parse_args()
    rows = []
    builds = [("this", a.msim)] + ([("old", a.old)] if a.old else [])
    for fmt, coll in (("vtu", "series.pvd"), ("hdf5", "series.xdmf")):
        for frames in (int(f) for f in a.frames.split(",")):
            for label, exe in builds:
                with tempfile.TemporaryDirectory() as tmp:
                    out = os.path.join(tmp, "out")
                    args = ["-msim_cloth_n", "5", "-msim_steps", str(frames - 1), "-msim_output", out, "-msim_output_every", "1",
                            "-msim_output_format", fmt]
                    w = written(exe, args, coll, tmp)
                    size = os.path.getsize(os.path.join(out, coll))
                    runs = [timed(exe, args) for _ in range(2)]
                rows.append({"format": fmt, "frames": frames, "build": label, "collection_bytes": size, "bytes_written": w,
                             "written_per_frame": round(w / frames, 1), "written_per_byte": round(w / size, 2),
                             "output_s": round(min(r[0] for r in runs), 3), "wall_s": round(min(r[1] for r in runs), 2)})
                print(",".join(str(v) for v in rows[-1].values()), flush=True)
    msimrun.write_csv(os.path.join(HERE, "scaling.csv"), rows)


if __name__ == "__main__":
    main()
