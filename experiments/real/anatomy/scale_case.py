#!/usr/bin/python3
"""A copy of an anatomy case with the whole world scaled by S about the origin: the same voxels
with their NIfTI transform (sform and qform) scaled, and the template's vertices scaled. The
control of REPRODUCTION.md's "The recipe at other sizes": the same structure S times as large, as
in another species' brain, where a registration whose lengths follow the structure ends where it
ends at S = 1.

  scale_case.py S OUT_DIR CASE_DIR...

Each CASE_DIR (data/real/anatomy/CASE/) must hold image.nii.gz, template.off and truth.nii.gz,
and may hold reference.nii.gz; OUT_DIR/CASE/ gets the scaled copies under the same names. Bad
input: one line naming the file, exit 2; a case is written whole or not at all.
"""
import math
import os
import sys

from case_dir import replace_case


def fail(message):
    print(f"scale_case.py: {message}", file=sys.stderr)
    sys.exit(2)


def scaled_off(path, s):
    try:
        lines = [l for l in open(path).read().split("\n") if l.strip() and not l.lstrip().startswith("#")]
        if not lines or lines[0].split()[0] != "OFF":
            raise ValueError("not an OFF file")
        nv = int(lines[1].split()[0])
        out = ["OFF", lines[1].strip()]
        for line in lines[2:2 + nv]:
            xyz = [float(x) for x in line.split()[:3]]
            if len(xyz) != 3 or not all(math.isfinite(x) for x in xyz):
                raise ValueError("a vertex without 3 finite coordinates")
            out.append(" ".join(repr(s * x) for x in xyz))
        if len(out) != 2 + nv:
            raise ValueError("fewer vertices than its header says")
        return "\n".join(out + lines[2 + nv:]) + "\n"
    except (OSError, ValueError, IndexError) as e:
        fail(f"{path}: {e}")


def scaled_nifti(path, s):
    import nibabel as nib
    import numpy as np
    try:
        image = nib.load(path)
        affine = np.diag([s, s, s, 1.0]) @ image.affine
        out = nib.Nifti1Image(np.asanyarray(image.dataobj), affine, image.header)
        out.set_sform(affine, 1)
        out.set_qform(affine, 1)
        return out
    except Exception as e:  # nibabel raises many kinds on a bad file
        fail(f"{path}: {e}")


def main(argv):
    if len(argv) < 4:
        fail("usage: scale_case.py S OUT_DIR CASE_DIR...")
    try:
        s = float(argv[1])
    except ValueError:
        fail(f"S: not a number: {argv[1]}")
    if not (s > 0 and math.isfinite(s)):
        fail(f"S: must be a positive number, not {argv[1]}")
    import nibabel as nib
    for case in argv[3:]:
        files = {}
        for name in ("image.nii.gz", "template.off", "truth.nii.gz", "reference.nii.gz"):
            path = os.path.join(case, name)
            if not os.path.exists(path):
                if name == "reference.nii.gz":
                    continue
                fail(f"{path}: missing")
            files[name] = scaled_off(path, s) if name.endswith(".off") else scaled_nifti(path, s)

        def write(staging):
            for name, content in files.items():
                if isinstance(content, str):
                    with open(os.path.join(staging, name), "w") as f:
                        f.write(content)
                else:
                    nib.save(content, os.path.join(staging, name))

        target = replace_case(argv[2], case, write)
        print(f"{target}: {case} scaled by {s}")


if __name__ == "__main__":
    main(sys.argv)
