#!/usr/bin/env python3
"""Tolerant numeric diff: files must have the same lines and tokens; integer tokens must be
equal, real tokens must agree within |a - b| <= atol + rtol * max(|a|, |b|); other tokens exactly.
Usage: numdiff.py EXPECTED ACTUAL [--rtol R] [--atol A]. Prints the first differences, exits 1."""
import argparse
import re
import sys

INT = re.compile(r"^[+-]?\d+$")
REAL = re.compile(r"^[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?$|^[+-]?(nan|inf)$", re.I)


def tokens(line):
    return re.split(r"[\s,]+", line.strip())


def compare(expected, actual, rtol, atol):
    problems = []
    if len(expected) != len(actual):
        problems.append(f"line count differs: expected {len(expected)}, got {len(actual)}")
    for n, (le, la) in enumerate(zip(expected, actual), 1):
        te, ta = tokens(le), tokens(la)
        if len(te) != len(ta):
            problems.append(f"line {n}: token count differs\n  expected: {le.rstrip()}\n  actual:   {la.rstrip()}")
            continue
        for a, b in zip(te, ta):
            if INT.match(a) and INT.match(b):
                ok = int(a) == int(b)
            elif REAL.match(a) and REAL.match(b):
                x, y = float(a), float(b)
                ok = abs(x - y) <= atol + rtol * max(abs(x), abs(y))
            else:
                ok = a == b
            if not ok:
                problems.append(f"line {n}: '{a}' vs '{b}'\n  expected: {le.rstrip()}\n  actual:   {la.rstrip()}")
                break
    return problems


def main():
    p = argparse.ArgumentParser()
    p.add_argument("expected")
    p.add_argument("actual")
    p.add_argument("--rtol", type=float, default=1e-6)
    p.add_argument("--atol", type=float, default=1e-9)
    a = p.parse_args()
    with open(a.expected) as f:
        e = f.readlines()
    with open(a.actual) as f:
        x = f.readlines()
    problems = compare(e, x, a.rtol, a.atol)
    for msg in problems[:10]:
        print(msg)
    sys.exit(1 if problems else 0)


if __name__ == "__main__":
    main()
