#!/usr/bin/python3
"""Writes docs/layout.md from the tree: every directory of the repository with what its README
says it is (its title) or, without one, what DIRS below says, and in it every source file,
script, build file and example with the first sentence of its top comment (a .cpp without one:
its header's). Data (meshes, CSV, pictures, expected outputs) is not listed file by file.
The files are git's (tracked and present) inside a git checkout, else every file on disk outside
build directories.

Usage: tools/layout_doc.py            rewrites docs/layout.md
       tools/layout_doc.py --check    exits 1, with the difference, when it is stale"""
import os
import re
import subprocess
import sys

from generated_page import write_or_check

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
# directories with no README of their own
DIRS = {
    ".": "msim: the build (CMakeLists.txt), the README, the licence",
    ".ci": "continuous integration: one script a clean Debian 12 machine runs",
    "include": "headers (msim/)",
    "docs": "reference pages: every option, this layout",
    "examples": "options files, one per method or scene, each with its purpose and run line",
    "include/msim": "the public headers: one per layer, plus the kernels, exchanges and sweeps the layers share",
    "runs/fuzz/findings": "inputs the fuzzers found that once crashed a reader, kept as regression seeds (one folder per harness)",
    "runs/quickstart": "the README's pictures and the scripts that draw them",
    "runs/tools": "what the studies share: running msim, reading its series, drawing them",
    "src": "the library every program and test links (msimcore), one folder per layer",
    "src/app": "the msim program",
    "src/implicit": "the implicit problem: Phi, its gradient and Hessian, PD's local and global steps, inertia correction",
    "src/implicit/schemes": "time schemes of the implicit problem, one file each: y, beta, the first iterate and the velocity update",
    "src/implicit/terms": "energy terms of the implicit problem, one file each: energy, gradient, Hessian blocks, PD projection",
    "src/integrators": "the integrator registry and the time loop",
    "src/integrators/impls": "one file per integrator type",
    "src/mesh": "mesh files in, validated, unique edges, TetGen",
    "src/output": "series (.vtu and HDF5), monitors, checkpoints, progress lines",
    "src/partition/impls": "one file per partitioner type",
    "src/partition": "partitions of the distributed vertex graph",
    "src/scene": "scene generators and the options every scene shares; distribution and refinement",
    "src/solvers": "msim's SNES types (pd, ntr), its PC (msimllt) and Newton's energy line search",
    "src/spectrum": "SLEPc spectra",
    "src/springs": "the distributed spring system: Vecs, ghost exchange, forces, energy, matrices",
    "src/util": "options, errors, signals, MPI and malloc settings",
    "tests/data": "test inputs",
    "tests/data/bad": "the malformed corpus: mesh files and options files each msim must refuse with one line",
    "tests/data/meshes": "valid meshes in every format msim reads",
    "tests/expected": "the expected output of every example (run_example.py; tests/regen_expected.sh remakes them)",
    "tests/unit": "C++ tests through the library",
    "tools": "build, install, test and documentation scripts",
}
# below these, only directories and scripts are listed (their other files are data)
DATA = ("tests/data", "tests/expected", "runs/fuzz/findings", "examples/meshes", "runs/quickstart")
CODE = (".cpp", ".h", ".hpp", ".py", ".sh")


