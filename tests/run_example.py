#!/usr/bin/env python3
"""Regression run of one example: runs msim on examples/NAME.opts at NP ranks with -options_left
(a mistyped option fails the test), the per-step monitor and -msim_view_final, then compares the
output (monitor lines at every STRIDE-th step, the final positions, the spectrum report) with
tests/expected/NAME.out through numdiff. The same expected file serves every rank count: results
must not depend on the partition beyond roundoff.
Usage: run_example.py MSIM NAME NP [--stride K] [--regen] [-- extra msim options]"""
import argparse
import os
import re
import sys
import tempfile

import msimtest as mt
import numdiff

HERE, ROOT = mt.HERE, mt.ROOT


def main():
    p = argparse.ArgumentParser()
    p.add_argument("msim")
    p.add_argument("name")
    p.add_argument("np", type=int)
    p.add_argument("--stride", type=int, default=100)
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--atol", type=float, default=1e-8)
    p.add_argument("--regen", action="store_true")
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    a = p.parse_args(argv[:argv.index("--")] if "--" in argv else argv)
    a.extra = extra
    with tempfile.TemporaryDirectory() as tmp:
        final = os.path.join(tmp, "final.txt")
        opts = os.path.join(ROOT, "examples", a.name + ".opts")
        with open(opts) as f:
            text = f.read()
        args = ["-options_file", opts, "-options_left"]
        if not re.search(r"^-msim_spectrum\s*$", text, re.M):  # spectrum-only examples do not step
            args += ["-msim_monitor", "-msim_view_final", mt.view_ascii(final)]
        if re.search(r"^-msim_output\s", text, re.M):  # the series goes to the temporary folder
            args += ["-msim_output", os.path.join(tmp, "series")]
        args += a.extra
        # one BLAS thread whatever the caller's environment: the expected files were made so
        r = mt.run(os.path.abspath(a.msim), args, a.np, cwd=ROOT, env=dict(mt.ENV, OPENBLAS_NUM_THREADS="1"))
        if r.returncode != 0:
            print(" ".join(mt.command(a.msim, args, a.np)))
            print(r.stdout[-4000:], r.stderr[-4000:])
            sys.exit(f"msim exited with {r.returncode}")
        if "There are no unused options" not in r.stdout or "WARNING! There are options you set that were not used" in r.stdout:
            print(r.stdout[-2000:])
            sys.exit("an option was not used (mistyped?)")
        lines = []
        out = r.stdout.splitlines(True)
        if re.search(r"^-ksp_type\s+(cg|gmres|minres)\s*$", text, re.M):
            # a Krylov method's iteration count depends on the partition's roundoff: not compared
            out = [re.sub(r" lin \d+ ", " lin - ", l) for l in out]
        steps = [l for l in out if re.match(r"step\s+\d+\s", l)]
        for line in out:
            m = re.match(r"step\s+(\d+)\s", line)
            if m:
                if int(m.group(1)) % a.stride == 0 or line is steps[-1]:
                    lines.append(line)
            elif line.startswith(("spectrum", "  ", "    ")) and "unused" not in line:
                lines.append(line)
        if os.path.exists(final):
            with open(final) as f:
                # PETSc's header comment names the rank count; the values follow in full precision
                lines += [l for l in f if not l.startswith("%")]
    expected = os.path.join(HERE, "expected", a.name + ".out")
    if a.regen:
        with open(expected, "w") as f:
            f.writelines(lines)
        print(f"wrote {expected} ({len(lines)} lines)")
        return
    with open(expected) as f:
        want = f.readlines()
    problems = numdiff.compare(want, lines, a.rtol, a.atol)
    for msg in problems[:10]:
        print(msg)
    if problems:
        sys.exit(f"{a.name} at {a.np} ranks differs from tests/expected/{a.name}.out")
    print(f"{a.name} at {a.np} ranks: {len(lines)} lines match")


if __name__ == "__main__":
    main()
