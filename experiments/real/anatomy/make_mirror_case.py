#!/usr/bin/python3
"""A mirror case of the anatomy development set for any AAL structure that is not held out, made
as make_inputs.py makes S_mirror: the right structure's surface mirrored onto the left about the
symmetry plane of ch2's intensities (`dsnake template --mirror x --image ch2.nii.gz`, 450
vertices), the mirrored ch2 as atlas image, ch2 as scan, the left label as truth.

  make_mirror_case.py DSNAKE OUT_DIR NAME LEFT RIGHT

LEFT and RIGHT are AAL labels (aal.nii.gz of Debian's mricron-data). Needs make_inputs.py's
data/real/anatomy/common/ (ch2.nii.gz, ch2_mirrored.nii.gz). Writes OUT_DIR/NAME/: truth.nii.gz
(uint8 0/1 on ch2's grid), template.off, and image.nii.gz and reference.nii.gz as symlinks into
common/; the case is written whole or not at all. HELD-OUT labels (the hippocampus 37/38, the
caudate and putamen 71-74, the thalamus 77/78) are refused before the label map is read: exit 2
with one line, as for any other bad argument.
"""
import os
import shutil
import subprocess
import sys
import tempfile

HELD_OUT = {37, 38, 71, 72, 73, 74, 77, 78}
ROOT = os.path.realpath(os.path.join(os.path.dirname(os.path.abspath(__file__)), "../../.."))


def fail(message):
    print(f"make_mirror_case.py: {message}", file=sys.stderr)
    sys.exit(2)


def main(argv):
    if len(argv) != 6:
        fail("usage: make_mirror_case.py DSNAKE OUT_DIR NAME LEFT RIGHT")
    dsnake, out_dir, name = os.path.realpath(argv[1]), os.path.realpath(argv[2]), argv[3]
    try:
        left, right = int(argv[4]), int(argv[5])
    except ValueError:
        fail(f"LEFT and RIGHT must be AAL labels (integers), got {argv[4]!r} and {argv[5]!r}")
    if left in HELD_OUT or right in HELD_OUT:
        fail(f"labels {left}, {right}: held out for the project's checks (never read)")
    if left == right or left <= 0 or right <= 0:
        fail(f"labels {left}, {right}: two different positive labels expected")
    if not name or "/" in name:
        fail(f"NAME {name!r}: a folder name expected")
    common = f"{ROOT}/data/real/anatomy/common"
    for f in ("ch2.nii.gz", "ch2_mirrored.nii.gz"):
        if not os.path.exists(f"{common}/{f}"):
            fail(f"{common}/{f} is missing: run experiments/real/anatomy/make_inputs.py first")
    import nibabel as nib
    import numpy as np
    aal = nib.load(f"{ROOT}/data/scans/mricron/aal.nii.gz")
    raw = np.asarray(aal.dataobj)
    labels = np.zeros(raw.shape, np.uint8)
    labels[raw == left] = 1
    labels[raw == right] = 2
    del raw  # nothing but the two labels is kept
    for value, which in ((1, left), (2, right)):
        if not (labels == value).any():
            fail(f"label {which} has no voxel in aal.nii.gz")
    os.makedirs(out_dir, exist_ok=True)
    work = tempfile.mkdtemp(prefix=f".{name}.", dir=out_dir)
    try:
        nib.save(nib.Nifti1Image((labels == 1).astype(np.uint8), aal.affine), f"{work}/truth.nii.gz")
        nib.save(nib.Nifti1Image(labels, aal.affine), f"{work}/labels.nii.gz")
        subprocess.run([dsnake, "template", "--mask", f"{work}/labels.nii.gz", "--label", "2", "--mirror", "x",
                        "--image", f"{common}/ch2.nii.gz", "--vertices", "450", "--out", f"{work}/template.off",
                        "-j", "2"], check=True, capture_output=True)
        os.remove(f"{work}/labels.nii.gz")
        os.symlink(f"{common}/ch2.nii.gz", f"{work}/image.nii.gz")
        os.symlink(f"{common}/ch2_mirrored.nii.gz", f"{work}/reference.nii.gz")
        final = f"{out_dir}/{name}"
        if os.path.lexists(final):
            shutil.rmtree(final)
        os.rename(work, final)
    except subprocess.CalledProcessError as e:
        shutil.rmtree(work, ignore_errors=True)
        fail(f"dsnake template failed: {e.stderr.decode(errors='replace').strip()}")
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    print(f"make_mirror_case.py: {out_dir}/{name}: left {int((labels == 1).sum())} voxels, "
          f"right {int((labels == 2).sum())}")


if __name__ == "__main__":
    main(sys.argv)
