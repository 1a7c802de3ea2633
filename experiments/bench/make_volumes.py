#!/usr/bin/python3
"""Writes the whole-process benchmark's volumes (experiments/bench/whole_process.sh) as MetaImage
files, float32, 1 mm voxels, origin 0:

  ellipsoid.mha  230 x 300 x 80: the in-process benchmark's object (experiments/bench/bench_images.h):
                 an ellipsoid of semi-axes 80, 110, 28 voxels about the grid's centre, 85 inside and
                 170 outside with a logistic edge of 1.5 voxels, so that `dsnake field` on it solves
                 the same system as BM_GvfMultigridConverged3d.
  ct_scan.nii.gz 512 x 512 x 300, 0.7 x 0.7 x 1 mm: a CT-sized scan as scanners' converters write it
                 (int16 with scl_slope 1 and scl_inter -1024, gzip): an elliptic body at 40 HU with two
                 lungs at -850 HU in air at -1000 HU, Gaussian noise of 20 HU (seed 1).

Usage: make_volumes.py OUT_DIR [--ct]   (--ct: also ct_scan.nii.gz)
"""
import gzip
import os
import struct
import sys

import numpy as np


def write_mha(path, volume):
    nz, ny, nx = volume.shape
    header = (
        "ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
        f"DimSize = {nx} {ny} {nz}\nElementSpacing = 1 1 1\nOffset = 0 0 0\n"
        "ElementType = MET_FLOAT\nElementDataFile = LOCAL\n"
    )
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(header.encode())
        f.write(volume.astype("<f4").tobytes())
    os.replace(tmp, path)


def ellipsoid():
    size, semi = (230, 300, 80), np.array([80.0, 110.0, 28.0])
    centre = (np.array(size) - 1) / 2
    z, y, x = np.meshgrid(*(np.arange(n, dtype=np.float64) for n in size[::-1]), indexing="ij")
    r = np.sqrt(((x - centre[0]) / semi[0]) ** 2 + ((y - centre[1]) / semi[1]) ** 2 + ((z - centre[2]) / semi[2]) ** 2)
    d = (r - 1.0) * semi.min()
    return 85.0 + 85.0 / (1.0 + np.exp(-d / 1.5))


def write_ct_nifti(path):
    nx, ny, nz = 512, 512, 300
    header = bytearray(352)
    struct.pack_into("<i", header, 0, 348)
    struct.pack_into("<8h", header, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<hh", header, 70, 4, 16)  # int16
    struct.pack_into("<8f", header, 76, 1, 0.7, 0.7, 1.0, 1, 1, 1, 1)
    struct.pack_into("<fff", header, 108, 352.0, 1.0, -1024.0)  # vox_offset, scl_slope, scl_inter
    struct.pack_into("<h", header, 254, 1)  # sform_code: scanner
    for row, values in enumerate(((-0.7, 0, 0, 179), (0, -0.7, 0, 179), (0, 0, 1.0, -150))):
        struct.pack_into("<4f", header, 280 + 16 * row, *values)
    header[344:348] = b"n+1\0"
    rng = np.random.default_rng(1)
    y, x = np.meshgrid(np.arange(ny, dtype=np.float32), np.arange(nx, dtype=np.float32), indexing="ij")
    body = ((x - 256) / 240) ** 2 + ((y - 256) / 180) ** 2 < 1
    lungs = (((x - 150) / 80) ** 2 + ((y - 240) / 120) ** 2 < 1) | (((x - 362) / 80) ** 2 + ((y - 240) / 120) ** 2 < 1)
    tmp = path + ".tmp"
    with gzip.open(tmp, "wb", compresslevel=1) as f:
        f.write(bytes(header))
        for z in range(nz):
            hu = np.full((ny, nx), -1000.0, dtype=np.float32)
            if 10 <= z < 290:
                hu[body] = 40
                if 40 <= z < 260:
                    hu[lungs] = -850
            hu += rng.normal(0, 20, hu.shape).astype(np.float32)
            f.write((np.rint(hu) + 1024).astype("<i2").tobytes())
    os.replace(tmp, path)


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    write_mha(os.path.join(out, "ellipsoid.mha"), ellipsoid())
    if "--ct" in sys.argv[2:]:
        write_ct_nifti(os.path.join(out, "ct_scan.nii.gz"))


if __name__ == "__main__":
    main()
