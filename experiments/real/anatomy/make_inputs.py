#!/usr/bin/python3
"""Makes the anatomy development set: real structures of Colin27 (MNI's single-subject T1, Debian
mricron-data's ch2.nii.gz and ch2better.nii.gz, fetched by scripts/fetch_scans.sh) with the AAL
labels (aal.nii.gz, on ch2's grid), into data/real/anatomy/ (not committed). Deterministic.

HELD-OUT: AAL 37/38 (hippocampus), 71-74 (caudate, putamen), 77/78 (thalamus) and the INIA19 atlas
are never read. The label map is filtered at once to the development labels below (DEV_LABELS);
nothing else of it is kept or looked at, and every later step (dsnake template included) reads the
filtered map common/labels_dev.nii.gz.

Structures (left label, right label in labels_dev.nii.gz):
  amygdala    41, 42   (AAL 41/42)
  pallidum    75, 76   (AAL 75/76)
  cerebellum  191, 192 (a cerebellar hemisphere: the AAL cerebellum labels 91..107 odd merged for
                        the left, 92..108 even for the right; the vermis 109..116 is not in it)
Why the cerebellar hemisphere as the third: on ch2 its boundary is visible over most of its extent
(mean T1 84 inside against 64 in a 1-2 voxel band outside; gradient magnitude, sigma 1 mm, 7.8 on
its boundary voxels against 4.2 inside), the parahippocampal gyrus (39/40) has none that stands out
(gradient 6.6 on the boundary, 6.8 inside: a cortical ribbon cut by the atlas). The amygdala (4.6
against 3.0; inside 87.5, outside 84.4) and the pallidum (2.3 against 1.5; inside 102.5, outside 103.0:
brighter than the putamen, darker than the internal capsule) have weak, mixed-polarity boundaries.

Cases, each a folder data/real/anatomy/CASE/ with the same file names (symlinks into common/):
  image.nii.gz          the scan (the target)
  truth.nii.gz          the true mask of the left structure on the scan's grid (uint8 0/1)
  template.off          the registrations' template (450 vertices)
  reference.nii.gz      the atlas image in which template.off sits on its object
                        (template.reference_image; elastix's and SyN's moving image)
  fixed_template.off    the fixed-point runs' template: the truth's own surface (450 vertices)
  fixed_reference.nii.gz the fixed-point runs' reference: the scan itself
  targets.json          (warp cases) ground_truth.correspondence: phi(p) per template vertex
  true_correspondence.off (warp cases) the template with every vertex at phi(p): what the truth
                        scores at the template's resolution
  S_mirror  scan ch2; template: the right structure's surface mirrored onto the left about the
            symmetry plane of ch2's intensities (`dsnake template --mirror x --image ch2.nii.gz`);
            reference: ch2 mirrored about the same plane (linear interpolation, on ch2's grid).
  S_cross   as S_mirror, but the scan is ch2better (another processing of the same subject: other
            contrast, skull stripped), 0.5 mm, resampled onto ch2's 1 mm grid (its voxel centres
            fall on ch2's: a [1/4 1/2 1/4] tent filter per axis, then every other voxel; 0 outside
            its extent) so that the truth (AAL, on ch2's grid) applies. The reference stays the
            mirrored ch2: a cross-contrast atlas.
  S_warp    scan: ch2 warped by a known smooth diffeomorphism phi (below); atlas: ch2 itself;
            template: the left structure's own (unwarped) surface at 450 vertices; truth: the
            warped label, linearly interpolated and thresholded at 0.5 (below); targets: phi(p) for
            every template vertex p.

phi(x) = x + sum_k a_k exp(-|x - c_k|^2 / (2 s^2)) (world LPS mm): K = 6 centres drawn uniformly in
the structure's bounding box widened by 10 mm, s = 8 mm (cerebellum 16 mm), a_k random directions
with lengths uniform in [0.5, 1], the whole field scaled so that max |u| over the structure's
surface (the template's vertices) is 3 mm; seeded per structure. The Jacobian determinant of phi is computed on the grid (central differences) and must
be > 0.2 everywhere (inputs.json records its range). The warped scan is ch2(phi^-1(y)) (cubic
interpolation, clipped to [0, 255]); phi^-1 by the fixed-point iteration x = y - u(x) (u is a
contraction: its gradient's norm is checked < 1), to 1e-6 mm.

The warped truth is the label's linear interpolant at phi^-1(y), thresholded at 0.5: the warped
anatomy's boundary, as the template's smooth surface carried by phi is. A nearest-neighbour warp
would carry the label's voxel staircase to places off the grid, where no smooth surface follows it:
measured on the amygdala, the template with every vertex at phi(p) scores Dice 0.946 against the
nearest-neighbour truth and 0.979 against this one, while the nearest-neighbour warp of the label
itself, what a label-warping peer returns at a perfect registration, scores 1.0 against the first.
The peers (experiments/real/elastix.sh, syn.py) warp their masks the same way.

Usage: make_inputs.py DSNAKE_BINARY [REPO_ROOT]
"""
import json
import os
import re
import subprocess
import sys

