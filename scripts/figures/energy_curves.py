#!/usr/bin/python3
"""Energy curves of one or more runs (e.g. the snake and the global solve of the same file):
the weighted total energy per iteration from each run folder's energy_trace.csv, and one panel
per term, log scale where every value is positive.

    /usr/bin/python3 scripts/figures/energy_curves.py RUN_DIR [RUN_DIR ...] --out energy.png [--labels a,b]

Prints one line per run: label, iterations, first and last total energy.
"""
import argparse
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import number, read_table  # noqa: E402

FIXED = {"iteration", "phase", "phase_iteration", "vertices", "max_displacement"}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--out", required=True)
    ap.add_argument("--labels")
    args = ap.parse_args()
    labels = args.labels.split(",") if args.labels else [os.path.basename(os.path.normpath(r)) for r in args.runs]
    if len(labels) != len(args.runs):
        sys.exit("--labels: one label per run")
    traces = [read_table(r, "energy_trace.csv", allow_empty=True) for r in args.runs]
    terms = []
    for t in traces:
        for k in (t[0].keys() if t else []):
            if k not in FIXED and k not in terms:
                terms.append(k)
    fig, axes = plt.subplots(1, len(terms), figsize=(3.8 * len(terms), 3.4), squeeze=False)
    for ax, term in zip(axes[0], terms):
        positive = True
        for label, t in zip(labels, traces):
            xs = [number(r["iteration"]) for r in t if term in r]
            ys = [number(r[term]) for r in t if term in r]
            positive &= all(y > 0 for y in ys if not math.isnan(y))
            ax.plot(xs, ys, label=label)
        if positive:
            ax.set_yscale("log")
        ax.set_title(term)
        ax.set_xlabel("iteration (over all phases)")
        # the terms' units differ (docs/methods.md, "Parameters with units")
        ax.set_ylabel("weight × term (the term's units)" + (", log scale" if positive else ""))
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    title = "energy: " + ", ".join(labels)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110, metadata={"Title": title})
    for label, t in zip(labels, traces):
        if t:
            print(f"{label},{len(t)},{number(t[0]['total']):.6g},{number(t[-1]['total']):.6g}")
        else:
            print(f"{label},0,nan,nan")
    return 0


if __name__ == "__main__":
    sys.exit(main())
