#!/usr/bin/env python3
"""A 2D case from a 3D case of the anatomy sets: the axial (or coronal) slice where the truth is largest.

    make_slice_case.py CASE_DIR OUT_DIR [--template FILE] [--spacing MM] [--axis z|y]

CASE_DIR holds image.nii.gz, reference.nii.gz, truth.nii.gz and template.off (make_inputs.py,
make_mirror_case.py). OUT_DIR gets the three images' slices as 2D NIfTI (the slice's world
position kept in the affine) and template.txt: the 3D template cut by the slice's plane (its
largest loop), resampled to vertices SPACING mm apart along its length (default 2, at least 16
vertices), counter-clockwise. --template: another mesh of CASE_DIR to cut (fixed_template.off
for a fixed point; give the image as reference yourself). --axis: the axis the slice is normal
to, z (axial, default) or y (coronal; the slice's second 2D axis is then the world's z, so that
the 2D image's LPS (x, y) are the world's LPS x and -z, as a 2D NIfTI of the coronal plane reads).
For mirror and cross-contrast cases the atlas's slice shows the same anatomy in the same plane
(the mirror is about x), so the 2D problem is the 3D one's cross-section.
"""
import argparse
import os
import sys
from collections import defaultdict

import nibabel as nib
import numpy as np


def fail(msg):
    print(f"make_slice_case.py: {msg}", file=sys.stderr)
    sys.exit(2)


def read_off(path):
    words = open(path).read().split()
    if not words or words[0] != "OFF":
        fail(f"{path}: not an OFF mesh")
    nv, nf = int(words[1]), int(words[2])
    p = 4
    v = np.array(words[p:p + 3 * nv], float).reshape(nv, 3)
    p += 3 * nv
    faces = []
    for _ in range(nf):
        n = int(words[p])
        faces.append([int(x) for x in words[p + 1:p + 1 + n]])
        p += 1 + n
    return v, faces


def cut(v, faces, z0):
    """The loops where the plane v[:, 2] = z0 cuts the mesh (v in the slice's frame: its two 2D
    coordinates first, the cut axis third); the largest one, as an array."""
    z = v[:, 2] - z0 + 1e-7  # no vertex exactly on the plane
    adj, pos = defaultdict(list), {}
    for f in faces:
        pts = []
        for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0])):
            if (z[a] > 0) != (z[b] > 0):
                s = z[a] / (z[a] - z[b])
                pts.append((tuple(sorted((a, b))), v[a] + s * (v[b] - v[a])))
        if len(pts) == 2:
            (ka, pa), (kb, pb) = pts
            adj[ka].append(kb)
            adj[kb].append(ka)
            pos[ka], pos[kb] = pa[:2], pb[:2]
    seen, loops = set(), []
    for start in adj:
        if start in seen:
            continue
        loop, prev, cur = [start], None, start
        seen.add(start)
        while True:
            nxt = [k for k in adj[cur] if k != prev and k not in seen]
            if not nxt:
                break
            prev, cur = cur, nxt[0]
            loop.append(cur)
            seen.add(cur)
        loops.append(np.array([pos[k] for k in loop]))
    if not loops:
        fail(f"the template does not cross the plane z = {z0} mm")
    return max(loops, key=lambda p: abs(signed_area(p)))


def signed_area(p):
    return 0.5 * np.sum(p[:, 0] * np.roll(p[:, 1], -1) - np.roll(p[:, 0], -1) * p[:, 1])


def resample(p, spacing):
    q = np.vstack([p, p[:1]])
    s = np.concatenate([[0], np.cumsum(np.linalg.norm(np.diff(q, axis=0), axis=1))])
    n = max(16, int(round(s[-1] / spacing)))
    t = np.arange(n) * s[-1] / n
    r = np.column_stack([np.interp(t, s, q[:, 0]), np.interp(t, s, q[:, 1])])
    return r if signed_area(r) > 0 else r[::-1]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case")
    ap.add_argument("out")
    ap.add_argument("--template", default="template.off")
    ap.add_argument("--spacing", type=float, default=2.0)
    ap.add_argument("--axis", default="z")
    a = ap.parse_args()
    if a.axis not in ("z", "y"):
        fail(f"--axis: expected z or y, got {a.axis}")
    ax = 2 if a.axis == "z" else 1
    if not a.spacing > 0:
        fail(f"--spacing: expected a length > 0 mm, got {a.spacing}")
    for f in ("image.nii.gz", "reference.nii.gz", "truth.nii.gz", a.template):
        if not os.path.isfile(os.path.join(a.case, f)):
            fail(f"{os.path.join(a.case, f)}: file not found")
    truth = nib.load(os.path.join(a.case, "truth.nii.gz"))
    inside = np.asarray(truth.dataobj) > 0
    k = int(np.argmax(inside.sum(axis=tuple(i for i in range(3) if i != ax))))
    affine = truth.affine
    if not np.allclose(affine[:3, :3], np.diag(np.diag(affine[:3, :3]))):
        fail(f"{a.case}/truth.nii.gz: the voxel axes are not the world's (an oblique or permuted grid)")
    keep = [0, 1] if ax == 2 else [0, 2]  # the slice's two voxel axes, as the 2D image's x and y
    slice_affine = np.eye(4)
    slice_affine[:2, :2] = affine[np.ix_(keep, keep)]
    slice_affine[:2, 3] = affine[keep, 3]
    slice_affine[2, 3] = affine[ax, 3] + affine[ax, ax] * k  # the slice's place on the cut axis
    os.makedirs(a.out, exist_ok=True)
    for name in ("image.nii.gz", "reference.nii.gz", "truth.nii.gz"):
        im = nib.load(os.path.join(a.case, name))
        if not np.allclose(im.affine, affine):
            fail(f"{a.case}/{name}: not on the truth's grid")
        data = np.take(np.asarray(im.dataobj), k, axis=ax)
        data = (data > 0).astype(np.uint8) if name == "truth.nii.gz" else data.astype(np.float32)
        nib.save(nib.Nifti1Image(data, slice_affine), os.path.join(a.out, name))
    z0 = affine[ax, 3] + affine[ax, ax] * k  # RAS world coordinate of the slice on the cut axis
    v, faces = read_off(os.path.join(a.case, a.template))  # LPS
    if ax == 2:
        planar = v  # (x, y) LPS; z LPS = z RAS
    else:  # 2D (x, y) = LPS x and -z (the RAS z as the 2D image's y, negated as LPS); cut at y = -z0 LPS
        planar = np.column_stack([v[:, 0], -v[:, 2], v[:, 1]])
        z0 = -z0
    contour = resample(cut(planar, faces, z0), a.spacing)
    np.savetxt(os.path.join(a.out, "template.txt"), contour, fmt="%.6f")
    print(f"{a.out}: slice {k} (RAS {a.axis} {affine[ax, 3] + affine[ax, ax] * k:g} mm), {int(np.take(inside, k, axis=ax).sum())} truth pixels, "
          f"template {len(contour)} vertices")


if __name__ == "__main__":
    main()
