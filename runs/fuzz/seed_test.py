#!/usr/bin/env python3
"""ctest: a fuzz harness (built without libFuzzer) over its seed corpus, and over the findings
kept under runs/fuzz/findings/<format>/ once fixed: every input runs without a crash. Fails when
there is no input at all (an empty corpus tests nothing) or when the harness ran fewer inputs than
the directories hold."""
import os
import re
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
from seeds import make  # noqa: E402

harness, fmt = sys.argv[1], sys.argv[2]
with tempfile.TemporaryDirectory() as tmp:
    dirs = [make(tmp, fmt)]
    found = os.path.join(HERE, "findings", fmt)
    if os.path.isdir(found):
        dirs.append(found)
    inputs = sum(1 for d in dirs for f in os.listdir(d) if os.path.isfile(os.path.join(d, f)))
    if inputs == 0:
        sys.exit(f"FAILED: no input for the {fmt} harness in {', '.join(dirs)}")
    r = subprocess.run([harness] + dirs, capture_output=True, text=True)
    print(r.stdout.strip(), r.stderr.strip()[-2000:])
    if r.returncode:
        sys.exit(r.returncode)
    ran = re.search(r"(\d+) inputs ran without a crash", r.stdout)
    if not ran or int(ran.group(1)) != inputs:
        sys.exit(f"FAILED: the harness ran {ran.group(1) if ran else 'no'} inputs of the {inputs} in {', '.join(dirs)}")
    print(f"{inputs} inputs ({fmt})")
