#!/usr/bin/env python3
"""Architecture figures of msim's C++ (issue 32), at a git revision or in the working tree:
- option reads: for each -msim_ option, how many places in src/ read it (calls of PetscOptions*,
  MSimOptions* whose first string argument names it), and which are read in more than one place;
- the longest functions in src/ (lines from the signature to the closing brace), found by matching
  braces after comments and string literals are blanked.
Usage: python3 tools/code_metrics.py [REV] [--top N]   (no REV: the working tree)"""
import argparse
import collections
import os
import re
import subprocess

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SOURCE = (".cpp", ".cc", ".c", ".hpp", ".h")


def files(rev):
    """{path: text} of src/ at rev (None: the working tree)"""
    if rev is None:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard", "src"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
        paths = [p for p in out.split() if p.endswith(SOURCE) and os.path.exists(os.path.join(ROOT, p))]
        return {p: open(os.path.join(ROOT, p), errors="replace").read() for p in paths}
    out = subprocess.run(["git", "ls-tree", "-r", "--name-only", rev, "src"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
    return {p: subprocess.run(["git", "show", f"{rev}:{p}"], cwd=ROOT, capture_output=True, text=True, check=True).stdout
            for p in out.split() if p.endswith(SOURCE)}


def blank(text):
    """comments and the insides of string and character literals replaced by spaces (newlines kept)"""
    out, i, n = [], 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            out.append(" " * (j - i))
            i = j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:j]))
            i = j
        elif c in "\"'":
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + " " * (min(j, n) - i - 1) + (c if j < n else ""))
            i = j + 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


OPTION_CALL = re.compile(r"\b((?:PetscOptions|MSimOptions)\w*)\s*\(([^;]*?)\"(-msim_\w+)\"", re.S)


def option_reads(sources):
    """{option: [path:line, ...]} of the places that read each -msim_ option"""
    reads = collections.defaultdict(list)
    for path, text in sources.items():
        for m in OPTION_CALL.finditer(text):
            if '"' in m.group(2):  # the option is not the call's first string argument
                continue
            reads[m.group(3)].append(f"{path}:{text.count(chr(10), 0, m.start()) + 1}")
    return reads


NOT_FUNCTION = re.compile(r"(\b(struct|class|union|enum|namespace|extern)\b[^;{}]*|=\s*)$")


def functions(sources):
    """[(lines, path:line, name)] of every function body at file scope (and in namespaces)"""
    found = []
    for path, text in sources.items():
        code = blank(text)
        depth, scopes, start = 0, [], None
        for i, c in enumerate(code):
            if c == "{":
                head = code[max(0, code.rfind("}", 0, i), code.rfind(";", 0, i), code.rfind("{", 0, i)) + 1:i].strip()
                if start is None and depth == len(scopes) and not NOT_FUNCTION.search(head) and head.endswith((")", "const", "override", "noexcept")):
                    name = re.findall(r"([~\w:]+)\s*\(", head)
                    sig = code.rfind("\n", 0, code.find(head, max(0, i - len(head) - 200))) + 1
                    start = (depth, sig, name[0] if name else "?")
                elif start is None and depth == len(scopes) and re.search(r"\b(namespace|extern)\b", head):
                    scopes.append(depth)
                depth += 1
            elif c == "}":
                depth -= 1
                if start and depth == start[0]:
                    first = code.count("\n", 0, start[1]) + 1
                    last = code.count("\n", 0, i) + 1
                    found.append((last - first + 1, f"{path}:{first}", start[2]))
                    start = None
                elif scopes and depth == scopes[-1]:
                    scopes.pop()
    return sorted(found, reverse=True)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("rev", nargs="?", default=None, help="a git revision (default: the working tree)")
    p.add_argument("--top", type=int, default=5)
    a = p.parse_args()
    sources = files(a.rev)
    reads = option_reads(sources)
    multi = {k: v for k, v in reads.items() if len(v) > 1}
    fns = functions(sources)
    print(f"revision: {a.rev or 'working tree'} ({len(sources)} files in src/)")
    print(f"-msim_ options read: {len(reads)}; places reading them: {sum(len(v) for v in reads.values())}; "
          f"reads per option: mean {sum(len(v) for v in reads.values()) / max(1, len(reads)):.2f}, max {max((len(v) for v in reads.values()), default=0)}; "
          f"read in more than one place: {len(multi)}")
    for k in sorted(multi, key=lambda k: (-len(multi[k]), k)):
        print(f"  {k}: {len(multi[k])} ({', '.join(multi[k])})")
    print(f"functions: {len(fns)}; longest:")
    for n, where, name in fns[:a.top]:
        print(f"  {n:5d} lines  {name}  {where}")


if __name__ == "__main__":
    main()
