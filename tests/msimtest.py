"""What msim's Python tests share, so that each script holds only what it checks:
- the command line: msim alone at 1 rank (a singleton, as a user typing ./msim runs it), under
  mpirun at more, with tools/env.sh's environment (Open MPI as root, more ranks than cores, one BLAS
  thread per rank) so that a script runs the same from ctest and from a shell;
- running it and reading what it wrote: stderr's lines, -msim_view_final's ascii_matlab file,
  the -msim_monitor_csv / -msim_monitor_convergence CSV files, series.pvd's frames;
- a tally of named checks (Checks), printed as they are made, whose exit code fails the test when
  any check failed or when none was made;
- ending a run with SIGKILL, mpirun and its ranks at once (kill_all).
Usage in a script (registered by one line in tests/CMakeLists.txt's MSIM_SCRIPT_TESTS):
  import msimtest as mt
  msim, check = mt.msim_path(), mt.Checks()
  for np in mt.ranks():
      r = mt.run(msim, ["-msim_steps", "3"], np)
      check(r.returncode == 0, f"np={np}: runs")
  sys.exit(check.exit_code())"""
import atexit
import csv
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# tools/env.sh's settings and MSIM_TEST_ENV's yielding ranks and named pml (tests/CMakeLists.txt
# says why; ctest sets the same): values already set win
ENV = dict(os.environ)
for _k, _v in (("OMPI_ALLOW_RUN_AS_ROOT", "1"), ("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1"),
               ("OMPI_MCA_rmaps_base_oversubscribe", "1"), ("OMPI_MCA_mpi_yield_when_idle", "1"),
               ("OMPI_MCA_pml", "ob1"), ("OPENBLAS_NUM_THREADS", "1")):
    ENV.setdefault(_k, _v)

# Open MPI's session directory: a singleton started with OMPI_MCA_ess_singleton_isolated (ctest's
# environment, tests/CMakeLists.txt) always takes <tmpdir>/ompi.<host>.<uid>/jf.0/1, so singletons
# running at once (two tests side by side, or one test's runs in parallel) create and remove the
# same directory: "A call to mkdir was unable to create the desired directory ... File exists",
# MPI_Init aborted (bad_input_np1, once, next to another test's singletons). Each singleton run
# gets a directory of its own under /tmp (short, as Open MPI's paths want), removed after it (a
# popen's at exit). mpirun's jobs keep the base they are given: mpirun names them uniquely, and a
# fresh base shared by concurrent mpiruns made them race to create its ompi.<host>.<uid> (seen:
# bad_input_np2, "ORTE_ERROR_LOG: Error in file session_dir.c").
_SESSIONS = []
atexit.register(lambda: [shutil.rmtree(d, True) for d in _SESSIONS])


def _own_session(np, kw):
    """kw's env with a session directory of this run's own for a singleton; returns it, or None"""
    if np != 1:
        return None
    env = dict(kw.get("env") or ENV)
    env["OMPI_MCA_orte_tmpdir_base"] = tempfile.mkdtemp(prefix="msim-ompi-", dir="/tmp")
    kw["env"] = env
    return env["OMPI_MCA_orte_tmpdir_base"]


def msim_path(argv=None):
    """the msim executable named first on the command line, absolute (tests run msim in other
    directories)"""
    argv = sys.argv if argv is None else argv
    if len(argv) < 2:
        sys.exit(f"usage: {os.path.basename(argv[0])} path/to/msim [...]")
    return os.path.abspath(argv[1])


def without_tetgen(script, needs="the bunny"):
    """True, once said, where ctest passes --no-tetgen (msim built without TetGen, which meshes
    the surface the test needs): the script has nothing to check"""
    if "--no-tetgen" not in sys.argv:
        return False
    print(f"{script}: msim was built without TetGen, which {needs} needs: nothing to check")
    return True


def ranks(default=(1, 2), argv=None):
    """the rank counts a script runs msim at: `--np N` on its command line (ctest's per-rank tests,
    tests/CMakeLists.txt) gives [N], else the default"""
    argv = sys.argv if argv is None else argv
    if "--np" in argv:
        return [int(argv[argv.index("--np") + 1])]
    return list(default)


def mpirun(np):
    """mpirun's part of a command line for np ranks; -q keeps mpirun's own banner (about a rank's
    non-zero exit) out of stderr, where the tests read msim's lines"""
    return ["mpirun", "--allow-run-as-root", "--oversubscribe", "-q", "-n", str(np)]


