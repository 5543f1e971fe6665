#!/usr/bin/env python3
"""A series file that rank 0 cannot write (disk full, an unwritable directory) ends the run with
one error line naming it, once, a non-zero exit, and the frames written before it still listed and
readable, at every rank count. Rank 0 writes the .vtu frames and the collections (series.pvd,
series.xdmf) alone: an error raised on rank 0 only left the other ranks in the next step's
collectives, waiting for ever (the 2-rank runs below hung until killed). The failure is made by a
directory where msim writes a file under a temporary name before renaming it:
- vtu: frame_000004.vtu.tmp, so frame 4 cannot be written (frames 0..3 were, and are listed);
- vtu and hdf5: a restart whose first frame rewrites the collection whole finds series.pvd.tmp or
  series.xdmf.tmp a directory; the collection the first run left (frames 0..5) stays as it was;
- vtu: series.pvd cannot grow past 4 KB (ulimit -f 4, SIGXFSZ ignored: the write fails with EFBIG
  as on a full disk), so a frame's entry written in place fails (the .vtu files are ~1 KB); the
  collection lists the frames before it. Under mpirun at 1 rank too (a singleton's MPI_Init
  writes files over the limit).
The monitors' CSV files, which rank 0 also writes alone, the same way: -msim_monitor_csv (a row a
step) and -msim_monitor_convergence (a row a Newton iteration) limited to 4 KB; their whole rows
before the failed one stay (each step's row in order from step 0).
Usage: output_write_error.py path/to/msim --np N"""
import os
import subprocess
import sys
import tempfile
import xml.etree.ElementTree as ET

import msimtest as mt

MSIM = mt.msim_path()
NP = mt.ranks()[0]
SCENE = ["-msim_cloth_n", "3", "-msim_output_every", "1"]
LIMIT = 40  # s: a run that ends takes 1-3 s (the old binary hung in 6 runs at 2 ranks: 240 s within ctest's 300)
check = mt.Checks()


def run(args, limit_kb=None):
    """msim to its end, or killed (mpirun and its ranks) after LIMIT s: (exit status or None,
    stderr's lines); limit_kb: each rank's files limited to that size"""
    if limit_kb is None:
        p = mt.popen(MSIM, args, NP, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=mt.RUN_ENV)
    else:
        cmd = mt.mpirun(NP) + ["bash", "-c", f'trap "" XFSZ; ulimit -f {limit_kb}; exec "$0" "$@"', MSIM] + list(args)
        p = subprocess.Popen(cmd, start_new_session=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=mt.RUN_ENV)
    try:
        _, err = p.communicate(timeout=LIMIT)
        return p.returncode, mt.lines(err)
    except subprocess.TimeoutExpired:
        mt.kill_all(p)
        return None, mt.lines(p.communicate()[1])


def listed(out, fmt):
    """the frame files the collection lists, in order"""
    root = ET.parse(os.path.join(out, "series.pvd" if fmt == "vtu" else "series.xdmf")).getroot()
    if fmt == "vtu":
        return [d.get("file") for d in root.iter("DataSet")]
    return [g.get("Name") + ".h5" for g in root.find("Domain/Grid").findall("Grid")]


def readable(out, f):
    """a listed frame file is complete: a .vtu ends its document, an .h5 holds every vertex's position"""
    path = os.path.join(out, f)
    if f.endswith(".vtu"):
        return open(path, "rb").read().rstrip().endswith(b"</VTKFile>")
    import h5py
    with h5py.File(path, "r") as h:
        return h["positions"].shape == (9, 3)  # the 3 x 3 cloth's vertices


