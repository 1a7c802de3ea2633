#!/usr/bin/python3
"""A peer of the real experiments: dipy's SyN (SymmetricDiffeomorphicRegistration with the
cross-correlation metric, Avants et al. 2008) after dipy's affine pre-alignment by mutual
information, its result measured exactly as dsnake's runs (and experiments/real/elastix.sh's) are.

  experiments/real/syn.py FIXED MOVING TEMPLATE GROUND_TRUTH OUT [--targets TARGETS.json]

FIXED is the scan, MOVING the atlas (reference) image in which TEMPLATE (a 3D mesh, or a 2D contour
.txt with 2D NIfTI images: dipy's 2D transforms and CCMetric(2)) sits on its object, GROUND_TRUTH
the true mask on FIXED's grid. Steps, into OUT:
  1. the template's mask in the moving space: result_mask.nii.gz of a 0-iteration dsnake run whose
     image is MOVING (as elastix.sh);
  2. the registration, in a child process under /usr/bin/time (wall, peak memory: registration.json):
     both images cropped to the same world box, the template mask's bounding box widened by
     MARGIN mm (default 30) on every side (what a user registering one structure does: the rest of
     the head costs time and brings nothing), intensities as they are (CC and MI need no
     normalisation);
     - affine pre-alignment (dipy AffineRegistration, MutualInformationMetric with 32 bins, full
       sampling; centres of mass, then translation, rigid, affine; level_iters [10000, 1000, 100],
       sigmas [3, 1, 0] voxels, factors [4, 2, 1]: dipy's documented example settings);
     - SyN with CCMetric(3, sigma_diff 2, radius 4), level_iters SYN_LEVELS (default 100,50,25);
     - the moving mask warped onto FIXED's grid by the mapping, linearly interpolated and
       thresholded at 0.5 (outside the box: 0; a nearest-neighbour warp would carry the mask's voxel
       staircase off the grid);
     - the template's vertices carried into the fixed space. The mapping's
       transform_points takes fixed (static) world points to moving world points (the direction
       that resamples the moving image); the template's vertices need the inverse, found per vertex by
       the fixed-point iteration y <- y - A^-1 (F(y) - p) (A: the pre-alignment's linear part), 50
       iterations at most, until |F(y) - p| < 1e-4 mm (the largest residual is reported). dipy's own
       transform_points_inverse (the backward field) is recorded beside it for comparison;
  3. `dsnake template --mask` makes a surface (VERTICES, default 3000, or the surface's own vertex
     count when it has fewer) of the warped mask (when the
     warped mask touches the image's border, a failed registration, with --allow-border: it is
     measured all the same, and summary.json says mask_touches_border);
  4. a 0-iteration dsnake run evaluates it against GROUND_TRUTH (Dice, mean surface distance, HD95,
     self-intersections), and another the template with its vertices carried (the same metrics, at
     the template's resolution, as dsnake's result has; with --targets also the carried vertices'
     distances to their targets).
Writes OUT/summary.json. Environment: DSNAKE (default build/release/experiments/dsnake),
THREADS (dsnake's threads, default 2), VERTICES, MARGIN, SYN_LEVELS.
"""
import json
import os
import re
import subprocess
import sys

import numpy as np

ROOT = os.path.realpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "../.."))


def lps_ras(p):
    q = np.array(p, dtype=np.float64)
    q[..., 0] *= -1.0
    q[..., 1] *= -1.0
    return q


def read_template(path):
    """The template's vertices (LPS mm): a 2D contour's .txt lines, or a 3D OFF mesh's."""
    if path.endswith(".txt"):
        return np.loadtxt(path, ndmin=2)
    return read_off(path)


def read_off(path):
    tok = [t for line in open(path) for t in line.split("#")[0].split()]
    assert tok[0] == "OFF"
    nv = int(tok[1])
    return np.array(tok[4:4 + 3 * nv], dtype=np.float64).reshape(nv, 3)


