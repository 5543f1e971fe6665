#!/usr/bin/env python3
"""The series' collection (series.pvd, series.xdmf) grows by O(1) bytes a frame and survives a kill
at any moment, in both formats:
- a run traced by strace (rank 0's writes): after the first frame, no frame writes more than two
  pages to the collection, and the run writes it at most 4 bytes per byte of the final file (a
  collection rewritten whole at every frame writes ~frames/2 times its size);
- replaying that trace write by write, and every write also cut at each page boundary inside it
  (where a kill -9 can stop a write), the collection is at every step well-formed XML that lists
  frames in order, each one's file already renamed into place, never fewer than before; the run's
  final collection lists exactly its frames;
- the state a kill can leave mid-way through adding a frame across a page (the entry staged, not
  yet listed, after an earlier frame added so) restarts like the same collection without the
  staged entry: a restart lists neither the staged entry nor anything of the comments;
- runs killed with SIGKILL after 30 and 80 frames leave a collection that parses and lists frames
  0..m, each complete on disk, with at most one frame on disk not yet listed.
Needs strace (its absence fails the test). Where strace cannot trace (ptrace denied: a container
without CAP_SYS_PTRACE), one line says so and the checks that read a trace (the O(1) writes, the
replay, the restart from a staged entry) are skipped; the runs' final collections and the kills are
still checked. Usage: output_series_append.py path/to/msim --np N"""
import os
import re
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET

import msimtest as mt

MSIM = mt.msim_path()
NP = mt.ranks()[0]
PAGE = os.sysconf("SC_PAGE_SIZE")
SCENE = ["-msim_cloth_n", "3", "-msim_output_every", "1"]
FRAMES = {"vtu": 300, "hdf5": 60}  # the vtu entry is ~70 bytes, the XDMF grid ~1.3 KB: both cross pages
check = mt.Checks()
SYSCALL = re.compile(r'^\d+ +(openat|write|pwrite64|rename|renameat|renameat2)\((.*)\) += (-?\d+)')
STRING = re.compile(r'"((?:\\x[0-9a-f]{2})*)"')
FDPATH = re.compile(r'^(\d+)<((?:\\x[0-9a-f]{2})*)>')


def unhex(s):
    return bytes.fromhex(s.replace("\\x", ""))


def listed(doc, fmt):
    """the frame files a collection lists, in its order (raises on a malformed document)"""
    root = ET.fromstring(bytes(doc))
    if fmt == "vtu":
        return [d.get("file") for d in root.iter("DataSet")]
    return [g.get("Name") + ".h5" for g in root.find("Domain/Grid").findall("Grid")]


def traced(args, tmp, name):
    """runs msim under strace; rank 0's syscalls on files, as (call, args, result) with strings decoded"""
    base = os.path.join(tmp, name + ".trace")
    st = ["strace", "-f", "-y", "-xx", "-s", "10000000", "-e", "trace=openat,write,pwrite64,rename,renameat,renameat2"]
    if NP == 1:
        cmd = st + ["-o", base + ".0", MSIM] + args
    else:
        cmd = mt.mpirun(NP) + ["sh", "-c", 'exec ' + " ".join(st) + ' -o "$0.$OMPI_COMM_WORLD_RANK" "$@"', base, MSIM] + args
    r = subprocess.run(cmd, capture_output=True, text=True, env=mt.RUN_ENV)
    check(r.returncode == 0, f"{name}: runs under strace" + ("" if r.returncode == 0 else ": " + r.stderr[-600:]))
    calls = []
    for line in open(base + ".0", errors="replace"):
        m = SYSCALL.match(line)
        if not m:
            if "unfinished" in line and ("pwrite64" in line or "rename" in line):
                check(False, f"{name}: a traced call cut by another thread: {line[:120]}")
            continue
        calls.append((m.group(1), m.group(2), int(m.group(3)), line))
    return calls


