#!/usr/bin/env python3
"""Snake versus global solve: runs every experiment file given (default: the set in
experiments/ablation/global/) once with "solver": "snake" and once with "solver": "global", and
prints a Markdown table of the final total energy and its terms (the same potential for both:
the file's "global" object), the metrics against ground truth, the wall time and the iterations
or evaluations. Also writes OUT/comparison.csv.

    python3 scripts/compare_global.py [--dsnake build/release/experiments/dsnake] [--out out/compare_global] [FILES...]
"""
import argparse
import csv
import glob
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run(dsnake, config, solver, out):
    cmd = [dsnake, "run", config, "--set", "solver=" + solver, "--out", out, "--quiet"]
    subprocess.run(cmd, check=True)
    with open(os.path.join(out, "result.json")) as f:
        return json.load(f)


def fmt(v, digits=3):
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    return f"{v:.{digits}g}" if abs(v) >= 1e3 or abs(v) < 1e-2 else f"{v:.{digits}f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--dsnake", default=os.path.join(ROOT, "build/release/experiments/dsnake"))
    ap.add_argument("--out", default=os.path.join(ROOT, "out/compare_global"))
    ap.add_argument("files", nargs="*")
    args = ap.parse_args()
    files = args.files or sorted(glob.glob(os.path.join(ROOT, "experiments/ablation/global/*.json")))
    rows = []
    for config in files:
        name = os.path.splitext(os.path.basename(config))[0]
        for solver in ("snake", "global"):
            r = run(args.dsnake, config, solver, os.path.join(args.out, name, solver))
            m, e, t = r["metrics"], r.get("energy", {}), r["timings"]
            g = r.get("global", {})
            rows.append({
                "case": name, "solver": solver, "success": r["success"],
                "energy_total": e.get("total"),
                "energy_terms": ", ".join(f"{k} {fmt(v)}" for k, v in e.get("terms", {}).items()),
                "mean_surface_distance": m["mean_surface_distance"], "hausdorff95": m["hausdorff95"],
                "dice": m["dice"], "correspondence_error_max": m["correspondence_error_max"],
                "evolve_s": t["evolve_s"], "total_s": t["total_s"],
                "iterations": r["iterations"],
                "evaluations": g.get("residual_evaluations"),
                "vertices": r["vertices"]["final"],
            })
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "comparison.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    cols = ["case", "solver", "success", "energy_total", "energy_terms", "mean_surface_distance", "hausdorff95",
            "dice", "correspondence_error_max", "evolve_s", "iterations", "evaluations"]
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for r in rows:
        print("| " + " | ".join(fmt(r[c]) if not isinstance(r[c], str) else r[c] for c in cols) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