def grid_affine(img):
    """The image's grid-to-world (RAS) affine in its own dimension: 4x4 in 3D; in 2D the 3x3 of its
    first two axes (a 2D NIfTI's slice keeps its z in the 4x4, which the 2D world drops)."""
    a = img.affine
    if len(img.shape) == 3:
        return a
    return np.array([[a[0, 0], a[0, 1], a[0, 3]], [a[1, 0], a[1, 1], a[1, 3]], [0.0, 0.0, 1.0]])


def crop(img, lo, hi):
    """The voxel box of img covering the world (RAS) box [lo, hi]: (array, affine in img's dimension)."""
    d = len(lo)
    aff_full = grid_affine(img)
    corners = np.array(np.meshgrid(*[[lo[i], hi[i]] for i in range(d)], indexing="ij")).reshape(d, -1)
    inv = np.linalg.inv(aff_full)
    v = inv[:d, :d] @ corners + inv[:d, d:d + 1]
    a = np.maximum(np.floor(v.min(1)).astype(int), 0)
    b = np.minimum(np.ceil(v.max(1)).astype(int) + 1, np.array(img.shape[:d]))
    data = np.asarray(img.dataobj, dtype=np.float32)[tuple(slice(a[i], b[i]) for i in range(d))]
    aff = aff_full.copy()
    aff[:d, d] = aff_full[:d, :d] @ a + aff_full[:d, d]
    return data, aff, a, b


def register(fixed, moving, moving_mask, out, template_points):
    import nibabel as nib
    from dipy.align.imaffine import AffineRegistration, MutualInformationMetric, transform_centers_of_mass
    from dipy.align.imwarp import SymmetricDiffeomorphicRegistration
    from dipy.align.metrics import CCMetric
    from dipy.align.transforms import (AffineTransform2D, AffineTransform3D, RigidTransform2D, RigidTransform3D,
                                       TranslationTransform2D, TranslationTransform3D)

    margin = float(os.environ.get("MARGIN", "30"))
    levels = [int(x) for x in os.environ.get("SYN_LEVELS", "100,50,25").split(",")]
    fimg, mimg, kimg = nib.load(fixed), nib.load(moving), nib.load(moving_mask)
    d = len(fimg.shape)
    k = np.asarray(kimg.dataobj) > 0
    idx = np.argwhere(k)
    vox = np.array(np.meshgrid(*[[idx[:, i].min(), idx[:, i].max()] for i in range(d)], indexing="ij")).reshape(d, -1)
    kg = grid_affine(kimg)
    w = kg[:d, :d] @ vox + kg[:d, d:d + 1]
    lo, hi = w.min(1) - margin, w.max(1) + margin
    fdat, faff, fa, fb = crop(fimg, lo, hi)
    mdat, maff, _, _ = crop(mimg, lo, hi)
    kdat, kaff, _, _ = crop(kimg, lo, hi)

    c_of_mass = transform_centers_of_mass(fdat, faff, mdat, maff)
    affreg = AffineRegistration(metric=MutualInformationMetric(32, None), level_iters=[10000, 1000, 100],
                                sigmas=[3.0, 1.0, 0.0], factors=[4, 2, 1], verbosity=0)
    start = c_of_mass.affine
    transforms = ((TranslationTransform3D(), RigidTransform3D(), AffineTransform3D()) if d == 3 else
                  (TranslationTransform2D(), RigidTransform2D(), AffineTransform2D()))
    for t in transforms:
        m = affreg.optimize(fdat, mdat, t, None, faff, maff, starting_affine=start)
        start = m.affine
    sdr = SymmetricDiffeomorphicRegistration(CCMetric(d, sigma_diff=2.0, radius=4), level_iters=levels)
    mapping = sdr.optimize(fdat, mdat, faff, maff, start)

    warped = mapping.transform(kdat.astype(np.float64), interpolation="linear", image_world2grid=np.linalg.inv(kaff),
                               out_shape=fdat.shape, out_grid2world=faff)
    full = np.zeros(fimg.shape[:d], np.uint8)
    full[tuple(slice(fa[i], fb[i]) for i in range(d))] = (warped >= 0.5).astype(np.uint8)
    hdr = fimg.header.copy()
    hdr.set_data_dtype(np.uint8)
    img = nib.Nifti1Image(full, fimg.affine, hdr)
    img.header["scl_slope"], img.header["scl_inter"] = 1.0, 0.0
    nib.save(img, f"{out}/syn_mask.nii.gz")
    info = {"crop_voxels": list(fdat.shape), "margin_mm": margin, "syn_level_iters": levels,
            "prealign": start.tolist()}
    if template_points:
        p = lps_ras(read_template(template_points))  # the template's vertices, RAS world (moving space)
        Ainv = np.linalg.inv(start[:d, :d])
        y = (np.linalg.inv(start) @ np.c_[p, np.ones(len(p))].T)[:d].T  # start: the inverse pre-alignment
        for it in range(50):
            r = mapping.transform_points(y) - p
            if np.abs(r).max() < 1e-4:
                break
            y = y - r @ Ainv.T
        r = np.linalg.norm(mapping.transform_points(y) - p, axis=1)
        yb = mapping.transform_points_inverse(p)
        info["points"] = {"iterations": it + 1, "residual_max_mm": float(r.max()),
                          "dipy_inverse_vs_iterative_mean_mm": float(np.linalg.norm(yb - y, axis=1).mean())}
        np.save(f"{out}/syn_points_lps.npy", lps_ras(y))
    json.dump(info, open(f"{out}/registration.json", "w"), indent=1)