def command(exe, args=(), np=1):
    """exe with args at np ranks: alone at 1 rank, under mpirun at more"""
    return ([] if np == 1 else mpirun(np)) + [exe] + [str(a) for a in args]


# For runs to their end (run(), not popen()): when a rank exits non-zero (bad input at 2 ranks),
# mpirun sends the job's ranks SIGTERM and waits odls_base_sigkill_timeout (1 s) before SIGKILL,
# even when every rank has already exited: 1-2 s more per refused run (bad_input's 2-rank half:
# 67 s without the wait, 137 and 146 s with it, load ~5-8). Not for popen(): a SIGTERM to mpirun
# reaches the ranks the same way, and without the wait they are killed before they save their
# checkpoint (tests/checkpoint.py's SIGTERM check).
RUN_ENV = dict(ENV)
RUN_ENV.setdefault("OMPI_MCA_odls_base_sigkill_timeout", "0")


def run(exe, args=(), np=1, cwd=None, **kw):
    """runs exe to its end; stdout and stderr captured as text"""
    kw.setdefault("env", RUN_ENV)
    own = _own_session(np, kw)
    try:
        return subprocess.run(command(exe, args, np), cwd=cwd, capture_output=True, text=True, **kw)
    finally:
        if own:
            shutil.rmtree(own, True)


# run_many's runs at once: a short run (bad input refused at set-up, a mesh file read) spends much
# of its wall time where its core idles (the loader mapping PETSc's ~110 libraries, mpirun starting
# and reaping its ranks): a refused run takes ~0.45 s wall for ~0.3 s CPU alone, at 2 ranks 0.5-1.5 s
# for ~0.45 s. ctest sets MSIM_TEST_JOBS to the test's PROCESSORS, capped at 2 (tests/CMakeLists.txt
# says why): a 2-rank test's runs go two at a time, a 1-rank test's one after another; by hand, 2.
JOBS = max(1, int(os.environ.get("MSIM_TEST_JOBS", "2")))


def run_many(exe, arglists, np=1, cwd=None, jobs=None, **kw):
    """run() of exe with each of arglists at np ranks, up to jobs (JOBS) at a time: independent
    runs only (none reads what another writes). The results come in arglists' order, so that a
    script checks them, and prints its checks, in the order it did when it ran them one by one"""
    from concurrent.futures import ThreadPoolExecutor
    arglists = [list(a) for a in arglists]
    with ThreadPoolExecutor(max_workers=jobs or JOBS) as pool:
        return list(pool.map(lambda a: run(exe, a, np, cwd=cwd, **kw), arglists))


def run_info(exe, args=(), np=1, classes="", cwd=None, **kw):
    """runs exe like run() with PETSc's -info written to one file per rank (PETSc names them
    info.RANK in a temporary directory): ranks that share stdout can cut a line of one rank into
    another's (a test once read a spliced number), files cannot. The process gets .info, every
    rank's lines in rank order, as stdout would have held them unspliced"""
    import glob
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        base = os.path.join(tmp, "info")
        r = run(exe, list(args) + ["-info", base + (":" + classes if classes else "")], np, cwd=cwd, **kw)
        files = sorted(glob.glob(base + ".*"), key=lambda f: int(f.rsplit(".", 1)[1]))
        r.info = "".join(open(f, errors="replace").read() for f in files)
    return r


def popen(exe, args=(), np=1, cwd=None, **kw):
    """starts exe in the background (a new session, so that kill_all reaches its ranks)"""
    kw.setdefault("start_new_session", True)
    kw.setdefault("env", ENV)
    own = _own_session(np, kw)
    if own:
        _SESSIONS.append(own)  # removed at exit
    return subprocess.Popen(command(exe, args, np), cwd=cwd, **kw)


def lines(text):
    """the non-blank lines of a stream"""
    return [l for l in text.splitlines() if l.strip()]


def refusals(check, exe, base, cases, np):
    """bad input: for each (label, args, words) of cases, msim with base + args exits non-zero with
    one error line that holds every one of words"""
    cases = list(cases)
    for (label, args, words), r in zip(cases, run_many(exe, [list(base) + list(args) for _, args, _ in cases], np)):
        err = lines(r.stderr)
        check(r.returncode != 0 and len(err) == 1 and all(w in err[0] for w in words), f"np {np}: {label}: one error line naming it ({err})")