def expect(label, args, out, fmt, bad, frames, limit_kb=None):
    rc, err = run(args, limit_kb)
    try:
        names = listed(out, fmt)
        ok_files = all(readable(out, f) for f in names)
    except (ET.ParseError, OSError) as e:
        names, ok_files = [f"unreadable: {e}"], False
    ext = ".vtu" if fmt == "vtu" else ".h5"
    want = [f"frame_{k:06d}{ext}" for k in range(frames)]
    check(rc is not None, f"np={NP} {label}: the run ends (not killed after {LIMIT} s)")
    check(rc not in (None, 0) and len(err) == 1 and err[0].startswith("msim: error: ") and os.path.join(out, bad) in err[0],
          f"np={NP} {label}: exit {rc}, one error line naming {bad} ({err[:3]})")
    check(names == want and ok_files, f"np={NP} {label}: the collection still lists frames 0..{frames - 1}, each readable ({names[-2:]})")


def main():
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "mid")
        os.makedirs(os.path.join(out, "frame_000004.vtu.tmp"))
        expect("vtu frame 4 unwritable", SCENE + ["-msim_steps", "10", "-msim_output", out], out, "vtu", "frame_000004.vtu.tmp", 4)
        # the entries are ~70 bytes after a ~140-byte head: the one that crosses 4096 bytes fails
        out = os.path.join(tmp, "full")
        entry = len('    <DataSet timestep="0.0002" part="0" file="frame_000001.vtu"/>\n')
        rc, err = run(SCENE + ["-msim_steps", "100", "-msim_output", out], 4)
        names = listed(out, "vtu") if os.path.exists(os.path.join(out, "series.pvd")) else []
        m = len(names)
        check(rc not in (None, 0) and len(err) == 1 and os.path.join(out, "series.pvd") + " failed" in err[0],
              f"np={NP} series.pvd limited to 4 KB: exit {rc}, one error line naming it ({err[:3]})")
        check(m > 4096 // (2 * entry) and names == [f"frame_{k:06d}.vtu" for k in range(m)] and all(readable(out, f) for f in names),
              f"np={NP} series.pvd limited to 4 KB: it lists frames 0..{m - 1}, each readable")
        for option, extra in (("-msim_monitor_csv", []), ("-msim_monitor_convergence", ["-msim_integrator", "implicit_euler"])):
            path = os.path.join(tmp, option[1:] + ".csv")
            rc, err = run(SCENE + extra + ["-msim_steps", "200", option, path], 4)
            check(rc not in (None, 0) and len(err) == 1 and f"{option}: write to {path} failed" in err[0],
                  f"np={NP} {option} limited to 4 KB: the run ends, exit {rc}, one error line naming it ({err[:3]})")
            rows = open(path).read().split("\n")[1:-1]  # the header, the whole rows, what the failed write left
            steps = [int(r.split(",")[0]) for r in rows]
            want = list(range(len(rows))) if option == "-msim_monitor_csv" else sorted(steps)
            check(len(rows) > 10 and steps == want and all(len(r.split(",")) == len(rows[0].split(",")) for r in rows),
                  f"np={NP} {option} limited to 4 KB: its {len(rows)} whole rows stay, in step order")
        for fmt, coll in (("vtu", "series.pvd"), ("hdf5", "series.xdmf")):
            out, ck = os.path.join(tmp, fmt), os.path.join(tmp, fmt + ".ck")
            first = SCENE + ["-msim_output", out, "-msim_output_format", fmt]
            r = mt.run(MSIM, first + ["-msim_steps", "5", "-msim_checkpoint", ck], NP)
            check(r.returncode == 0 and listed(out, fmt) == [f"frame_{k:06d}{'.vtu' if fmt == 'vtu' else '.h5'}" for k in range(6)],
                  f"np={NP} {fmt}: a first run writes frames 0..5 and a checkpoint" + ("" if r.returncode == 0 else ": " + r.stderr[-300:]))
            os.makedirs(os.path.join(out, coll + ".tmp"))
            expect(f"{fmt} restart, {coll} unwritable", first + ["-msim_steps", "10", "-msim_restart", ck], out, fmt, coll + ".tmp", 6)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
