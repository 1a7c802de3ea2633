#!/usr/bin/python3
"""A scan and its label map placed in another world frame, as a scanner's frame differs from an
atlas's: the voxels are kept and the NIfTI sform and qform are moved by a rigid map (a rotation
of DEG degrees about a fixed oblique axis through the world origin, then a shift), optionally
after keeping only a slab of the volume along one axis (another field of view). Nothing is
resampled, so the truth moves exactly with the scan.

  displace_scan.py OUT_PREFIX DEG SX,SY,SZ [AXIS LO HI] -- IMAGE [IMAGE ...]

Writes OUT_PREFIX + basename(IMAGE) for each IMAGE (NIfTI). SX,SY,SZ in mm (RAS, as nibabel's
affine); AXIS 0-2 and LO, HI fractions of that axis's voxels kept. Bad arguments: one line, exit
2, nothing written.
"""
import os
import sys

import numpy as np


def fail(message):
    print(f"displace_scan.py: {message}", file=sys.stderr)
    sys.exit(2)


def rotation(degrees):
    axis = np.array([0.3, 0.5, 0.81])
    axis /= np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    a = np.deg2rad(degrees)
    return np.eye(3) + np.sin(a) * k + (1 - np.cos(a)) * k @ k


def main(argv):
    if "--" not in argv or len(argv) < 6:
        fail("usage: displace_scan.py OUT_PREFIX DEG SX,SY,SZ [AXIS LO HI] -- IMAGE [IMAGE ...]")
    split = argv.index("--")
    head, images = argv[1:split], argv[split + 1:]
    if len(head) not in (3, 6) or not images:
        fail("usage: displace_scan.py OUT_PREFIX DEG SX,SY,SZ [AXIS LO HI] -- IMAGE [IMAGE ...]")
    prefix = head[0]
    try:
        degrees = float(head[1])
        shift = [float(x) for x in head[2].split(",")]
        crop = (int(head[3]), float(head[4]), float(head[5])) if len(head) == 6 else None
    except ValueError:
        fail(f"DEG, SX,SY,SZ (and AXIS LO HI) must be numbers, got {' '.join(head[1:])!r}")
    if len(shift) != 3 or not all(np.isfinite(shift)) or not np.isfinite(degrees):
        fail(f"the shift must be three finite numbers SX,SY,SZ, got {head[2]!r}")
    if crop and (crop[0] not in (0, 1, 2) or not 0 <= crop[1] < crop[2] <= 1):
        fail(f"AXIS must be 0, 1 or 2 and 0 <= LO < HI <= 1, got {crop}")
    import nibabel as nib
    m = np.eye(4)
    m[:3, :3] = rotation(degrees)
    m[:3, 3] = shift
    out = []
    for path in images:
        try:
            img = nib.load(path)
        except Exception as e:  # nibabel's own message names what is wrong
            fail(f"{path}: {e}")
        data = np.asanyarray(img.dataobj)
        if data.ndim != 3:
            fail(f"{path}: expected a 3D volume, found shape {data.shape}")
        affine = img.affine.copy()
        if crop:
            n = data.shape[crop[0]]
            lo, hi = int(crop[1] * n), max(int(crop[1] * n) + 1, int(crop[2] * n))
            index = [slice(None)] * 3
            index[crop[0]] = slice(lo, hi)
            data = data[tuple(index)]
            first = [0, 0, 0]
            first[crop[0]] = lo
            affine[:3, 3] = affine[:3, :3] @ np.array(first) + affine[:3, 3]
        affine = m @ affine
        moved = nib.Nifti1Image(data, affine, img.header)
        moved.set_sform(affine, 1)
        moved.set_qform(affine, 1)
        out.append((prefix + os.path.basename(path), moved))
    for name, moved in out:  # all read and checked first: written whole or not at all
        nib.save(moved, name)


if __name__ == "__main__":
    main(sys.argv)
