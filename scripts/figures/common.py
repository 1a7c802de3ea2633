"""Shared readers for the figure scripts: CSV tables and our legacy-VTK meshes. Run the scripts
with /usr/bin/python3 (Debian's python3-matplotlib)."""
import csv
import os
import sys


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def read_table(directory, name, allow_empty=False):
    """The rows of directory/name; exits with one line naming the file if it is missing (or empty,
    unless allow_empty)."""
    path = os.path.join(directory, name)
    try:
        rows = read_csv(path)
    except OSError as e:
        sys.exit(f"{path}: {e.strerror}")
    if not rows and not allow_empty:
        sys.exit(f"{path}: no rows")
    return rows


def number(text):
    try:
        return float(text)
    except (TypeError, ValueError):
        return float("nan")


def read_vtk(path):
    """Points and polygons (or lines) of a legacy ASCII POLYDATA file written by dsnake."""
    with open(path) as f:
        tokens = f.read().split()
    points, cells = [], []
    i = 0
    while i < len(tokens):
        t = tokens[i]
        if t == "POINTS":
            n = int(tokens[i + 1])
            values = [float(v) for v in tokens[i + 3:i + 3 + 3 * n]]
            points = [values[3 * k:3 * k + 3] for k in range(n)]
            i += 3 + 3 * n
        elif t in ("POLYGONS", "LINES"):
            n, size = int(tokens[i + 1]), int(tokens[i + 2])
            values = [int(v) for v in tokens[i + 3:i + 3 + size]]
            j = 0
            for _ in range(n):
                m = values[j]
                cells.append(values[j + 1:j + 1 + m])
                j += 1 + m
            i += 3 + size
        else:
            i += 1
    return points, cells
