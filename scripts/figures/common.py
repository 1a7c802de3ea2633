"""Shared readers of dsnake's files for the figure scripts and the report (scripts/report): CSV
tables and our legacy-VTK meshes. Run the scripts with /usr/bin/python3 (Debian's
python3-matplotlib)."""
import csv
import os
import sys


class InputError(Exception):
    """Missing or malformed input; the message names the file."""


def read_csv_records(path):
    """(header, [(row number, fields), ...]) of a CSV file, blank lines left out (the header is
    row 1); InputError naming the file when it cannot be read, is not CSV or has no header."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            records = list(csv.reader(f))
    except OSError as e:
        raise InputError(f"{path}: cannot be read: {e.strerror}") from None
    except (csv.Error, UnicodeDecodeError) as e:
        raise InputError(f"{path}: not CSV ({e})") from None
    if not records:
        raise InputError(f"{path}: empty: no header")
    return [h.strip() for h in records[0]], [(n, r) for n, r in enumerate(records[1:], start=2) if r]


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
    """(points, cells) of a legacy ASCII POLYDATA file as lists: triangles, or line segments."""
    mesh = read_polydata(path)
    cells = mesh.get("triangles", mesh.get("segments"))
    return mesh["points"].tolist(), cells.tolist()


def _vtk_numbers(tokens, start, count, path, what, kind=float):
    if start + count > len(tokens):
        raise InputError(f"{path}: {what}: the file ends after {len(tokens) - start} of {count} values")
    import numpy as np
    try:
        values = np.array(tokens[start:start + count], dtype=np.float64)
    except ValueError:
        raise InputError(f"{path}: {what}: a value is not a number") from None
    if not np.all(np.isfinite(values)):
        raise InputError(f"{path}: {what}: a value is not finite")
    if kind is int:
        if np.any(values != np.round(values)) or np.any(values < 0):
            raise InputError(f"{path}: {what}: an index is not a non-negative integer")
        return values.astype(np.int64)
    return values


def _vtk_cells(numbers, path, keyword):
    """The cells of a POLYGONS or LINES list (each: count, then indices) as a list of lists."""
    cells, i = [], 0
    while i < len(numbers):
        k = int(numbers[i])
        if k < 1 or i + 1 + k > len(numbers):
            raise InputError(f"{path}: {keyword}: a cell's vertex count does not match the list's size")
        cells.append(numbers[i + 1:i + 1 + k].tolist())
        i += 1 + k
    return cells


def _vtk_point_arrays(tokens, i, n, path):
    """The POINT_DATA arrays (SCALARS with their LOOKUP_TABLE line, VECTORS, NORMALS) from token i."""
    arrays = {}
    while i < len(tokens):
        keyword = tokens[i].upper()
        if keyword == "SCALARS":
            name = tokens[i + 1] if i + 2 < len(tokens) else "?"
            components, i = 1, i + 3
            if i < len(tokens) and tokens[i].isdigit():
                components, i = int(tokens[i]), i + 1
            if i + 1 < len(tokens) and tokens[i].upper() == "LOOKUP_TABLE":
                i += 2
            arrays[name] = _vtk_numbers(tokens, i, n * components, path, f"SCALARS {name}")
            i += n * components
        elif keyword in ("VECTORS", "NORMALS"):
            name = tokens[i + 1] if i + 1 < len(tokens) else "?"
            arrays[name] = _vtk_numbers(tokens, i + 3, 3 * n, path, f"{keyword} {name}").reshape(n, 3)
            i += 3 + 3 * n
        elif keyword == "CELL_DATA":
            break  # the report uses point data only
        else:
            raise InputError(f"{path}: unexpected '{tokens[i]}' in POINT_DATA")
    return arrays


def read_polydata(path):
    """A legacy ASCII POLYDATA file: {"points": (n, 3), "triangles" or "segments": (m, 3 or 2)
    vertex indices, "arrays": {name: per-point values}}. Polygons are split into fans, polylines
    into segments."""
    try:
        with open(path, encoding="ascii") as f:
            lines = f.read().split("\n", 3)
    except (OSError, UnicodeDecodeError) as e:
        raise InputError(f"{path}: cannot be read: {getattr(e, 'strerror', None) or e}") from None
    if len(lines) < 4 or not lines[0].startswith("# vtk DataFile") or lines[2].strip().upper() != "ASCII":
        raise InputError(f"{path}: not a legacy ASCII VTK file")
    tokens = lines[3].split()
    if tokens[:2] != ["DATASET", "POLYDATA"]:
        raise InputError(f"{path}: not a POLYDATA data set")
    mesh, i = {"points": None, "polygons": [], "lines": [], "arrays": {}}, 2
    while i < len(tokens):
        keyword = tokens[i].upper()
        if keyword == "POINTS" and i + 2 < len(tokens) and tokens[i + 1].isdigit():
            n = int(tokens[i + 1])
            mesh["points"] = _vtk_numbers(tokens, i + 3, 3 * n, path, "POINTS").reshape(n, 3)
            i += 3 + 3 * n
        elif keyword in ("POLYGONS", "LINES", "VERTICES", "TRIANGLE_STRIPS") and i + 2 < len(tokens):
            size = int(tokens[i + 2]) if tokens[i + 2].isdigit() else -1
            numbers = _vtk_numbers(tokens, i + 3, max(size, 0), path, keyword, int)
            if keyword in ("POLYGONS", "LINES"):
                mesh[keyword.lower()] += _vtk_cells(numbers, path, keyword)
            i += 3 + max(size, 0)
        elif keyword == "POINT_DATA" and mesh["points"] is not None:
            count = tokens[i + 1] if i + 1 < len(tokens) else ""
            if count != str(len(mesh["points"])):
                raise InputError(f"{path}: POINT_DATA {count}: expected the point count, {len(mesh['points'])}")
            mesh["arrays"] = _vtk_point_arrays(tokens, i + 2, len(mesh["points"]), path)
            break
        else:
            raise InputError(f"{path}: unexpected '{tokens[i]}'")
    if mesh["points"] is None:
        raise InputError(f"{path}: no POINTS")
    return _vtk_connectivity(mesh, path)


def _vtk_connectivity(mesh, path):
    import numpy as np
    n = len(mesh["points"])
    if mesh["polygons"]:
        cells = [(c[0], c[k], c[k + 1]) for c in mesh["polygons"] for k in range(1, len(c) - 1)]
        out = {"points": mesh["points"], "triangles": np.array(cells, dtype=np.int64).reshape(-1, 3)}
    else:
        cells = [(c[k], c[k + 1]) for c in mesh["lines"] for k in range(len(c) - 1)]
        out = {"points": mesh["points"], "segments": np.array(cells, dtype=np.int64).reshape(-1, 2)}
    connectivity = out.get("triangles", out.get("segments"))
    if len(connectivity) == 0:
        raise InputError(f"{path}: no POLYGONS or LINES")
    if connectivity.max() >= n:
        raise InputError(f"{path}: a cell names vertex {int(connectivity.max())} of {n}")
    out["arrays"] = mesh["arrays"]
    return out