def view_ascii(path):
    """the ascii_matlab option of -msim_view_final, as a PetscViewer spec"""
    return f"ascii:{path}:ascii_matlab"


def read_view(path):
    """the numbers of a Vec written by -msim_view_final ascii:PATH:ascii_matlab, in order (PETSc's
    header and the 'Vec_... = [' / '];' lines around them are not numbers)"""
    with open(path) as f:
        return [float(l) for l in f if l.strip() and l.strip()[0] in "+-0123456789"]


def read_binary_vec(path):
    """the numbers of a Vec written by -msim_view_final binary:PATH (big-endian: int classid, int n,
    n doubles), bit for bit: restart tests compare them exactly"""
    import struct
    data = open(path, "rb").read()
    n = struct.unpack(">i", data[4:8])[0]
    return struct.unpack(f">{n}d", data[8:8 + 8 * n])


def positions(path):
    """read_view's numbers as an (n, 3) numpy array of vertex positions"""
    import numpy as np
    return np.array(read_view(path)).reshape(-1, 3)


def final_positions(exe, args, np, tmp, name="final", cwd=None, info=None):
    """runs exe with -msim_view_final into tmp/NAME_NP.txt; (n, 3) positions, or None when the run
    failed (its stderr's tail printed), and the finished process; info (a class list, "" for all)
    runs it with run_info's -info files"""
    path = os.path.join(tmp, f"{name}_{np}.txt")
    args = list(args) + ["-msim_view_final", view_ascii(path)]
    r = run(exe, args, np, cwd=cwd) if info is None else run_info(exe, args, np, info, cwd=cwd)
    if r.returncode:
        print(f"msim exited with {r.returncode}: {' '.join(str(a) for a in args)}\n{r.stderr[-1500:]}")
        return None, r
    return positions(path), r


def read_csv(path):
    """the rows of a CSV file msim wrote (-msim_monitor_csv, -msim_monitor_convergence) as dicts
    keyed by its header"""
    with open(path) as f:
        return list(csv.DictReader(f))


def write_box_obj(path, b):
    """a closed box x0,x1,y0,y1,z0,z1 as 12 outward triangles in an OBJ file (a mesh obstacle)"""
    x0, x1, y0, y1, z0, z1 = b
    V = [(x, y, z) for x in (x0, x1) for y in (y0, y1) for z in (z0, z1)]
    Q = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    with open(path, "w") as f:
        for v in V:
            f.write("v %r %r %r\n" % v)
        for q in Q:
            f.write("f %d %d %d\nf %d %d %d\n" % (q[0] + 1, q[1] + 1, q[2] + 1, q[0] + 1, q[2] + 1, q[3] + 1))


def frames(out):
    """the frame files series.pvd in the output directory out lists, in order (read as XML: a killed
    run's collection may hold an entry not yet listed, inside a processing instruction)"""
    import xml.etree.ElementTree as ET
    return [d.get("file") for d in ET.parse(os.path.join(out, "series.pvd")).getroot().iter("DataSet")]


class Checks:
    """A tally of named checks: each prints 'ok' or 'FAIL' and what it checked (only failures with
    quiet=True); exit_code() is 1 when any failed or when none was made (a test that checked
    nothing passes nothing)."""

    def __init__(self, quiet=False):
        self.passed = 0
        self.failed = 0
        self.quiet = quiet

    def __call__(self, ok, what):
        ok = bool(ok)
        if not ok or not self.quiet:
            print(("ok   " if ok else "FAIL ") + what, flush=True)
        self.passed += ok
        self.failed += not ok
        return ok

    def exit_code(self):
        if self.passed + self.failed == 0:
            print("FAILED: no check was made")
            return 1
        print(f"{self.passed} passed, {self.failed} failed")
        return 1 if self.failed else 0


def kill_all(p):
    """SIGKILL to mpirun's ranks (Open MPI puts them in process groups of their own) and to mpirun
    or the single msim, at once; returns when none is left"""
    ranks = [int(x) for x in subprocess.run(["pgrep", "-P", str(p.pid)], capture_output=True, text=True).stdout.split()]
    for pid in ranks + [p.pid]:
        try:
            os.kill(pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
    p.wait()
    deadline = time.time() + 10  # a zombie no init reaps stays listed: give up waiting then
    for pid in ranks:
        while time.time() < deadline:
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                break
            time.sleep(0.01)
