#!/usr/bin/python3
"""Writes docs/options.md from msim's own -help: the hand-written explanations of
docs/options.template.md with, in place of its line @OPTION_TABLES@, one table per -help section
of every option msim defines (-msim_*, and the options of its PETSc types: -snes_pd_*, -snes_ntr_*,
-pd_pc_msimllt_*), with the default and the description -help gives.

Which runs: -help lists an object's options only when the object is made, so msim runs once with
its defaults, once per scene and per integrator its -help lists (new ones are picked up), and
once per SNES type msim adds or wires specially under implicit Euler. An option's default is
taken from a run that did not set it. A -msim_*, -snes_pd_*, -snes_ntr_* or -pc_msimllt_* name
written in src/ that no run lists fails the script (a new option needs a run that shows it: add
one to RUNS).

Usage: tools/options_doc.py path/to/msim            rewrites docs/options.md
       tools/options_doc.py path/to/msim --check    exits 1, with the difference, when it is stale"""
import os
import re
import subprocess
import sys

from generated_page import write_or_check

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TEMPLATE = os.path.join(ROOT, "docs", "options.template.md")
# one step of the default scene: -help prints while the objects are set up
QUICK = ["-msim_steps", "1"]
# runs beyond the defaults, the scenes and the integrators: the implicit solvers msim defines or
# wires (their options show once the SNES is of that type)
RUNS = [["-msim_integrator", "implicit_euler", "-snes_type", t] for t in ("newtonls", "pd", "ntr", "qn")] + [
    ["-msim_integrator", "implicit_euler", "-snes_type", "anderson", "-npc_snes_type", "pd"],
    ["-msim_integrator", "implicit_euler", "-msim_self_contact"]]  # the self-contact term's own options
# a file for the scenes that need one
MESH_FILES = {"tet": "examples/meshes/beam.msh", "mesh": "tests/data/meshes/sheet.obj"}
# msim's names, with or without an options prefix (pd_, npc_)
OURS = re.compile(r"^-(?:[a-z]+_)?(?:msim_|snes_pd_|snes_ntr_|pc_msimllt_)")
RULE = "-" * 40
ENV = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1", OPENBLAS_NUM_THREADS="1")


def run_help(msim, args):
    r = subprocess.run([msim, "-help"] + QUICK + args, cwd=ROOT, capture_output=True, text=True, env=ENV)
    if r.returncode:
        sys.exit(f"options_doc.py: msim -help {' '.join(args)} failed ({r.returncode}): {r.stderr.strip()[-500:]}")
    return r.stdout


def parse_line(line):
    """(name, default, description, kind) of one option line of -help, or None. PETSc 3.18 prints
    integers, strings and lists '<now CURRENT : formerly DEFAULT>', reals '<CURRENT : DEFAULT>',
    booleans ': <DEFAULT : CURRENT>', arrays '<CURRENT>' (only the first entry when unset)"""
    m = re.match(r"^\s+(-[A-Za-z0-9_]+)(:?) ?<([^>]*)>:? ?(.*)$", line)
    if not m:
        m = re.match(r"^\s+(-[A-Za-z0-9_]+) (ascii|binary|draw|socket|saws)\S*:? (.*)$", line)
        return (m.group(1), "", "a PetscViewer", "viewer") if m else None
    name, boolean, value, rest = m.groups()
    values = re.match(r"now (.*) : formerly (.*)$", value)
    pair = re.match(r"(.*) : (.*)$", value)
    if values:
        default, kind = values.group(2), "value"
    elif pair and boolean:
        default, kind = pair.group(1).lower(), "bool"
    elif pair:
        default, kind = pair.group(2), "real"
    else:
        default, kind = value, "array"
    return name, default.strip(), describe(rest), kind


def describe(text):
    """-help's description without the man page in parentheses at its end; '(one of) a b c' as
    'one of: a, b, c'"""
    text = re.sub(r"\s*\((?:None|\(null\)|[A-Z][A-Za-z]*|)\)\s*$", "", text.strip())
    m = re.match(r"^(.*?)\s*\((?:choose )?one of\)\s*(.*)$", text)
    if m:
        text = f"{m.group(1)}; one of: {', '.join(m.group(2).split())}" if m.group(1) else "one of: " + ", ".join(m.group(2).split())
    return text


