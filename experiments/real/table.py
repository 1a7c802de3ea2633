#!/usr/bin/python3
"""Prints a real experiment's sweep results as a Markdown table (experiments/real/run.sh):
per method its start and final Dice and mean surface distance (mm), HD95 (mm), self-intersections,
Euler characteristic of the result (3D), the centroid's shift (mm), iterations and wall time (s).

Usage: table.py OUT_DIR   (the sweep's output folder, holding results.csv and runs/)
"""
import csv
import json
import os
import sys


def fmt(v, digits=3):
    return "-" if v is None else f"{v:.{digits}f}"


def main():
    out = sys.argv[1]
    rows = list(csv.DictReader(open(os.path.join(out, "results.csv"))))
    print("| method | start Dice | Dice | start msd | msd | HD95 | SI | centroid shift | iterations | time (s) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for row in rows:
        path = os.path.join(out, "runs", row["run_id"], "result.json")
        if not os.path.exists(path):
            print(f"| {row['method']} | (not finished) |")
            continue
        r = json.load(open(path))
        m, s = r["metrics"], r.get("start", {}).get("metrics", {})
        shift = r.get("pose", {}).get("centroid_shift")
        print(f"| {row['method']} | {fmt(s.get('dice'))} | {fmt(m['dice'])} | {fmt(s.get('mean_surface_distance'), 2)} | "
              f"{fmt(m['mean_surface_distance'], 2)} | {fmt(m['hausdorff95'], 2)} | {m['self_intersections']} | "
              f"{fmt(shift, 2)} | {r['iterations']} | {r['timings']['total_s']:.1f} |")


if __name__ == "__main__":
    main()