def zero_run(dsnake, out, name, image, template, truth=None, targets=None, threads="2"):
    dimension = 2 if template.endswith(".txt") else 3
    gt = {}
    if truth:
        gt["mask"] = truth
    if targets:
        gt["correspondence"] = targets
    exp = {"dimension": dimension, "name": name, "image": {"file": image}, "template": {"file": template},
           "field": {"type": "gradient"}, "energies": [{"type": "internal", "weight": 1.0}],
           "phases": [{"iterations": 0}], "output": {"figures": True}}
    if gt:
        exp["ground_truth"] = gt
    json.dump(exp, open(f"{out}/{name}.json", "w"), indent=1)
    subprocess.run([dsnake, "run", f"{out}/{name}.json", "--out", f"{out}/{name}", "--quiet", "-j", threads], check=True)


def write_template(path, verts, src):
    """verts as a template like src: a 2D contour's .txt, or an OFF mesh with src's faces."""
    if src.endswith(".txt"):
        np.savetxt(path, verts, fmt="%.10g")
        return
    write_off(path, verts, src)


def write_off(path, verts, faces_src):
    """verts with the faces of the OFF file faces_src (same vertex count)."""
    tok = [t for line in open(faces_src) for t in line.split("#")[0].split()]
    nv, nf = int(tok[1]), int(tok[2])
    faces = tok[4 + 3 * nv:]
    with open(path, "w") as f:
        f.write(f"OFF\n{nv} {nf} 0\n")
        for v in verts:
            f.write(f"{v[0]!r} {v[1]!r} {v[2]!r}\n")
        i = 0
        for _ in range(nf):
            n = int(faces[i])
            f.write(" ".join(faces[i:i + n + 1]) + "\n")
            i += n + 1