def files():
    try:
        out = subprocess.run(["git", "ls-files", "-z"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
        names = [n for n in out.split("\0") if n and os.path.isfile(os.path.join(ROOT, n))]
    except (OSError, subprocess.CalledProcessError):
        names = []
        for d, subdirs, fs in os.walk(ROOT):
            # what .gitignore keeps out: build directories, /out/, /.devpkg/, __pycache__
            subdirs[:] = [s for s in subdirs if not (s.startswith("build") or s in (".git", "__pycache__")
                                                     or (d == ROOT and s in ("out", ".devpkg")))]
            names += [os.path.relpath(os.path.join(d, f), ROOT) for f in fs if not f.endswith(".tmp")]
    return sorted(n.replace(os.sep, "/") for n in names)


def listed(name):
    """a file this page names: code, a build file, an example, a script without an extension"""
    d, base = os.path.split(name)
    if base.endswith(CODE) or base == "CMakeLists.txt":
        return True
    if d == "examples" and base.endswith(".opts"):
        return True
    if "." not in base and not d.startswith(DATA):
        with open(os.path.join(ROOT, name), "rb") as f:
            return f.read(2) == b"#!"
    return False


def first_sentence(text):
    text = " ".join(text.split())
    # a sentence ends at . ! or ? before a word that does not go on in lower case or with a number
    # ("Liu et al. 2013", "solid ... facet" go on)
    m = re.match(r"^(.+?[.!?])(?:\s+(?=[^a-z0-9])|$)", text)
    s = m.group(1) if m else text
    if len(s) > 140:
        s = s[:137].rsplit(" ", 1)[0] + " ..."
    return s


def top_comment(name):
    """the first sentence of a file's top comment: /* */ in C and C++, the module docstring in
    Python, the first # lines after the shebang in shell, CMake and options files"""
    with open(os.path.join(ROOT, name), errors="replace") as f:
        text = f.read(6000)
    if name.endswith((".cpp", ".h", ".hpp")):
        m = re.match(r"\s*/\*(.*?)\*/", text, re.S)
        if not m:
            m = re.match(r"\s*((?://[^\n]*\n)+)", text)
            return first_sentence(re.sub(r"^\s*//", "", m.group(1), flags=re.M)) if m else ""
        return first_sentence(m.group(1))
    if name.endswith(".py"):
        m = re.match(r'(?:#[^\n]*\n|\s)*(?:"""|\'\'\')(.*?)(?:"""|\'\'\')', text, re.S)
        return first_sentence(m.group(1)) if m else ""
    lines = text.splitlines()
    if lines and lines[0].startswith("#!"):
        lines = lines[1:]
    comment = []
    for line in lines:
        if not line.startswith("#"):
            break
        comment.append(line.lstrip("#"))
    return first_sentence(" ".join(comment)) if comment else ""


def describe_dir(d):
    readme = os.path.join(ROOT, d, "README.md")
    if os.path.exists(readme):
        with open(readme) as f:
            for line in f:
                if line.startswith("# "):
                    return line[2:].strip()
    return DIRS.get(d)


def render():
    names = files()
    dirs = sorted({os.path.dirname(n) or "." for n in names} | {"."})
    # every ancestor of a directory is listed too
    for d in list(dirs):
        while "/" in d:
            d = d.rsplit("/", 1)[0]
            if d not in dirs:
                dirs.append(d)
    dirs = sorted(set(dirs), key=lambda d: (d != ".", d.split("/")))
    # a folder inside data with nothing to describe (runs/fuzz/findings/gmsh) is its parent's data
    dirs = [d for d in dirs if describe_dir(d) or not any(d.startswith(r + "/") for r in DATA)
            or any(os.path.dirname(n) == d and listed(n) for n in names)]
    missing = [d for d in dirs if not describe_dir(d)]
    if missing:
        sys.exit(f"layout_doc.py: no README.md and no entry in DIRS for {', '.join(missing)}: give each a line")
    out = ["# Source layout", "",
           "Every directory, and in it every source file, script, build file and example with the first",
           "sentence of its top comment. Generated from the tree by `tools/layout_doc.py` (the ctest",
           "`layout_doc` fails when this page is stale: regenerate with `/usr/bin/python3 tools/layout_doc.py`).", ""]
    for d in dirs:
        shown = "(top)" if d == "." else d + "/"
        out.append(f"- **`{shown}`** {describe_dir(d)}")
        for n in names:
            if (os.path.dirname(n) or ".") != d or not listed(n):
                continue
            text = top_comment(n)
            if not text and n.endswith(".cpp") and os.path.exists(os.path.join(ROOT, n[:-4] + ".h")):
                text = top_comment(n[:-4] + ".h")
            out.append(f"  - `{os.path.basename(n)}`" + (f": {text}" if text else ""))
    return "\n".join(out) + "\n"


def main():
    text = render()
    write_or_check("docs/layout.md", text, "the tree", "/usr/bin/python3 tools/layout_doc.py", f"{text.count(chr(10))} lines")

if __name__ == "__main__":
    main()
