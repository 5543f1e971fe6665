"""What tools/options_doc.py and tools/layout_doc.py share: a page of docs/ made by a script is
either written or, with --check (ctest), compared with the file committed, the difference printed
and the exit code 1 when it is stale."""
import difflib
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def write_or_check(page, text, source, regenerate, summary):
    """page: path under the repository (docs/NAME.md); source: what it is made from (for the
    diff's header); regenerate: the command that remakes it; summary: one line on what it holds"""
    path = os.path.join(ROOT, page)
    if "--check" in sys.argv:
        with open(path) as f:
            old = f.read()
        if old != text:
            sys.stdout.writelines(difflib.unified_diff(old.splitlines(True), text.splitlines(True), page, source))
            sys.exit(f"{page} is stale: regenerate it with {regenerate}")
        print(f"{page} matches {source}: {summary}")
        return
    with open(path, "w") as f:
        f.write(text)
    print(f"wrote {page}: {summary}")
