#!/usr/bin/python3
"""Makes the inputs of the 2D real experiments from ITK's example data
(data/scans/itk/, fetched by scripts/fetch_scans.sh) into data/real/<case>/ (not committed).

Rat lung (RatLungSlice1/2.mha: 128 x 128 MR slices, 1 mm pixels, the left lung dark on brighter
tissue). The reference segmentation of each slice, by one procedure (the same for both slices):
  1. Gaussian smoothing, sigma 1 px;
  2. threshold: smoothed intensity < 26 (the lung's air is below ~20, the surrounding tissue
     above ~40 on this scan's 0..255 scale);
  3. the 4-connected component holding the seed (x 25, y 50) (the left lung, image left);
  4. hole filling (vessels inside the lung are brighter);
  5. morphological opening with a disk of radius 2 px (cuts the thin bridges into the airway and,
     on slice 2, along the diaphragm into the right lung), the seed's component again, holes
     filled again.
Slice 1's mask gives the template (its contour, by `dsnake template`); slice 2's mask is the
ground truth. Slice 1 is also the template's reference image (the previous slice).

Corpus callosum (BrainMidSagittalSlice.png: 217 x 180, 1 mm pixels; T1: the corpus callosum
~135, grey matter ~90-100, CSF ~45). No label exists; the reference contour, by one procedure:
  1. Gaussian smoothing, sigma 1 px;
  2. threshold: smoothed intensity > 115 (midway between the CC's ~135 and grey matter's ~95);
  3. the 4-connected component holding the seed (x 100, y 80), in the CC's body;
  4. hole filling; opening with a disk of radius 1 px (3 x 3); the seed's component again.
The template is ITK's CorpusCallosumMeanShape.mha (a signed distance map of a mean shape, 2 mm
pixels): its zero level set, as a contour (`dsnake template --mask` of the map's negative
part). The case places it (template.transform in experiments/real/cc/sweep.json) by eye, as a
user would: centred on the CC's middle and scaled by the ratio of the CC's length to the
shape's.

Usage: make_2d_inputs.py DSNAKE_BINARY [REPO_ROOT]
"""
import os
import subprocess
import sys
import zlib

import numpy as np
from scipy import ndimage as ndi


def read_mha(path):
    """Reads a 2D MetaImage (uncompressed or zlib, .raw or LOCAL) as (array[y, x], header)."""
    raw = open(path, "rb").read()
    header, pos = {}, 0
    while True:
        end = raw.index(b"\n", pos)
        line = raw[pos:end].decode()
        pos = end + 1
        key, _, value = line.partition("=")
        header[key.strip()] = value.strip()
        if key.strip() == "ElementDataFile":
            break
    types = {"MET_UCHAR": np.uint8, "MET_FLOAT": np.float32, "MET_SHORT": np.int16}
    dims = [int(v) for v in header["DimSize"].split()]
    if header["ElementDataFile"] == "LOCAL":
        data = raw[pos:]
    else:
        data = open(os.path.join(os.path.dirname(path), header["ElementDataFile"]), "rb").read()
    if header.get("CompressedData", "False") == "True":
        data = zlib.decompress(data)
    return np.frombuffer(data, dtype=types[header["ElementType"]]).reshape(dims[1], dims[0]), header


def write_mask(path, mask, spacing=(1.0, 1.0), offset=(0.0, 0.0)):
    """Writes a uint8 0/1 mask as an uncompressed 2D MetaImage (atomically)."""
    h, w = mask.shape
    head = ("ObjectType = Image\nNDims = 2\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
            f"CompressedData = False\nOffset = {offset[0]} {offset[1]}\n"
            f"ElementSpacing = {spacing[0]} {spacing[1]}\nDimSize = {w} {h}\n"
            "ElementType = MET_UCHAR\nElementDataFile = LOCAL\n")
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(head.encode())
        f.write(np.ascontiguousarray(mask, dtype=np.uint8).tobytes())
    os.replace(tmp, path)


def component(mask, seed_xy):
    """The 4-connected component of `mask` holding the seed (x, y)."""
    labels, _ = ndi.label(mask)
    lab = labels[seed_xy[1], seed_xy[0]]
    if lab == 0:
        raise SystemExit(f"make_2d_inputs: the seed {seed_xy} is outside the thresholded region")
    return labels == lab


def segment(image, below=None, above=None, seed=(0, 0), opening=None):
    """The reference procedure of the docstring: smooth, threshold, component, fill, open."""
    s = ndi.gaussian_filter(image.astype(np.float64), 1.0)
    m = s < below if below is not None else s > above
    m = ndi.binary_fill_holes(component(m, seed))
    m = ndi.binary_fill_holes(component(ndi.binary_opening(m, structure=opening), seed))
    return m.astype(np.uint8)


def disk(radius):
    """A disk of `radius` px as a structuring element."""
    y, x = np.ogrid[-radius:radius + 1, -radius:radius + 1]
    return x * x + y * y <= radius * radius


def template(dsnake, mask_path, out, vertices):
    subprocess.run([dsnake, "template", "--mask", mask_path, "--label", "1", "--vertices", str(vertices),
                    "--out", out], check=True, stdout=subprocess.DEVNULL)


def lung(dsnake, scans, out):
    for k in (1, 2):
        img, _ = read_mha(f"{scans}/RatLungSlice{k}.mha")
        write_mask(f"{out}/slice{k}_mask.mha", segment(img, below=26, seed=(25, 50), opening=disk(2)))
    template(dsnake, f"{out}/slice1_mask.mha", f"{out}/template.txt", 64)
    template(dsnake, f"{out}/slice2_mask.mha", f"{out}/truth_template.txt", 64)


def corpus_callosum(dsnake, scans, out):
    import matplotlib.image
    img = matplotlib.image.imread(f"{scans}/BrainMidSagittalSlice.png") * 255.0
    write_mask(f"{out}/reference_mask.mha", segment(img, above=115, seed=(100, 80), opening=disk(1)))
    dist, header = read_mha(f"{scans}/CorpusCallosumMeanShape.mha")
    spacing = [float(v) for v in header["ElementSpacing"].split()]
    offset = [float(v) for v in header["Offset"].split()]
    write_mask(f"{out}/mean_shape_mask.mha", (dist < 0).astype(np.uint8), spacing, offset)
    template(dsnake, f"{out}/mean_shape_mask.mha", f"{out}/template.txt", 64)
    template(dsnake, f"{out}/reference_mask.mha", f"{out}/truth_template.txt", 64)


def main():
    dsnake = os.path.abspath(sys.argv[1])
    root = sys.argv[2] if len(sys.argv) > 2 else os.path.join(os.path.dirname(__file__), "..", "..")
    scans = os.path.join(root, "data", "scans", "itk")
    for case, make in (("lung", lung), ("cc", corpus_callosum)):
        out = os.path.join(root, "data", "real", case)
        os.makedirs(out, exist_ok=True)
        make(dsnake, scans, out)
        print(f"make_2d_inputs: {out}")


if __name__ == "__main__":
    main()
