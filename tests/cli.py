#!/usr/bin/env python3
"""The command line as a user meets it, at 1 rank (a singleton: standard output is msim's own):
- `msim -help`'s first line names what msim simulates today (it said "cloth, chains" alone);
- standard output closed by its reader (`msim -msim_monitor | head -1`): the run stops after the
  step quietly, exit status 141 (was PETSc's "Caught signal number 13 Broken Pipe" trace and Open
  MPI's abort lines, exit 59), the checkpoint asked for written, and a restart from it runs on;
- -msim_view_final into a directory that is not there, or under a file: refused before any step
  in one line naming the option (failed after the whole run, naming none)."""
import os
import subprocess
import sys
import tempfile

import msimtest as mt

MSIM = mt.msim_path()


def main():
    check = mt.Checks()
    r = mt.run(MSIM, ["-help"])
    first = r.stdout.splitlines()[0] if r.stdout else ""
    check(r.returncode == 0 and all(w in first for w in ("surfaces", "tet solids", "obstacles", "self-contact", "PETSc TS")),
          f"-help's first line describes msim: {first!r}")
    with tempfile.TemporaryDirectory() as tmp:
        ck = os.path.join(tmp, "chain.ck")
        # 20000 monitor lines (2.7 MB) fill any pipe's buffer: msim is still stepping when the reader leaves
        args = ["-msim_scene", "chain", "-msim_steps", "20000"]
        p = mt.popen(MSIM, args + ["-msim_monitor", "-msim_checkpoint", ck], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        line = p.stdout.readline()
        p.stdout.close()
        err = p.stderr.read().decode()
        rc = p.wait()
        check(line.startswith(b"step      0 ") and rc == 141 and err == "" and os.path.exists(ck),
              f"standard output closed after one line: exit {rc} (141), nothing on stderr ({err[-300:]!r}), the checkpoint written")
        r = mt.run(MSIM, args + ["-msim_restart", ck])
        check(r.returncode == 0 and r.stderr.strip() == "", f"the restart from it runs to the end (exit {r.returncode}, {r.stderr.strip()[-200:]!r})")
        open(os.path.join(tmp, "afile"), "w").close()
        for where, why in (("nodir/x.bin", "No such file or directory"), ("afile/x.bin", "Not a directory")):
            r = mt.run(MSIM, ["-msim_scene", "chain", "-msim_steps", "3", "-msim_monitor", "-msim_view_final", "binary:" + where], cwd=tmp)
            lines = mt.lines(r.stderr)
            check(r.returncode != 0 and r.stdout == "" and lines == [f"msim: error: -msim_view_final binary:{where}: cannot write in {where.split('/')[0]} ({why})"],
                  f"-msim_view_final binary:{where}: refused before the first step in one line ({lines!r}, stdout {r.stdout[:80]!r})")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