import nibabel as nib
import numpy as np
from scipy import ndimage as ndi

HELD_OUT = {37, 38, 71, 72, 73, 74, 77, 78}
STRUCTURES = {  # name: (left label, right label, source AAL labels left, right, RBF width mm)
    "amygdala": (41, 42, [41], [42], 8.0),
    "pallidum": (75, 76, [75], [76], 8.0),
    "cerebellum": (191, 192, list(range(91, 108, 2)), list(range(92, 109, 2)), 16.0),
}
DEV_LABELS = sorted({l for s in STRUCTURES.values() for l in s[2] + s[3]})
assert not HELD_OUT & set(DEV_LABELS)
VERTICES = 450
SEEDS = {"amygdala": 4101, "pallidum": 7501, "cerebellum": 9101}
PEAK_MM = 3.0
K_RBF = 6


def run(cmd):
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"make_inputs: {' '.join(cmd)} failed:\n{r.stdout}{r.stderr}")
    return r.stdout + r.stderr


def save(vol, ref, path, dtype):
    """NIfTI on ref's grid (its affine and header: sform_code 4 as ch2's)."""
    hdr = ref.header.copy()
    hdr.set_data_dtype(dtype)
    img = nib.Nifti1Image(np.asarray(vol, dtype=dtype), ref.affine, hdr)
    img.set_sform(ref.affine, int(ref.header["sform_code"]))
    img.set_qform(ref.header.get_qform(), int(ref.header["qform_code"]))
    hdr["scl_slope"], hdr["scl_inter"] = 1.0, 0.0
    nib.save(img, path + ".tmp.nii.gz")
    os.replace(path + ".tmp.nii.gz", path)


def lps_grid(img):
    """World LPS coordinates of every voxel centre, shape (3, nx, ny, nz)."""
    ijk = np.indices(img.shape, dtype=np.float64).reshape(3, -1)
    ras = img.affine[:3, :3] @ ijk + img.affine[:3, 3:4]
    ras[0] *= -1.0
    ras[1] *= -1.0
    return ras.reshape((3,) + img.shape)


def lps_to_vox(img, pts):
    """(3, N) LPS mm -> (3, N) voxel indices of img."""
    ras = np.array(pts, dtype=np.float64)
    ras[0] *= -1.0
    ras[1] *= -1.0
    inv = np.linalg.inv(img.affine)
    return inv[:3, :3] @ ras + inv[:3, 3:4]


def read_off(path):
    tok = [t for line in open(path) for t in line.split("#")[0].split()]
    assert tok[0] == "OFF"
    nv = int(tok[1])
    return np.array(tok[4:4 + 3 * nv], dtype=np.float64).reshape(nv, 3)


