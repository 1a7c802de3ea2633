#!/usr/bin/python3
"""Writes the whole-process benchmark's volumes (experiments/bench/whole_process.sh) as MetaImage
files, float32, 1 mm voxels, origin 0:

  ellipsoid.mha  230 x 300 x 80: the in-process benchmark's object (experiments/bench/bench_images.h):
                 an ellipsoid of semi-axes 80, 110, 28 voxels about the grid's centre, 85 inside and
                 170 outside with a logistic edge of 1.5 voxels, so that `dsnake field` on it solves
                 the same system as BM_GvfMultigridConverged3d.

Usage: make_volumes.py OUT_DIR
"""
import os
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


def main():
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    write_mha(os.path.join(out, "ellipsoid.mha"), ellipsoid())


if __name__ == "__main__":
    main()