def sections(text):
    """[(section title, [(name, default, description, kind)])] of msim's options in one -help
    output, in order; an option of ours in a PETSc section goes under that section's subheading
    (e.g. 'SNES ntr (...)')"""
    out, title, sub = [], None, None
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line == RULE:
            title, sub = (lines[i + 1].rstrip(":") if i + 1 < len(lines) else None), None
            continue
        if title is None or line.rstrip(":") == title:
            continue
        if re.match(r"^  [A-Za-z]", line):
            sub = line.strip()
            continue
        entry = parse_line(line)
        if not entry or not OURS.match(entry[0]):
            continue
        # a viewer option's forms get a section of their own, after which PETSc goes on with the
        # options of the object that asked for it without a new title
        viewer = re.match(r"Viewer \((-\S+)\) options", title)
        if viewer and viewer.group(1) == entry[0]:
            head = "msim output"
        else:
            head = title if title.lower().startswith("msim") else (sub or title)
        if not out or out[-1][0] != head:
            out.append((head, []))
        same = [k for k, e in enumerate(out[-1][1]) if e[0] == entry[0]]
        if not same:
            out[-1][1].append(entry)
        elif out[-1][1][same[0]][3] == "viewer" and entry[3] != "viewer":
            # a viewer's own description (PetscOptionsViewer's "-NAME <>: text") after its forms
            out[-1][1][same[0]] = (entry[0], "", entry[2], "viewer")
    return out


def collect(msim):
    base = run_help(msim, [])
    lists = {}
    for _, entries in sections(base):
        for name, default, desc, _ in entries:
            m = re.search(r"one of: (.*)$", desc)
            if m:
                lists[name] = [v.strip() for v in m.group(1).split(",")]
    runs = [[]]
    runs += [["-msim_scene", s] + (["-msim_mesh_file", MESH_FILES[s]] if s in MESH_FILES else []) for s in lists.get("-msim_scene", []) if s != "cloth"]
    runs += [["-msim_integrator", i] for i in lists.get("-msim_integrator", []) if i != "symplectic_euler"]
    runs += RUNS
    order, table = [], {}  # section -> [name]; (section, name) -> entry, from a run that did not set it
    for args in runs:
        for head, entries in sections(base if not args else run_help(msim, args)):
            if head not in table:
                order.append(head)
                table[head] = {}
            for e in entries:
                if e[0] not in table[head] or (e[0] in table[head][e[0]][1] and e[0] not in args):
                    table[head][e[0]] = (e, args)
    return [(head, [table[head][n][0] for n in table[head]]) for head in order]


def cell(text):
    return text.replace("|", "\\|")


def render(groups):
    out = []
    for head, entries in groups:
        out += [f"### {head}", "", "| option | default | |", "|---|---|---|"]
        for name, default, desc, kind in entries:
            if kind == "array":
                shown = "see above"
            elif kind == "viewer":
                shown = "not set"
            else:
                shown = f"`{default}`" if default else "not set"
            out.append(f"| `{name}` | {cell(shown)} | {cell(desc)} |")
        out.append("")
    return "\n".join(out).rstrip("\n")


def written_names():
    """msim's option names written out in src/ ("-msim_dt", ...; a name built at run time, such
    as "-msim_stiffness_" plus a family, ends in _ and is left out)"""
    names = set()
    for d, _, files in os.walk(os.path.join(ROOT, "src")):
        for f in files:
            if f.endswith((".cpp", ".h", ".hpp")):
                with open(os.path.join(d, f), errors="replace") as fh:
                    names |= set(re.findall(r'"(-(?:msim|snes_pd|snes_ntr|pc_msimllt)_[a-z0-9_]*[a-z0-9])', fh.read()))
    return names


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    msim = os.path.abspath(sys.argv[1])
    groups = collect(msim)
    listed = {re.sub(r"^-(?:pd_|npc_)", "-", n) for _, entries in groups for n, *_ in entries}
    missing = sorted(n for n in written_names() if n not in listed)
    if missing:
        sys.exit(f"options_doc.py: {', '.join(missing)} written in src/ but listed by no -help run: add a run that shows them to RUNS")
    with open(TEMPLATE) as f:
        template = f.read()
    if template.count("@OPTION_TABLES@") != 1:
        sys.exit(f"options_doc.py: {TEMPLATE} must hold the line @OPTION_TABLES@ once")
    text = template.replace("@OPTION_TABLES@", render(groups))
    write_or_check("docs/options.md", text, "-help", "/usr/bin/python3 tools/options_doc.py build/msim",
                   f"{len(listed)} options in {len(groups)} sections")

if __name__ == "__main__":
    main()
