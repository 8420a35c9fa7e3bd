#!/usr/bin/env python3
"""The length of every Rust function in the given files: lines from the `fn` line to its closing
brace (nested functions counted on their own as well), longest first, as `LINES FILE:NAME`.

Usage: scripts/fn_lengths.py [--min N] FILE...
  e.g. scripts/fn_lengths.py --min 60 read/src/*.rs gaps/src/*.rs

A text scan, not a parser: braces inside string and character literals and `//` comments are
skipped; a declaration without a body (a trait method) is not listed.
"""
import re
import sys

FN = re.compile(r"^\s*(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?fn\s+([A-Za-z_0-9]+)")


def code(line):
    """The line without its comment and with string and character literals emptied."""
    line = re.sub(r'"(\\.|[^"\\])*"', '""', line)
    line = re.sub(r"'(\\.|[^'\\])'", "''", line)
    return re.sub(r"//.*", "", line)


def lengths(path):
    lines = open(path, encoding="utf-8").read().split("\n")
    for i, line in enumerate(lines):
        m = FN.match(line)
        if not m:
            continue
        depth, parens, body = 0, 0, False
        for j in range(i, len(lines)):
            for c in code(lines[j]):
                if c == "{":
                    depth, body = depth + 1, True
                elif c == "}":
                    depth -= 1
                elif c in "([":
                    parens += 1
                elif c in ")]":
                    parens -= 1
                elif c == ";" and not body and parens == 0:
                    break  # no body
            else:
                if body and depth == 0:
                    yield j - i + 1, f"{path}:{m.group(6)}"
                    break
                continue
            break


def main(argv):
    least = 0
    if argv[:1] == ["--min"]:
        least, argv = int(argv[1]), argv[2:]
    if not argv:
        sys.exit(__doc__)
    found = [r for p in argv for r in lengths(p) if r[0] >= least]
    for n, where in sorted(found, reverse=True):
        print(f"{n:5d} {where}")


if __name__ == "__main__":
    main(sys.argv[1:])
