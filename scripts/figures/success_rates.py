#!/usr/bin/python3
"""Success-rate curves of a sweep (Figs. 15-18 as curves): one panel per corruption
type, one line per method (and grid point), success rate over the seeds against the corruption
magnitude, from DIR/breakdown.csv written by `dsnake sweep`. Dashed lines mark the 80% pass and
20% fail levels; a cross marks each curve's breakdown level (success below 50%).

    /usr/bin/python3 scripts/figures/success_rates.py SWEEP_DIR [--out SWEEP_DIR/success_rates.png]

Prints one line per curve: method, grid, type, breakdown level.
"""
import argparse
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import number, read_table  # noqa: E402


def curves(rows):
    """{type: {(method, grid): [(magnitude, rate), ...]}} sorted by magnitude."""
    out = {}
    for r in rows:
        key = (r["method"], r.get("grid", ""))
        out.setdefault(r["corruption_type"], {}).setdefault(key, []).append(
            (number(r["magnitude"]), number(r["success_rate"])))
    for per_type in out.values():
        for points in per_type.values():
            points.sort()
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep_dir")
    ap.add_argument("--out")
    args = ap.parse_args()
    rows = read_table(args.sweep_dir, "breakdown.csv")
    data = curves(rows)
    types = sorted(data)
    fig, axes = plt.subplots(1, len(types), figsize=(4.2 * len(types), 3.6), squeeze=False)
    for ax, ctype in zip(axes[0], types):
        for (method, grid), points in sorted(data[ctype].items()):
            label = method + (f" [{grid}]" if grid and grid != "0" else "")
            xs, ys = [p[0] for p in points], [p[1] for p in points]
            line, = ax.plot(xs, ys, marker="o", label=label)
            level = next((p[0] for p in points if p[1] < 0.5), None)
            if level is not None:
                ax.plot([level], [0.5], marker="x", markersize=12, color=line.get_color())
            print(f"{method},{grid},{ctype},{'none' if level is None else format(level, 'g')}")
        ax.axhline(0.8, color="0.6", linestyle="--", linewidth=0.8)
        ax.axhline(0.2, color="0.6", linestyle="--", linewidth=0.8)
        ax.set_ylim(-0.05, 1.05)
        ax.set_xlabel(f"{ctype} level")
        ax.set_ylabel("success rate")
        ax.set_title(ctype)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    out = args.out or os.path.join(args.sweep_dir, "success_rates.png")
    fig.savefig(out, dpi=110)
    return 0


if __name__ == "__main__":
    sys.exit(main())
