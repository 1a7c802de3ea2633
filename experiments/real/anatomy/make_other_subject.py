#!/usr/bin/python3
"""Makes the "other subject" set: Colin27 (ch2) made to look like another subject on another
scanner, one scan per structure, into data/real/anatomy/other/ (not committed). Deterministic.

Colin27 is the average of 27 scans of one man: its noise is far below a single acquisition's, and
its mirrored and warped copies (make_inputs.py) keep its exact intensities. A user's scan differs
from the atlas by the subject's anatomy, by the scanner's intensity response and bias field, and
by noise. Per structure:

  shape      phi = W o A: A an affine about the template's centroid (a rotation of up to 4 degrees
             about each axis, scales 0.93..1.07 per axis, a shift of up to 3 mm per axis), W(z) =
             z + sum_k a_k exp(-|z - c_k|^2 / (2 s^2)) with K = 8 centres in the structure's box
             widened by 15 mm, s = 12 mm, scaled so that max |u| over the structure's surface is 5 mm
             (make_inputs.py's warp is 3 mm and has no affine part). phi^-1 = A^-1 o W^-1, W^-1 by
             the fixed-point iteration of make_inputs.py within reach of the centres (48 mm; beyond,
             u < 1e-7 mm).
  intensity  ch2(phi^-1(y)) (cubic), then I -> 255 (I / 255)^0.8 (another response), times a smooth
             bias field 1 + 0.12 cos(x / 60 + 1) cos(y / 70) cos(z / 50 + 0.5) (x, y, z LPS mm),
             plus Gaussian noise of standard deviation 4 (ch2's white matter is ~150: an SNR of ~35,
             a good single T1 acquisition), clipped at 0.
  files      NAME_scan.nii.gz, NAME_scan_t2.nii.gz (the same scan made T2-like: within the head,
             230 (1 - I / 255)^1.3 + 20, so fluid bright and white matter dark; 0 outside),
             NAME_clean.nii.gz (the warped ch2 alone: no response, bias or noise), NAME_noise.nii.gz
             (the warped ch2 plus the noise alone), NAME_template.off (the left structure's own
             surface on ch2, 450 vertices), NAME_truth.nii.gz (the label's linear interpolant at
             phi^-1(y) thresholded at 0.5), NAME_targets.json (phi(p) for every template vertex:
             ground_truth.correspondence), NAME_phi.off (the template with every vertex at phi(p): what
             the truth scores at 450 vertices).

The atlas (template.reference_image) is ch2 itself (data/real/anatomy/common/ch2.nii.gz).

Structures: AAL 41 amygdala, 75 pallidum, 29 insula, 39 parahippocampal gyrus, 35 posterior
cingulate gyrus, 83 superior temporal pole, 21 olfactory cortex, 79 Heschl's gyrus (left).
HELD-OUT (make_inputs.py's HELD_OUT) is never read: the label map is filtered to these labels at
once.

Usage: make_other_subject.py DSNAKE_BINARY [REPO_ROOT]   (after make_inputs.py)
"""
import json
import os
import subprocess
import sys

import nibabel as nib
import numpy as np
from scipy import ndimage as ndi

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import make_inputs as mi  # noqa: E402

STRUCTURES = {"amygdala": 41, "pallidum": 75, "insula": 29, "parahippocampal": 39, "posterior_cingulate": 35,
              "temporal_pole": 83, "olfactory": 21, "heschl": 79}
assert not set(STRUCTURES.values()) & mi.HELD_OUT
PEAK_MM, K_RBF, RBF_SIGMA, NOISE, GAMMA = 5.0, 8, 12.0, 4.0, 0.8


def rotation(angles):
    cx, cy, cz = np.cos(angles)
    sx, sy, sz = np.sin(angles)
    return (np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]]) @ np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
            @ np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]]))


