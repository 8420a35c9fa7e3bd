#!/usr/bin/env python3
"""Compares two `aerosid gaps` report.json documents (or two folders of them): the same structure,
the same words, and every number equal within a relative tolerance — the check that a change
meant to make the analysis faster did not change what it concludes.

    compare_reports.py BEFORE AFTER [--rtol 1e-6] [--atol 1e-12]

BEFORE/AFTER are report.json files or folders holding `*/report.json` (matched by sub-folder
name). Numbers inside strings (verdicts print rounded values) are compared with the tolerance of
their printed digits. Prints the largest relative difference per report and every mismatch;
exit status 1 if any report differs beyond the tolerance.
"""
import argparse
import json
import math
import re
import sys
from pathlib import Path

NUM = re.compile(r"[-+]?(?:\d+\.\d*|\.\d+|\d+)(?:[eE][-+]?\d+)?")


def rel(a, b, atol):
    if a == b or (isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b)):
        return 0.0
    return abs(a - b) / max(abs(a), abs(b), atol)


def compare(a, b, path, rtol, atol, out):
    """Appends mismatches to out; returns the largest relative difference of the numbers."""
    worst = 0.0
    if isinstance(a, dict) and isinstance(b, dict):
        if a.keys() != b.keys():
            out.append(f"{path}: keys {sorted(set(a) ^ set(b))} differ")
        for k in a.keys() & b.keys():
            worst = max(worst, compare(a[k], b[k], f"{path}.{k}", rtol, atol, out))
    elif isinstance(a, list) and isinstance(b, list):
        if len(a) != len(b):
            out.append(f"{path}: length {len(a)} vs {len(b)}")
        for i, (x, y) in enumerate(zip(a, b)):
            worst = max(worst, compare(x, y, f"{path}[{i}]", rtol, atol, out))
    elif isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(a, bool):
        d = rel(float(a), float(b), atol)
        if d > rtol:
            out.append(f"{path}: {a!r} vs {b!r} (relative {d:.2e})")
        worst = d
    elif isinstance(a, str) and isinstance(b, str):
        if NUM.sub("#", a) != NUM.sub("#", b):
            out.append(f"{path}: text differs:\n    {a}\n    {b}")
        else:
            for x, y in zip(NUM.findall(a), NUM.findall(b)):
                if x == y:
                    continue
                # A printed number is rounded: allow one unit of its last digit, or rtol.
                digits = len(x.split(".")[1].split("e")[0].split("E")[0]) if "." in x else 0
                ulp = 10.0 ** -digits
                if "e" in x.lower():
                    ulp *= 10.0 ** int(x.lower().split("e")[1])
                if abs(float(x) - float(y)) > max(ulp * 1.01, rtol * abs(float(x))):
                    out.append(f"{path}: number in text {x} vs {y}")
    elif a != b:
        out.append(f"{path}: {a!r} vs {b!r}")
    return worst


def pairs(before, after):
    if before.is_file():
        return [(before.parent.name, before, after)]
    return [
        (p.parent.name, p, after / p.parent.name / "report.json")
        for p in sorted(before.glob("*/report.json"))
    ]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("before", type=Path)
    ap.add_argument("after", type=Path)
    ap.add_argument("--rtol", type=float, default=1e-6)
    ap.add_argument("--atol", type=float, default=1e-12)
    args = ap.parse_args()
    bad = False
    for name, b, a in pairs(args.before, args.after):
        if not a.exists():
            print(f"{name}: missing {a}")
            bad = True
            continue
        out = []
        worst = compare(json.loads(b.read_text()), json.loads(a.read_text()), "", args.rtol, args.atol, out)
        print(f"{name:<20} largest relative difference {worst:.1e}  {'OK' if not out else f'{len(out)} MISMATCHES'}")
        for line in out[:20]:
            print("   ", line)
        bad |= bool(out)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
