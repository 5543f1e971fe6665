#!/usr/bin/env python3
"""ctest: a fuzz harness (built without libFuzzer) over its seed corpus, and over the findings
kept under runs/fuzz/findings/<format>/ once fixed: every input runs without a crash."""
import os
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
    r = subprocess.run([harness] + dirs, capture_output=True, text=True)
    print(r.stdout.strip(), r.stderr.strip()[-2000:])
    sys.exit(r.returncode)
