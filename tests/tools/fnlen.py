#!/usr/bin/env python3
"""Lists Rust functions longer than LIMIT lines, outside test modules and tests/.

Usage: fnlen.py LIMIT SRC_DIR [SRC_DIR ...]

A function runs from its `fn` line to the closing brace at the same indentation
(rustfmt's layout). Exit status 1 when one is longer than LIMIT.
"""
import os
import re
import sys

FN = re.compile(
    r'^(\s*)(pub(\([^)]*\))?\s+)?(const\s+)?(async\s+)?(unsafe\s+)?(extern\s+"C"\s+)?fn\s+(\w+)'
)


def long_functions(path, limit):
    lines = open(path, encoding="utf-8").read().split("\n")
    end = len(lines)
    for i, line in enumerate(lines):
        if line.strip() == "#[cfg(test)]" and i + 1 < len(lines) and re.match(r"\s*mod \w+", lines[i + 1]):
            end = i
            break
    for i in range(end):
        m = FN.match(lines[i])
        if not m or lines[i].rstrip().endswith(";"):
            continue
        indent = " " * len(m.group(1))
        for j in range(i + 1, end):
            close = lines[j]
            if close.startswith(indent + "}") and (len(close) == len(indent) + 1 or close[len(indent) + 1] in " ;,)"):
                if j - i + 1 > limit:
                    yield j - i + 1, i + 1, m.group(8)
                break


def main(argv):
    limit, found = int(argv[0]), 0
    for root in argv[1:]:
        for folder, _, files in sorted(os.walk(root)):
            if "/tests" in folder:
                continue
            for name in sorted(files):
                if name.endswith(".rs") and name != "tests.rs":
                    path = os.path.join(folder, name)
                    for lines, at, fn in long_functions(path, limit):
                        print(f"{lines} lines: {path}:{at} {fn}")
                        found += 1
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]) if len(sys.argv) > 2 else (print(__doc__) or 2))
