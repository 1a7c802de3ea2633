#!/usr/bin/python3
"""Colour-coded correspondence (the paper's Fig. 20): the template (the snake's start) and the
result side by side, every template vertex drawn in the same colour in both (a colour per
template id), with landmarks labelled; from a run folder's correspondence.csv and its
initial.vtk / final.vtk. 2D contours or 3D meshes (3D: the vertices over the mesh's edges).

    /usr/bin/python3 scripts/figures/correspondence.py RUN_DIR [--out RUN_DIR/correspondence.png]

Prints the number of template vertices drawn and the largest correspondence error.
"""
import argparse
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import number, read_table, read_vtk  # noqa: E402


def edges(cells):
    seen = set()
    for c in cells:
        for k in range(len(c)):
            a, b = c[k], c[(k + 1) % len(c)]
            if len(c) == 2 and k == 1:
                break
            seen.add((min(a, b), max(a, b)))
    return sorted(seen)


def run_name(run_dir):
    """The run's own name (result.json's "name"), else its folder's."""
    try:
        with open(os.path.join(run_dir, "result.json")) as f:
            return json.load(f)["name"]
    except (OSError, ValueError, KeyError, TypeError):
        return os.path.basename(os.path.normpath(os.path.abspath(run_dir)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--out")
    args = ap.parse_args()
    rows = read_table(args.run_dir, "correspondence.csv")
    dim = 3 if "initial_z" in rows[0] else 2
    axes_names = ["x", "y", "z"][:dim]
    initial = [[number(r["initial_" + a]) for a in axes_names] for r in rows]
    final = [[number(r["final_" + a]) for a in axes_names] for r in rows]
    ids = [int(r["template_id"]) for r in rows]
    n = len(rows)
    cmap = plt.get_cmap("hsv")
    colours = [cmap(i / max(1, n)) for i in ids]
    meshes = []
    for name in ("initial.vtk", "final.vtk"):
        path = os.path.join(args.run_dir, name)
        meshes.append(read_vtk(path) if os.path.exists(path) else ([], []))
    fig = plt.figure(figsize=(10, 4.8))
    for k, (title, pts, (mesh_points, cells)) in enumerate(
            [("template (start)", initial, meshes[0]), ("result", final, meshes[1])]):
        ax = fig.add_subplot(1, 2, k + 1, projection="3d" if dim == 3 else None)
        for a, b in edges(cells):
            p, q = mesh_points[a], mesh_points[b]
            if dim == 3:
                ax.plot([p[0], q[0]], [p[1], q[1]], [p[2], q[2]], color="0.75", linewidth=0.4)
            else:
                ax.plot([p[0], q[0]], [p[1], q[1]], color="0.6", linewidth=0.8)
        coords = list(zip(*pts))
        if dim == 3:
            ax.scatter(*coords, c=colours, s=18, depthshade=False)
        else:
            ax.scatter(*coords, c=colours, s=22, zorder=3)
            ax.set_aspect("equal")
            ax.invert_yaxis()  # image rows grow downwards, as in the overlay figures
        for r, p in zip(rows, pts):
            if r.get("landmark"):
                ax.text(*p, r["landmark"], fontsize=7)
        ax.set_title(title)
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        if dim == 3:
            ax.set_zlabel("z (mm)")
    errors = [number(r["error"]) for r in rows]
    finite = [e for e in errors if not math.isnan(e)]
    name = run_name(args.run_dir)
    suptitle = (f"{name} — correspondence: one colour per template vertex"
                + (f" (max error {max(finite):.2f} mm)" if finite else ""))
    fig.suptitle(suptitle)
    fig.tight_layout()
    out = args.out or os.path.join(args.run_dir, "correspondence.png")
    fig.savefig(out, dpi=110, metadata={"Title": suptitle})
    print(f"{n} template vertices; max error {max(finite) if finite else float('nan'):.4g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
