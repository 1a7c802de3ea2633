#!/usr/bin/python3
"""The figure of a 2D real experiment (REPRODUCTION.md, "Real scans"): the image with the
reference contour (green: the ground truth's boundary, drawn by the procedure of
make_2d_inputs.py), the placed template (yellow) and each listed method's result (red, dashed for
the second), cropped to the reference's surroundings.

Usage: figure_2d.py OUT_DIR CASE PNG   (OUT_DIR: the case's sweep output, e.g. out/real/cc)
"""
import glob
import json
import os
import sys

import matplotlib
matplotlib.use("Agg")
import matplotlib.image
import matplotlib.pyplot as plt
import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_2d_inputs import read_mha  # noqa: E402


def run_dir(out, method):
    runs = glob.glob(os.path.join(out, "runs", method + "-g*"))
    return runs[0] if runs else None


def load_image(path):
    if path.endswith(".png"):
        return matplotlib.image.imread(path)
    return read_mha(path)[0]


def main():
    out, case, png = sys.argv[1:4]
    recipe = run_dir(out, "recipe")
    config = json.load(open(os.path.join(recipe, "result.json")))["config"]
    image = load_image(config["image"]["file"])
    truth = read_mha(config["ground_truth"]["mask"])[0]
    ys, xs = np.nonzero(truth)
    pad = 15
    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.imshow(image, cmap="gray", interpolation="nearest")
    ax.contour(truth, [0.5], colors="lime", linewidths=1.0)
    closed = lambda p: np.vstack([p, p[:1]])
    start = closed(np.loadtxt(os.path.join(recipe, "initial.txt")))
    ax.plot(start[:, 0], start[:, 1], "-", color="yellow", lw=1.0, label="template (start)")
    for method, style in (("recipe", "-"), ("paper", "--")):
        d = run_dir(out, method)
        if d and os.path.exists(os.path.join(d, "final.txt")):
            r = json.load(open(os.path.join(d, "result.json")))
            p = closed(np.loadtxt(os.path.join(d, "final.txt")))
            ax.plot(p[:, 0], p[:, 1], style, color="red", lw=1.0,
                    label=f"{method} (Dice {r['metrics']['dice']:.3f})")
    ax.plot([], [], "-", color="lime", label="reference contour")
    ax.set_xlim(xs.min() - pad, xs.max() + pad)
    ax.set_ylim(ys.max() + pad, ys.min() - pad)
    ax.legend(loc="lower right", fontsize=7)
    ax.set_title(case)
    fig.tight_layout()
    fig.savefig(png, dpi=110)


if __name__ == "__main__":
    main()