def main():
    args = sys.argv[1:]
    if args and args[0] == "--register":
        register(*args[1:5], args[5] if len(args) > 5 else None)
        return
    targets = None
    if "--targets" in args:
        i = args.index("--targets")
        targets = os.path.realpath(args[i + 1])
        del args[i:i + 2]
    if len(args) != 5:
        raise SystemExit("usage: syn.py FIXED MOVING TEMPLATE GROUND_TRUTH OUT [--targets TARGETS.json]")
    fixed, moving, template, truth = (os.path.realpath(a) for a in args[:4])
    out = args[4]
    dsnake = os.path.realpath(os.environ.get("DSNAKE", f"{ROOT}/build/release/experiments/dsnake"))
    threads = os.environ.get("THREADS", "2")
    vertices = os.environ.get("VERTICES", "3000")
    ext = "txt" if template.endswith(".txt") else "off"
    subprocess.run(["rm", "-rf", out], check=True)
    os.makedirs(out)
    out = os.path.realpath(out)

    zero_run(dsnake, out, "moving_mask", moving, template, threads=threads)
    with open(f"{out}/syn.log", "w") as log:
        subprocess.run(["/usr/bin/time", "-f", "%e %M", "-o", f"{out}/syn_time.txt", sys.executable,
                        os.path.abspath(__file__), "--register", fixed, moving, f"{out}/moving_mask/result_mask.nii.gz",
                        out, template], check=True, stdout=log, stderr=log,
                       env=dict(os.environ, OMP_NUM_THREADS=threads))
    cmd = [dsnake, "template", "--mask", f"{out}/syn_mask.nii.gz", "--label", "1", "--vertices", vertices,
           "--out", f"{out}/syn_result.{ext}", "-j", threads]
    t = subprocess.run(cmd, capture_output=True, text=True)
    border = t.returncode != 0 and "touches the image border" in t.stderr
    if border:  # a registration that pushed the mask off the image: still measured, with a flat cap
        print(t.stderr.strip())
        t = subprocess.run(cmd + ["--allow-border"], capture_output=True, text=True)
    fewer = re.search(r"more than the ([0-9]+) vertices of the surface", t.stderr) if t.returncode != 0 else None
    if fewer:  # a small mask's surface has fewer vertices than asked: the surface at its own count
        print(t.stderr.strip())
        cmd[cmd.index("--vertices") + 1] = fewer.group(1)
        t = subprocess.run(cmd + (["--allow-border"] if border else []), capture_output=True, text=True)
    if t.returncode != 0:
        raise SystemExit(f"syn.py: {' '.join(cmd)} failed: {t.stderr.strip()}")
    tlog = t.stdout.strip()
    zero_run(dsnake, out, "evaluate", fixed, f"{out}/syn_result.{ext}", truth, threads=threads)
    m = json.load(open(f"{out}/evaluate/result.json"))["metrics"]
    wall, kb = open(f"{out}/syn_time.txt").read().split()[-2:]
    reg = json.load(open(f"{out}/registration.json"))
    summary = {"metrics": m, "syn_wall_s": float(wall), "syn_peak_mb": int(kb) / 1024, "registration": reg,
               "mask_touches_border": border}
    # the template's own vertices carried by the registration: the same mesh, at the template's
    # resolution, as dsnake's result; measured by dsnake (Dice, ..., and with --targets the
    # carried vertices against their targets, ground_truth.correspondence)
    # (a failed registration can fold the template onto itself: dsnake refuses it as a template,
    # and the summary says why instead)
    write_template(f"{out}/syn_points.{ext}", np.load(f"{out}/syn_points_lps.npy"), template)
    try:
        zero_run(dsnake, out, "correspondence", fixed, f"{out}/syn_points.{ext}", truth, targets, threads=threads)
        cm = json.load(open(f"{out}/correspondence/result.json"))["metrics"]
    except subprocess.CalledProcessError:
        cm = {}
        summary["carried_template_refused"] = True
    summary["carried_template_metrics"] = cm
    if targets:
        summary["correspondence_error_mean"] = cm.get("correspondence_error_mean")
        summary["correspondence_error_max"] = cm.get("correspondence_error_max")
    json.dump(summary, open(f"{out}/summary.json", "w"), indent=1)
    print(tlog)
    print(f"SyN (MI affine + CC SyN, box +{reg['margin_mm']:.0f} mm): Dice {m['dice']:.4f}, mean surface distance "
          f"{m['mean_surface_distance']:.3f} mm, HD95 {m['hausdorff95']:.3f} mm, self-intersections "
          f"{m['self_intersections']}; {float(wall):.1f} s wall, {int(kb) / 1024:.0f} MB peak"
          + (f"; correspondence error mean {summary['correspondence_error_mean']:.3f} mm" if targets else ""))


if __name__ == "__main__":
    main()
