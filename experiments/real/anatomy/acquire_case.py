#!/usr/bin/python3
"""A copy of an anatomy case whose scan is acquired again on another grid: other voxel sizes
(thick slices, finer voxels), a grid turned against the world axes (an oblique acquisition) and
another intensity scale stored as int16. The world stays where it was: the scan is resampled
(cubic spline, scipy.ndimage.map_coordinates) at the new voxel centres, and the template, the
atlas image (reference.nii.gz, another acquisition in any case) and the truth are copied
unchanged. The control of REPRODUCTION.md's "Other acquisitions": a registration run with
dsnake init's settings on the re-acquired scan should end where it ends on the original one, up
to what the new voxels resolve.

  acquire_case.py OUT_DIR CASE_DIR... [--spacing SX SY SZ] [--rotate DEG] [--gain G] [--offset O] [--bias B]

--spacing: the new voxel size in mm along the new grid's axes (default: the scan's); --rotate:
the new grid turned by DEG degrees about the axis (1, 1, 1)/sqrt(3) through the scan's centre;
--gain, --offset: the stored intensities are G * I + O, written as int16 (default 1, 0: float32).
--bias: a smooth multiplicative field (an MR coil's intensity inhomogeneity), 1 + B t with t
running linearly from -1 to 1 across the scan's box along (1, 2, 2) / 3 (default 0: none).
Each CASE_DIR must hold image.nii.gz, template.off and truth.nii.gz and may hold
reference.nii.gz; OUT_DIR/CASE/ gets the copies under the same names. Bad input: one line naming
the file or option, exit 2; a case is written whole or not at all.
"""
import math
import os
import shutil
import sys

from case_dir import replace_case


def fail(message):
    print(f"acquire_case.py: {message}", file=sys.stderr)
    sys.exit(2)


def rotation(deg):
    import numpy as np
    a = np.ones(3) / math.sqrt(3.0)
    t = math.radians(deg)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(t) * k + (1 - math.cos(t)) * (k @ k)


def reacquire(path, spacing, deg, gain, offset, bias=0.0):
    """The scan at `path` resampled onto a grid of `spacing` mm turned by `deg` about its centre."""
    import nibabel as nib
    import numpy as np
    from scipy import ndimage
    try:
        image = nib.load(path)
        data = np.asanyarray(image.get_fdata(dtype=np.float32))
        if data.ndim != 3:
            raise ValueError(f"a volume has 3 axes, this one {data.ndim}")
        old = image.affine
        old_spacing = np.sqrt((old[:3, :3] ** 2).sum(axis=0))
        new_spacing = np.array(spacing if spacing else old_spacing, dtype=float)
        old_dir = old[:3, :3] / old_spacing
        centre = old[:3, :3] @ ((np.array(data.shape) - 1) / 2.0) + old[:3, 3]
        extent = old_spacing * (np.array(data.shape) - 1)
        r = rotation(deg)
        new_dir = r @ old_dir
        # The new grid covers the old one's box whatever its turn: the box's corners in the new axes.
        corners = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], dtype=float)
        world = (old_dir @ ((corners - 0.5) * extent).T).T
        local = world @ new_dir
        half = np.abs(local).max(axis=0)
        shape = np.ceil(2 * half / new_spacing).astype(int) + 1
        origin = centre - new_dir @ (half)
        affine = np.eye(4)
        affine[:3, :3] = new_dir * new_spacing
        affine[:3, 3] = origin
        ijk = np.indices(shape, dtype=np.float64).reshape(3, -1)
        xyz = affine[:3, :3] @ ijk + affine[:3, 3:4]
        old_ijk = np.linalg.solve(old[:3, :3], xyz - old[:3, 3:4])
        values = ndimage.map_coordinates(data, old_ijk, order=3, mode="constant", cval=0.0)
        values = values.reshape(tuple(shape))
        if bias != 0.0:
            u = np.array([1.0, 2.0, 2.0]) / 3.0
            t = u @ (xyz - centre[:, None])
            values = values * (1.0 + bias * (t / np.abs(t).max())).reshape(tuple(shape))
        if gain != 1.0 or offset != 0.0:
            values = np.clip(np.rint(gain * values + offset), -32768, 32767).astype(np.int16)
        else:
            values = values.astype(np.float32)
        out = nib.Nifti1Image(values, affine)
        out.set_sform(affine, 1)
        out.set_qform(affine, 1)
        return out
    except Exception as e:  # nibabel and scipy raise many kinds on a bad file
        fail(f"{path}: {e}")


def main(argv):
    args = argv[1:]
    options = {"--spacing": None, "--rotate": 0.0, "--gain": 1.0, "--offset": 0.0, "--bias": 0.0}
    positional = []
    i = 0
    while i < len(args):
        if args[i] == "--spacing":
            try:
                options["--spacing"] = [float(x) for x in args[i + 1:i + 4]]
            except ValueError:
                fail(f"--spacing: three numbers (mm), not {' '.join(args[i + 1:i + 4])}")
            if len(options["--spacing"]) != 3 or not all(s > 0 and math.isfinite(s) for s in options["--spacing"]):
                fail("--spacing: three positive numbers (mm)")
            i += 4
        elif args[i] in options:
            if i + 1 >= len(args):
                fail(f"{args[i]}: a number")
            try:
                options[args[i]] = float(args[i + 1])
            except ValueError:
                fail(f"{args[i]}: not a number: {args[i + 1]}")
            if not math.isfinite(options[args[i]]):
                fail(f"{args[i]}: not a finite number: {args[i + 1]}")
            i += 2
        else:
            positional.append(args[i])
            i += 1
    if len(positional) < 2:
        fail("usage: acquire_case.py OUT_DIR CASE_DIR... [--spacing SX SY SZ] [--rotate DEG] [--gain G] [--offset O] "
             "[--bias B]")
    if not -1 < options["--bias"] < 1:
        fail("--bias: must lie in (-1, 1), so that the field stays positive")
    if options["--gain"] == 0:
        fail("--gain: must not be 0")
    import nibabel as nib
    for case in positional[1:]:
        for name in ("image.nii.gz", "template.off", "truth.nii.gz"):
            if not os.path.exists(os.path.join(case, name)):
                fail(f"{os.path.join(case, name)}: missing")
        scan = reacquire(os.path.join(case, "image.nii.gz"), options["--spacing"], options["--rotate"],
                         options["--gain"], options["--offset"], options["--bias"])

        def write(staging):
            nib.save(scan, os.path.join(staging, "image.nii.gz"))
            for name in ("template.off", "truth.nii.gz", "reference.nii.gz"):
                if os.path.exists(os.path.join(case, name)):
                    shutil.copyfile(os.path.join(case, name), os.path.join(staging, name))

        target = replace_case(positional[0], case, write)
        print(f"{target}: {case} on {scan.shape} voxels of {scan.header.get_zooms()} mm")


if __name__ == "__main__":
    main(sys.argv)