def replay(calls, out, fmt):
    """every state of the collection the trace passes through (and every page-boundary cut of a
    write to it) checked; returns the figures and some states for the restart check"""
    coll = os.path.join(out, "series.pvd" if fmt == "vtu" else "series.xdmf").encode()
    files, offset, on_disk = {}, {}, set()
    before, states, problems = [], 0, []
    written, per_frame, frame_bytes, crossings, staged = 0, [], 0, 0, []

    def look(doc, what):
        nonlocal before, states
        states += 1
        try:
            now = listed(doc, fmt)
        except ET.ParseError as e:
            problems.append(f"{what}: not well-formed ({e})")
            return
        missing = [f for f in now if f not in on_disk]
        if missing or now[:len(before)] != before or len(set(now)) != len(now) or now != sorted(now):
            problems.append(f"{what}: lists {now[-3:]} after {before[-3:]} (missing on disk: {missing[:2]})")
        before = now

    for call, args, res, line in calls:
        if call == "openat":
            ret = FDPATH.match(line.rsplit("= ", 1)[1])
            if ret:
                path = unhex(ret.group(2))
                offset[int(ret.group(1))] = 0
                if "O_TRUNC" in args:
                    files[path] = bytearray()
            continue
        if call.startswith("rename"):
            paths = [unhex(s) for s in STRING.findall(args)]
            if res == 0 and len(paths) == 2:
                files[paths[1]] = files.pop(paths[0], bytearray())
                if paths[1] == coll:
                    look(files[coll], "a rename")
                elif os.path.dirname(paths[1]) == out.encode():
                    on_disk.add(os.path.basename(paths[1]).decode())
                    if re.match(rb"frame_\d+\.(vtu|h5)$", os.path.basename(paths[1])):
                        per_frame.append(frame_bytes)
                        frame_bytes = 0
            continue
        fd = FDPATH.match(args)
        if not fd or res <= 0:
            continue
        path, data = unhex(fd.group(2)), unhex(STRING.findall(args)[0])
        if path not in (coll, coll + b".tmp"):
            continue
        written += res
        frame_bytes += res
        data = data[:res]
        at = int(args.rsplit(",", 1)[1]) if call == "pwrite64" else offset.get(int(fd.group(1)), 0)
        doc = files.setdefault(path, bytearray())
        old = bytes(doc)
        if path == coll:  # the states a kill inside this write can leave: cut at each page boundary
            for cut in range((at // PAGE + 1) * PAGE, at + len(data), PAGE):
                part = bytearray(doc)
                part[at:at + cut - at] = data[:cut - at]
                look(part, f"write of {len(data)} bytes at {at} cut at {cut}")
        if len(doc) < at:
            doc.extend(b"\0" * (at - len(doc)))
        doc[at:at + len(data)] = data
        if call == "write":
            offset[int(fd.group(1))] = at + len(data)
        if path == coll:
            if data == b"<":
                crossings += 1
            if data.startswith(b"<?msim -->"):  # an entry staged, not yet listed; the state before it
                staged.append((bytes(doc), old))
            look(doc, f"write of {len(data)} bytes at {at}")
    per_frame.append(frame_bytes)
    return {"problems": problems, "states": states, "written": written, "per_frame": per_frame,
            "crossings": crossings, "staged": staged, "final": before}


def kills(fmt, tmp):
    for after in (30, 80):
        out = os.path.join(tmp, f"kill_{fmt}_{after}")
        p = mt.popen(MSIM, ["-msim_cloth_n", "5", "-msim_steps", "1000000", "-msim_output", out, "-msim_output_every", "1",
                            "-msim_output_format", fmt], NP, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        ext = ".vtu" if fmt == "vtu" else ".h5"
        deadline = time.time() + 120
        while time.time() < deadline:
            time.sleep(0.05)
            if os.path.isdir(out) and sum(1 for f in os.listdir(out) if f.startswith("frame_") and f.endswith(ext)) >= after:
                break
        mt.kill_all(p)
        on_disk = sorted(f for f in os.listdir(out) if re.match(r"frame_\d+" + re.escape(ext) + "$", f))
        try:
            names = listed(open(os.path.join(out, "series.pvd" if fmt == "vtu" else "series.xdmf"), "rb").read(), fmt)
        except (ET.ParseError, OSError) as e:
            check(False, f"{fmt} killed after {len(on_disk)} frames: the collection does not parse ({e})")
            continue
        complete = all(open(os.path.join(out, f), "rb").read().rstrip().endswith(b"</VTKFile>") for f in names) if fmt == "vtu" \
            else all(os.path.getsize(os.path.join(out, f)) > 0 for f in names)
        want = [f"frame_{k:06d}{ext}" for k in range(len(names))]
        check(names == want and complete and len(on_disk) - len(names) in (0, 1),
              f"{fmt} np={NP} killed with SIGKILL after {len(on_disk)} frames on disk: the collection parses and lists frames "
              f"0..{len(names) - 1}, each complete ({names[-1:] if names else 'none'})")


def strace_works():
    """whether strace can trace here, and its last line of stderr where it cannot (ptrace denied:
    "ptrace(PTRACE_TRACEME, ...): Operation not permitted")"""
    r = subprocess.run(["strace", "-f", "-o", "/dev/null", "true"], capture_output=True, text=True)
    return r.returncode == 0, (r.stderr.strip().splitlines() or [f"exit {r.returncode}"])[-1]


def main():
    import shutil
    if not shutil.which("strace"):  # a failure, not a skip: the O(1) checks need it
        check(False, "strace is needed to trace the collection's writes (tools/install-deps.sh installs it)")
        return check.exit_code()
    tracing, why = strace_works()
    if not tracing:  # installed, but the kernel refuses it ptrace: the untraced checks still run
        print(f"np={NP}: the O(1)-write checks (and the trace's replay and staged-entry restart) are skipped: strace cannot trace here, "
              f"ptrace is denied ({why}); the final collections and the SIGKILL checks still run", flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in ("vtu", "hdf5"):
            n = FRAMES[fmt] - 1
            out, ck = os.path.join(tmp, fmt), os.path.join(tmp, fmt + ".ck")
            args = SCENE + ["-msim_steps", str(n), "-msim_output", out, "-msim_output_format", fmt, "-msim_checkpoint", ck]
            ext, coll = (".vtu", "series.pvd") if fmt == "vtu" else (".h5", "series.xdmf")
            if tracing:
                r = replay(traced(args, tmp, fmt), out, fmt)
            else:
                rr = mt.run(MSIM, args, NP)
                check(rr.returncode == 0, f"{fmt}: runs" + ("" if rr.returncode == 0 else ": " + rr.stderr[-600:]))
            final = open(os.path.join(out, coll), "rb").read()
            check(listed(final, fmt) == [f"frame_{k:06d}{ext}" for k in range(n + 1)],
                  f"{fmt} np={NP}: the final collection ({len(final)} bytes) is well-formed and lists frames 0..{n}")
            if not tracing:  # a restart from the run's end (the staged-entry one needs the trace)
                rr = mt.run(MSIM, SCENE + ["-msim_steps", str(n + 5), "-msim_output", out, "-msim_output_format", fmt, "-msim_restart", ck], NP)
                got = listed(open(os.path.join(out, coll), "rb").read(), fmt)
                check(rr.returncode == 0 and got == [f"frame_{k:06d}{ext}" for k in range(n + 6)],
                      f"{fmt} np={NP}: a restart to step {n + 5} lists frames 0..{n + 5} ({got[-2:]})" + ("" if rr.returncode == 0 else ": " + rr.stderr[-600:]))
                kills(fmt, tmp)
                continue
            check(not r["problems"] and r["states"] > n,
                  f"{fmt} np={NP}: each of {r['states']} states a kill can leave (every write to the collection, cut at page "
                  f"boundaries too) is well-formed, lists frames in order, each on disk, none lost" + "".join("; " + m for m in r["problems"][:3]))
            middle = r["per_frame"][2:-1]  # after the first frame's write, before the last frame and the run's end
            most = max(middle) if middle else 0
            check(middle and most <= 2 * PAGE,
                  f"{fmt} np={NP}: at most {most} bytes written to the collection by a frame (bound 2 pages, {2 * PAGE})")
            check(r["written"] <= 4 * len(final),
                  f"{fmt} np={NP}: {r['written']} bytes written to the collection over {n + 1} frames, "
                  f"{r['written'] / len(final):.2f} per byte of the final {len(final)} (bound 4)")
            check(r["crossings"] >= 2, f"{fmt} np={NP}: {r['crossings']} frames added across a page (at least 2 to check the restart below)")
            if r["crossings"] >= 2 and len(r["staged"]) >= 2:
                with_pi, without = r["staged"][1]
                got = {}
                for label, doc in (("staged", with_pi), ("plain", without)):
                    d = os.path.join(tmp, f"{fmt}_{label}")
                    os.makedirs(d)
                    for f in os.listdir(out):
                        if f.startswith("frame_") or f == "mesh.h5":
                            os.link(os.path.join(out, f), os.path.join(d, f))
                    open(os.path.join(d, coll), "wb").write(doc)
                    rr = mt.run(MSIM, SCENE + ["-msim_steps", str(n + 5), "-msim_output", d, "-msim_output_format", fmt, "-msim_restart", ck], NP)
                    check(rr.returncode == 0, f"{fmt} {label}: restarts" + ("" if rr.returncode == 0 else ": " + rr.stderr[-600:]))
                    try:
                        got[label] = listed(open(os.path.join(d, coll), "rb").read(), fmt)
                    except ET.ParseError as e:
                        got[label] = [f"not well-formed: {e}"]
                staged_only = listed(with_pi, fmt)
                check(got["staged"] == got["plain"] and len(got["plain"]) > len(staged_only) and got["plain"][-1] == f"frame_{n + 5:06d}{ext}",
                      f"{fmt} np={NP}: a restart from a collection killed with an entry staged (after {len(staged_only)} frames listed) "
                      f"lists what it does from the same collection without it ({len(got['plain'])} frames, up to {got['plain'][-1:]}; "
                      f"with it: {len(got['staged'])}, up to {got['staged'][-1:]})")
            kills(fmt, tmp)
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