def write_off_like(path, verts, out):
    """The OFF mesh at path with its vertices moved to verts (3, N): same faces, same order."""
    body = [line for line in open(path) if line.split("#")[0].strip()]
    nv = int(body[1].split()[0])
    assert verts.shape == (3, nv)
    lines = body[:2] + [" ".join(repr(float(x)) for x in p) + "\n" for p in verts.T] + body[2 + nv:]
    open(out + ".tmp", "w").writelines(lines)
    os.replace(out + ".tmp", out)


class Warp:
    def __init__(self, centres, amps, s):
        self.c, self.a, self.s = centres, amps, s  # (K, 3), (K, 3), mm

    def u(self, x):  # x (3, ...) LPS -> displacement (3, ...)
        out = np.zeros_like(x)
        for c, a in zip(self.c, self.a):
            g = np.exp(-sum((x[i] - c[i]) ** 2 for i in range(3)) / (2 * self.s ** 2))
            for i in range(3):
                out[i] += a[i] * g
        return out

    def inverse(self, y, tol=1e-6):
        x = y.copy()
        for it in range(200):
            nx = y - self.u(x)
            d = np.abs(nx - x).max()
            x = nx
            if d < tol:
                return x
        raise SystemExit("make_inputs: phi^-1 did not converge")


def make_warp(name, box_lo, box_hi, s, verts):
    rng = np.random.default_rng(SEEDS[name])
    lo, hi = box_lo - 10.0, box_hi + 10.0
    centres = lo + rng.random((K_RBF, 3)) * (hi - lo)
    d = rng.normal(size=(K_RBF, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    amps = d * rng.uniform(0.5, 1.0, (K_RBF, 1))
    w = Warp(centres, amps, s)
    # scale to a peak |u| of PEAK_MM over the structure's surface (the template's vertices)
    peak = np.linalg.norm(w.u(verts), axis=0).max()
    w.a = amps * (PEAK_MM / peak)
    return w


def main():
    dsnake = os.path.realpath(sys.argv[1])
    root = os.path.realpath(sys.argv[2] if len(sys.argv) > 2 else ".")
    scans = f"{root}/data/scans/mricron"
    out = f"{root}/data/real/anatomy"
    com = f"{out}/common"
    os.makedirs(com, exist_ok=True)
    ch2 = nib.load(f"{scans}/ch2.nii.gz")
    c = np.asarray(ch2.dataobj, dtype=np.float32)
    info = {"vertices": VERTICES, "held_out_never_read": sorted(HELD_OUT), "structures": {}}

    # The label map, filtered to the development labels at once.
    aal_img = nib.load(f"{scans}/aal.nii.gz")
    assert np.allclose(aal_img.affine, ch2.affine) and aal_img.shape == ch2.shape
    raw = np.asarray(aal_img.dataobj)
    dev = np.zeros(raw.shape, np.uint8)
    for name, (l, r, src_l, src_r, _) in STRUCTURES.items():
        dev[np.isin(raw, src_l)] = l
        dev[np.isin(raw, src_r)] = r
    del raw
    save(dev, ch2, f"{com}/labels_dev.nii.gz", np.uint8)

    # ch2better on ch2's grid
    cb = nib.load(f"{scans}/ch2better.nii.gz")
    b = np.asarray(cb.dataobj, dtype=np.float32)
    for ax in range(3):
        b = ndi.correlate1d(b, [0.25, 0.5, 0.25], axis=ax, mode="nearest")
    ijk = np.indices(ch2.shape, dtype=np.float64).reshape(3, -1)
    world = ch2.affine[:3, :3] @ ijk + ch2.affine[:3, 3:4]
    inv = np.linalg.inv(cb.affine)
    src = inv[:3, :3] @ world + inv[:3, 3:4]
    assert np.abs(src - np.rint(src)).max() < 1e-6  # ch2's voxel centres are ch2better's
    better = ndi.map_coordinates(b, src, order=1, cval=0.0).reshape(ch2.shape)
    save(better, ch2, f"{com}/ch2better_1mm.nii.gz", np.float32)
    save(c, ch2, f"{com}/ch2.nii.gz", np.float32)

    plane = None
    for name, (l, r, _, _, s) in STRUCTURES.items():
        st = {}
        mask = (dev == l).astype(np.uint8)
        save(mask, ch2, f"{com}/{name}_truth.nii.gz", np.uint8)
        log = run([dsnake, "template", "--mask", f"{com}/{name}_truth.nii.gz", "--label", "1", "--vertices",
                   str(VERTICES), "--out", f"{com}/{name}_truth_{VERTICES}.off", "-j", "2"])
        st["truth_surface"] = log.strip()
        log = run([dsnake, "template", "--mask", f"{com}/labels_dev.nii.gz", "--label", str(r), "--mirror", "x",
                   "--image", f"{scans}/ch2.nii.gz", "--vertices", str(VERTICES), "--out",
                   f"{com}/{name}_mirrored_{VERTICES}.off", "-j", "2"])
        st["mirrored_template"] = log.strip()
        p = float(re.search(r"mirrored about x = (-?[0-9.]+) mm", log).group(1))
        assert plane is None or abs(plane - p) < 1e-9, (plane, p)
        plane = p
        st["voxels"] = int(mask.sum())

        # the warp
        idx = np.argwhere(mask)
        corners = np.array([[idx[:, 0].min(), idx[:, 0].max()], [idx[:, 1].min(), idx[:, 1].max()],
                            [idx[:, 2].min(), idx[:, 2].max()]], dtype=np.float64)
        corner_pts = np.array(np.meshgrid(*corners, indexing="ij")).reshape(3, -1)
        ras = ch2.affine[:3, :3] @ corner_pts + ch2.affine[:3, 3:4]
        lps = ras * np.array([[-1.0], [-1.0], [1.0]])
        verts = read_off(f"{com}/{name}_truth_{VERTICES}.off").T
        w = make_warp(name, lps.min(1), lps.max(1), s, verts)
        y = lps_grid(ch2)
        # Jacobian of phi = I + grad u on the grid (1 mm spacing, central differences, in LPS axes)
        uy = w.u(y)
        J = np.empty((3, 3) + ch2.shape, np.float64)
        sign = [-1.0, -1.0, 1.0]  # LPS axis i runs along voxel axis i with this sign (ch2: RAS diagonal affine)
        for i in range(3):
            for j in range(3):
                J[i, j] = np.gradient(uy[i], axis=j) * sign[j] / ch2.header.get_zooms()[j]
        gnorm = np.sqrt((J ** 2).sum(axis=(0, 1))).max()
        for i in range(3):
            J[i, i] += 1.0
        det = (J[0, 0] * (J[1, 1] * J[2, 2] - J[1, 2] * J[2, 1]) - J[0, 1] * (J[1, 0] * J[2, 2] - J[1, 2] * J[2, 0])
               + J[0, 2] * (J[1, 0] * J[2, 1] - J[1, 1] * J[2, 0]))
        del J, uy
        if det.min() <= 0.2 or gnorm >= 1.0:
            raise SystemExit(f"make_inputs: {name}: warp not safely invertible (det min {det.min()}, |grad u| {gnorm})")
        xinv = w.inverse(y)
        vox = lps_to_vox(ch2, xinv.reshape(3, -1))
        warped = np.clip(ndi.map_coordinates(c, vox, order=3, mode="nearest"), 0, 255).reshape(ch2.shape)
        wmask = (ndi.map_coordinates(mask.astype(np.float32), vox, order=1, cval=0.0) >= 0.5).reshape(ch2.shape)
        wmask = wmask.astype(np.uint8)
        save(warped, ch2, f"{com}/{name}_warped.nii.gz", np.float32)
        save(wmask, ch2, f"{com}/{name}_warped_truth.nii.gz", np.uint8)
        run([dsnake, "template", "--mask", f"{com}/{name}_warped_truth.nii.gz", "--label", "1", "--vertices",
             str(VERTICES), "--out", f"{com}/{name}_warped_truth_{VERTICES}.off", "-j", "2"])
        targets = verts + w.u(verts)
        back = w.inverse(targets)
        assert np.abs(back - verts).max() < 1e-4
        json.dump({"targets": targets.T.tolist()}, open(f"{com}/{name}_targets.json", "w"))
        write_off_like(f"{com}/{name}_truth_{VERTICES}.off", targets,
                       f"{com}/{name}_true_correspondence_{VERTICES}.off")
        disp = np.linalg.norm(targets - verts, axis=0)
        st["warp"] = {"seed": SEEDS[name], "rbf_sigma_mm": s, "centres_lps": w.c.tolist(), "amplitudes_mm": w.a.tolist(),
                      "jacobian_det_min": float(det.min()), "jacobian_det_max": float(det.max()),
                      "grad_u_frobenius_max": float(gnorm), "vertex_displacement_mm": {
                          "mean": float(disp.mean()), "max": float(disp.max())},
                      "warped_truth_voxels": int(wmask.sum())}
        info["structures"][name] = st

        cases = {
            f"{name}_mirror": {"image": "ch2.nii.gz", "reference": "ch2_mirrored.nii.gz",
                               "template": f"{name}_mirrored_{VERTICES}.off", "truth": f"{name}_truth.nii.gz",
                               "fixed_template": f"{name}_truth_{VERTICES}.off"},
            f"{name}_cross": {"image": "ch2better_1mm.nii.gz", "reference": "ch2_mirrored.nii.gz",
                              "template": f"{name}_mirrored_{VERTICES}.off", "truth": f"{name}_truth.nii.gz",
                              "fixed_template": f"{name}_truth_{VERTICES}.off"},
            f"{name}_warp": {"image": f"{name}_warped.nii.gz", "reference": "ch2.nii.gz",
                             "template": f"{name}_truth_{VERTICES}.off", "truth": f"{name}_warped_truth.nii.gz",
                             "fixed_template": f"{name}_warped_truth_{VERTICES}.off",
                             "targets": f"{name}_targets.json",
                             "true_correspondence": f"{name}_true_correspondence_{VERTICES}.off"},
        }
        for case, files in cases.items():
            d = f"{out}/{case}"
            os.makedirs(d, exist_ok=True)
            links = {"image.nii.gz": files["image"], "reference.nii.gz": files["reference"],
                     "template.off": files["template"], "truth.nii.gz": files["truth"],
                     "fixed_template.off": files["fixed_template"], "fixed_reference.nii.gz": files["image"]}
            if "targets" in files:
                links["targets.json"] = files["targets"]
                links["true_correspondence.off"] = files["true_correspondence"]
            for link, target in links.items():
                if os.path.lexists(f"{d}/{link}"):
                    os.remove(f"{d}/{link}")
                os.symlink(f"../common/{target}", f"{d}/{link}")
        print(f"make_inputs: {name}: {st['voxels']} voxels; warp det [{det.min():.3f}, {det.max():.3f}], "
              f"vertex displacement mean {disp.mean():.2f} max {disp.max():.2f} mm", flush=True)

    # ch2 mirrored about the plane the templates were mirrored about (LPS x = plane)
    y = lps_grid(ch2)
    y[0] = 2.0 * plane - y[0]
    vox = lps_to_vox(ch2, y.reshape(3, -1))
    mirrored = ndi.map_coordinates(c, vox, order=1, mode="nearest").reshape(ch2.shape)
    save(mirrored, ch2, f"{com}/ch2_mirrored.nii.gz", np.float32)
    info["mirror_plane_lps_x_mm"] = plane
    json.dump(info, open(f"{out}/inputs.json", "w"), indent=1)
    print(f"make_inputs: mirror plane x = {plane} mm (LPS); {out}/inputs.json")


if __name__ == "__main__":
    main()
