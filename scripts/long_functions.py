#!/usr/bin/env python3
"""Lists the functions longer than a limit (default 80 lines) in the project's C++ sources.

A function is a brace block at namespace or class level whose opening line looks like a
signature (has a '(' before the '{'); lambdas and blocks inside a function count towards it.
Usage: scripts/long_functions.py [--limit N] [PATH ...]   (default: the source folders)
Exit code 1 if any is found, so that a check can use it.
"""
import argparse
import pathlib
import re
import sys

FOLDERS = ["framework", "energies", "fields", "remesh", "registration", "experiments", "docs/examples"]


def strip(text):
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"/\*.*?\*/", lambda m: "\n" * m.group(0).count("\n"), text, flags=re.S)
    text = re.sub(r'R"\((.*?)\)"', lambda m: '""' + "\n" * m.group(0).count("\n"), text, flags=re.S)
    text = re.sub(r'"(\\.|[^"\\\n])*"', '""', text)
    text = re.sub(r"'(\\.|[^'\\\n])'", "''", text)
    return text


def functions(path):
    text = strip(path.read_text(errors="replace"))
    depth, start, head, kinds = 0, 0, "", []
    line = 1
    last_stmt = 0
    for i, c in enumerate(text):
        if c == "\n":
            line += 1
        elif c == "{":
            header = text[last_stmt:i]
            is_function = "(" in header and not re.search(r"\b(namespace|struct|class|enum|union)\b[^(]*$", header) \
                and not re.search(r"=\s*$", header.strip()) and not header.strip().endswith(("]", "="))
            scope_fn = any(k == "function" for k in kinds)
            kinds.append("function" if is_function and not scope_fn else "block")
            if kinds[-1] == "function":
                start, head = line, " ".join(header.split())[-90:]
            depth += 1
            last_stmt = i + 1
        elif c == "}":
            depth -= 1
            kind = kinds.pop() if kinds else "block"
            if kind == "function":
                yield head, start, line
            last_stmt = i + 1
        elif c == ";":
            last_stmt = i + 1


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--limit", type=int, default=80)
    ap.add_argument("paths", nargs="*")
    args = ap.parse_args()
    root = pathlib.Path(__file__).resolve().parent.parent
    paths = [pathlib.Path(p) for p in args.paths] or [f for d in FOLDERS for f in sorted((root / d).rglob("*")) if f.suffix in (".cpp", ".h")]
    found = 0
    for path in paths:
        for head, a, b in functions(path):
            if b - a + 1 > args.limit:
                found += 1
                print(f"{path.relative_to(root) if path.is_absolute() else path}:{a}: {b - a + 1} lines: {head}")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
