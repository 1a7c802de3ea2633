#!/usr/bin/python3
"""Carries a template's vertices from the moving (atlas) space into the fixed space with an elastix
registration (experiments/real/elastix.sh, CORRESPONDENCE=...), for the correspondence error of
the known-warp cases.

  elastix_points.py TRANSFORM_PARAMETERS TEMPLATE.off OUT.off [TRANSFORMIX_THREADS]

Direction: elastix's transform T maps fixed-space points to moving-space points (the direction
in which the moving image is resampled), and `transformix -def POINTS` applies T. A template
vertex p lives in the moving space, so its fixed-space position is T^-1(p): found per vertex by
the fixed-point iteration y <- y - (T(y) - p) from y = p (T is the affine then the B-spline; the
iteration converges while T's Jacobian stays near the identity, as it does for these
registrations), each step one transformix call on all vertices, until max |T(y) - p| < 1e-3 mm
or 30 steps. Points are world LPS mm (elastix's physical space and the mesh's). Writes OUT.off
(the template's faces, the carried vertices) and prints the steps and the largest residual.
"""
import os
import re
import subprocess
import sys
import tempfile

import numpy as np


def read_off(path):
    tok = [t for line in open(path) for t in line.split("#")[0].split()]
    assert tok[0] == "OFF"
    nv, nf = int(tok[1]), int(tok[2])
    return np.array(tok[4:4 + 3 * nv], dtype=np.float64).reshape(nv, 3), nf, tok[4 + 3 * nv:]


def transformix(tp, pts, threads, tmp):
    with open(f"{tmp}/points.txt", "w") as f:
        f.write(f"point\n{len(pts)}\n")
        for p in pts:
            f.write(f"{p[0]!r} {p[1]!r} {p[2]!r}\n")
    subprocess.run(["transformix", "-def", f"{tmp}/points.txt", "-tp", tp, "-out", tmp, "-threads", threads],
                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    out = []
    for line in open(f"{tmp}/outputpoints.txt"):
        m = re.search(r"OutputPoint = \[\s*([^\]]+)\]", line)
        out.append([float(v) for v in m.group(1).split()])
    assert len(out) == len(pts)
    return np.array(out)


def main():
    tp, template, out = sys.argv[1:4]
    threads = sys.argv[4] if len(sys.argv) > 4 else "1"
    p, nf, faces = read_off(template)
    with tempfile.TemporaryDirectory() as tmp:
        y = p.copy()
        for step in range(1, 31):
            r = transformix(tp, y, threads, tmp) - p
            res = np.linalg.norm(r, axis=1).max()
            if res < 1e-3:
                break
            y = y - r
    with open(out, "w") as f:
        f.write(f"OFF\n{len(y)} {nf} 0\n")
        for v in y:
            f.write(f"{v[0]!r} {v[1]!r} {v[2]!r}\n")
        i = 0
        for _ in range(nf):
            n = int(faces[i])
            f.write(" ".join(faces[i:i + n + 1]) + "\n")
            i += n + 1
    print(f"elastix_points: {len(y)} vertices carried by T^-1 (fixed-point iteration, {step} transformix calls), "
          f"largest residual |T(y) - p| {res:.2e} mm, mean move {np.linalg.norm(y - p, axis=1).mean():.3f} mm")


if __name__ == "__main__":
    main()