def main():
    dsnake = os.path.realpath(sys.argv[1])
    root = os.path.realpath(sys.argv[2] if len(sys.argv) > 2 else ".")
    com = f"{root}/data/real/anatomy/common"
    out = f"{root}/data/real/anatomy/other"
    os.makedirs(out, exist_ok=True)
    ch2 = nib.load(f"{com}/ch2.nii.gz")
    c = np.asarray(ch2.dataobj, dtype=np.float32)
    raw = np.asarray(nib.load(f"{root}/data/scans/mricron/aal.nii.gz").dataobj)
    labels = np.where(np.isin(raw, list(STRUCTURES.values())), raw, 0).astype(np.uint8)
    del raw
    y = mi.lps_grid(ch2).reshape(3, -1)
    bias = (1 + 0.12 * np.cos(y[0] / 60 + 1) * np.cos(y[1] / 70) * np.cos(y[2] / 50 + 0.5)).reshape(ch2.shape)
    info = {"structures": {}}
    for k, (name, label) in enumerate(STRUCTURES.items()):
        rng = np.random.default_rng(1000 + k)
        mask = (labels == label).astype(np.uint8)
        mi.save(mask, ch2, f"{out}/{name}_label.nii.gz", np.uint8)
        mi.run([dsnake, "template", "--mask", f"{out}/{name}_label.nii.gz", "--label", "1", "--vertices",
                str(mi.VERTICES), "--out", f"{out}/{name}_template.off", "-j", "2"])
        v = mi.read_off(f"{out}/{name}_template.off").T
        ctr = v.mean(1, keepdims=True)
        A = rotation(np.deg2rad(rng.uniform(-4, 4, 3))) @ np.diag(rng.uniform(0.93, 1.07, 3))
        t = rng.uniform(-3, 3, (3, 1))
        lo, hi = v.min(1) - 15, v.max(1) + 15
        centres = lo[None] + rng.random((K_RBF, 3)) * (hi - lo)[None]
        d = rng.normal(size=(K_RBF, 3))
        d /= np.linalg.norm(d, axis=1, keepdims=True)
        amps = d * rng.uniform(0.5, 1, (K_RBF, 1))
        w = mi.Warp(centres, amps, RBF_SIGMA)
        av = A @ (v - ctr) + ctr + t
        w.a = amps * (PEAK_MM / np.linalg.norm(w.u(av), axis=0).max())
        z = y.copy()
        near = np.all((y >= (centres.min(0) - 48)[:, None]) & (y <= (centres.max(0) + 48)[:, None]), axis=0)
        z[:, near] = w.inverse(y[:, near])
        vox = mi.lps_to_vox(ch2, np.linalg.solve(A, z - ctr - t) + ctr)
        clean = ndi.map_coordinates(c, vox, order=3, mode="nearest").reshape(ch2.shape)
        noise = rng.normal(0, NOISE, ch2.shape)
        mi.save(clean, ch2, f"{out}/{name}_clean.nii.gz", np.float32)
        mi.save(np.clip(clean + noise, 0, None), ch2, f"{out}/{name}_noise.nii.gz", np.float32)
        scan = np.clip(255 * np.clip(clean / 255, 0, None) ** GAMMA * bias + noise, 0, None)
        mi.save(scan, ch2, f"{out}/{name}_scan.nii.gz", np.float32)
        head = ndi.gaussian_filter(scan, 2) > 15
        t2 = np.where(head, 230 * np.clip(1 - scan / 255, 0, 1) ** 1.3 + 20, 0)
        mi.save(t2, ch2, f"{out}/{name}_scan_t2.nii.gz", np.float32)
        truth = (ndi.map_coordinates(mask.astype(np.float32), vox, order=1, cval=0).reshape(ch2.shape) >= 0.5)
        mi.save(truth.astype(np.uint8), ch2, f"{out}/{name}_truth.nii.gz", np.uint8)
        targets = w.u(av) + av
        json.dump({"targets": targets.T.tolist()}, open(f"{out}/{name}_targets.json", "w"))
        mi.write_off_like(f"{out}/{name}_template.off", targets, f"{out}/{name}_phi.off")
        disp = np.linalg.norm(targets - v, axis=0)
        info["structures"][name] = {"aal_label": label, "affine": A.tolist(), "shift_mm": t.ravel().tolist(),
                                    "vertex_displacement_mm": {"mean": float(disp.mean()), "max": float(disp.max())},
                                    "voxels": int(mask.sum()), "truth_voxels": int(truth.sum())}
        print(f"make_other_subject: {name}: vertices moved {disp.mean():.2f} mm on average, {disp.max():.2f} at most",
              flush=True)
    with open(f"{out}/inputs.json.tmp", "w") as f:
        json.dump(info, f, indent=1)
    os.replace(f"{out}/inputs.json.tmp", f"{out}/inputs.json")


if __name__ == "__main__":
    main()
