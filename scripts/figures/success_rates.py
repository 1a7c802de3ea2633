#!/usr/bin/python3
"""Success-rate curves of a sweep (Figs. 15-18 as curves): one panel per corruption
type, one line per method (and grid point), the success rate over the seeds against the corruption
magnitude in its unit, with its 95% Wilson interval as a band and n (finished runs per point) in
the legend, from DIR/breakdown.csv written by `dsnake sweep`. Curves that coincide stay visible:
each has its own marker and line style, and they are offset sideways by a small fraction of the
axis. Dashed lines mark the 80% pass and 20% fail levels; a cross marks each curve's breakdown
level (success below 50%).

    /usr/bin/python3 scripts/figures/success_rates.py SWEEP_DIR [--out SWEEP_DIR/success_rates.png] [--quiet]

Prints one line per curve: method, grid, type, breakdown level.
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

# The magnitude of each corruption type, with its unit (experiments/phantoms/corruption.h).
AXIS = {"outliers": "outliers: fraction of voxels flipped",
        "noise": "noise: Gaussian sigma (grey levels of 0-255)",
        "perturb": "perturbation radius (mm)",
        "clean": "clean"}
MARKERS = "osD^v<>phX*"
STYLES = ["-", "--", "-.", ":"]


def wilson(k, n, z=1.959963984540054):
    """The 95% Wilson score interval of k successes in n (experiments/sweep/sweep_summary.h)."""
    if n <= 0:
        return 0.0, 1.0
    p, z2n = k / n, z * z / n
    centre = (p + z2n / 2) / (1 + z2n)
    half = z / (1 + z2n) * math.sqrt(p * (1 - p) / n + z2n / (4 * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def curves(rows):
    """{type: {(method, grid): [(magnitude, rate, successes, finished), ...]}} sorted by magnitude."""
    out = {}
    for r in rows:
        key = (r["method"], r.get("grid", ""))
        finished = int(number(r.get("finished", "0")) or 0)
        successes = int(number(r.get("successes", "0")) or 0)
        out.setdefault(r["corruption_type"], {}).setdefault(key, []).append(
            (number(r["magnitude"]), number(r["success_rate"]), successes, finished))
    for per_type in out.values():
        for points in per_type.values():
            points.sort()
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep_dir")
    ap.add_argument("--out")
    ap.add_argument("--quiet", action="store_true", help="print nothing")
    args = ap.parse_args(argv)
    rows = read_table(args.sweep_dir, "breakdown.csv")
    data = curves(rows)
    types = sorted(data)
    fig, axes = plt.subplots(1, len(types), figsize=(4.2 * len(types), 3.6), squeeze=False)
    for ax, ctype in zip(axes[0], types):
        keys = sorted(data[ctype])
        magnitudes = sorted({p[0] for points in data[ctype].values() for p in points if math.isfinite(p[0])})
        span = (magnitudes[-1] - magnitudes[0]) if len(magnitudes) > 1 else 1.0
        for i, (method, grid) in enumerate(keys):
            points = data[ctype][(method, grid)]
            ns = sorted({p[3] for p in points})
            n = str(ns[0]) if len(ns) == 1 else f"{ns[0]}-{ns[-1]}"
            label = method + (f" [{grid}]" if grid and grid != "0" else "") + f" (n = {n})"
            shift = (i - (len(keys) - 1) / 2) * 0.012 * span  # sideways, so equal curves do not hide each other
            xs = [p[0] + shift for p in points]
            ys = [p[1] for p in points]
            bands = [wilson(p[2], p[3]) for p in points]
            line, = ax.plot(xs, ys, marker=MARKERS[i % len(MARKERS)], linestyle=STYLES[i % len(STYLES)],
                            markersize=5, linewidth=1.4, label=label, zorder=3 + i)
            ax.fill_between(xs, [b[0] for b in bands], [b[1] for b in bands], color=line.get_color(), alpha=0.12,
                            linewidth=0)
            level = next((p[0] for p in points if p[1] < 0.5), None)
            if level is not None:
                ax.plot([level + shift], [0.5], marker="x", markersize=12, color=line.get_color(), zorder=10)
            if not args.quiet:
                print(f"{method},{grid},{ctype},{'none' if level is None else format(level, 'g')}")
        ax.axhline(0.8, color="0.6", linestyle="--", linewidth=0.8)
        ax.axhline(0.2, color="0.6", linestyle="--", linewidth=0.8)
        ax.set_ylim(-0.05, 1.05)
        ax.set_xlabel(AXIS.get(ctype, f"{ctype} level"))
        ax.set_ylabel("success rate (fraction of runs; 95% Wilson band)")
        ax.set_title(ctype)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
    # The sweep's own name (its folder) as the title, and the PNG's Title metadata.
    title = os.path.basename(os.path.normpath(os.path.abspath(args.sweep_dir))) + " — success rate"
    fig.suptitle(title)
    fig.tight_layout()
    out = args.out or os.path.join(args.sweep_dir, "success_rates.png")
    tmp = out + f".{os.getpid()}.tmp.png"
    fig.savefig(tmp, dpi=110, metadata={"Title": title})
    os.replace(tmp, out)
    plt.close(fig)
    return 0


if __name__ == "__main__":
    sys.exit(main())
