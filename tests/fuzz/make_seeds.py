#!/usr/bin/env python3
"""Writes the fuzz targets' seed corpus (tests/fuzz/corpus/<target>/seed_*): small valid files
of every format and variant each reader takes, so that the fuzzer starts from inside the
formats. Run from anywhere; the files are committed, beside the inputs that once found a bug
(corpus/<target>/crash_*), which this script leaves alone. Needs only Python's standard library
(the image seeds are written by hand, byte by byte, after each format's specification).
"""
import gzip
import json
import pathlib
import shutil
import struct
import zlib

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent.parent
CORPUS = HERE / "corpus"

# A 4 x 3 x 2 volume (x fastest) and a 4 x 3 image, float32 and uint8.
NX, NY, NZ = 4, 3, 2
VOLUME = [float((x + 2 * y + 3 * z) % 7) for z in range(NZ) for y in range(NY) for x in range(NX)]
IMAGE = VOLUME[: NX * NY]


def f32(values):
    return struct.pack("<%df" % len(values), *values)


def u8(values):
    return bytes(int(v) * 30 for v in values)


def put(target, name, data):
    folder = CORPUS / target
    folder.mkdir(parents=True, exist_ok=True)
    (folder / ("seed_" + name)).write_bytes(data if isinstance(data, bytes) else data.encode())


def metaimage():
    def header(dims, element, extra=""):
        return ("ObjectType = Image\nNDims = %d\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
                "ElementSpacing = %s\nOffset = %s\nDimSize = %s\n%sElementType = %s\nElementDataFile = LOCAL\n"
                % (len(dims), " ".join(["0.5"] * len(dims)), " ".join(["1"] * len(dims)),
                   " ".join(map(str, dims)), extra, element)).encode()
    put("metaimage", "volume_float.mha", header((NX, NY, NZ), "MET_FLOAT") + f32(VOLUME))
    put("metaimage", "image_uchar.mha", header((NX, NY), "MET_UCHAR") + u8(IMAGE))
    packed = zlib.compress(f32(VOLUME))
    put("metaimage", "volume_zlib.mha",
        header((NX, NY, NZ), "MET_FLOAT", "CompressedData = True\nCompressedDataSize = %d\n" % len(packed)) + packed)
    put("metaimage", "volume_ulong_long.mha", header((NX, NY, NZ), "MET_ULONG_LONG")
        + struct.pack("<%dQ" % len(VOLUME), *(int(v) << 40 for v in VOLUME)))
    put("metaimage", "volume_rotated.mha",
        header((NX, NY, NZ), "MET_SHORT", "TransformMatrix = 0 1 0 -1 0 0 0 0 1\nAnatomicalOrientation = RAI\n")
        + struct.pack("<%dh" % len(VOLUME), *map(int, VOLUME)))


def nifti_bytes(dims, datatype, bitpix, data, qform=True, magic=b"n+1\0"):
    h = bytearray(352)
    struct.pack_into("<i", h, 0, 348)
    dim = [len(dims)] + list(dims) + [1] * (7 - len(dims))
    struct.pack_into("<8h", h, 40, *dim)
    struct.pack_into("<hh", h, 70, datatype, bitpix)
    struct.pack_into("<8f", h, 76, 1.0, *([0.5] * 7))   # pixdim (qfac 1)
    struct.pack_into("<f", h, 108, 352.0)                 # vox_offset
    struct.pack_into("<ff", h, 112, 1.0, 0.0)             # scl_slope, scl_inter
    struct.pack_into("<B", h, 123, 2)                     # xyzt_units: mm
    if qform:
        struct.pack_into("<hh", h, 252, 1, 0)             # qform_code scanner, sform_code 0
        struct.pack_into("<6f", h, 256, 0.0, 0.0, 1.0, 10.0, -5.0, 2.0)  # flipped-axis quaternion + offset
    h[344:348] = magic
    return bytes(h) + data


def nifti2_bytes(dims, datatype, bitpix, data, big_endian=False, magic=b"n+2\0"):
    """A single-file NIfTI-2 (the NIfTI-2 spec: 540-byte header, 64-bit dims, double fields)."""
    e = ">" if big_endian else "<"
    h = bytearray(544)
    struct.pack_into(e + "i", h, 0, 540)
    h[4:12] = magic + b"\r\n\032\n"
    struct.pack_into(e + "hh", h, 12, datatype, bitpix)
    dim = [len(dims)] + list(dims) + [1] * (7 - len(dims))
    struct.pack_into(e + "8q", h, 16, *dim)
    struct.pack_into(e + "8d", h, 104, -1.0, *([0.5] * 7))  # pixdim (qfac -1)
    struct.pack_into(e + "q", h, 168, 544)                   # vox_offset
    struct.pack_into(e + "dd", h, 176, 1.0, 0.0)             # scl_slope, scl_inter
    struct.pack_into(e + "ii", h, 344, 1, 1)                 # qform_code, sform_code: scanner
    struct.pack_into(e + "6d", h, 352, 0.0, 0.0, 1.0, 10.0, -5.0, 2.0)  # flipped-axis quaternion + offset
    struct.pack_into(e + "12d", h, 400, -0.5, 0.0, 0.0, 10.0, 0.0, -0.5, 0.0, -5.0, 0.0, 0.0, -0.5, 2.0)  # srow: the qform's placement
    struct.pack_into(e + "i", h, 500, 2)                     # xyzt_units: mm
    return bytes(h) + data


def nifti():
    put("nifti", "volume_float.nii", nifti_bytes((NX, NY, NZ), 16, 32, f32(VOLUME)))
    put("nifti", "image_uint8.nii", nifti_bytes((NX, NY), 2, 8, u8(IMAGE), qform=False))
    put("nifti", "volume_int16.nii",
        nifti_bytes((NX, NY, NZ), 4, 16, struct.pack("<%dh" % len(VOLUME), *map(int, VOLUME))))
    put("nifti", "volume_float.nii.gz", gzip.compress(nifti_bytes((NX, NY, NZ), 16, 32, f32(VOLUME)), mtime=0))
    put("nifti", "volume_int64.nii",
        nifti_bytes((NX, NY, NZ), 1024, 64, struct.pack("<%dq" % len(VOLUME), *(int(v) << 33 for v in VOLUME))))
    put("nifti", "volume_float_nifti2.nii", nifti2_bytes((NX, NY, NZ), 16, 32, f32(VOLUME)))
    put("nifti", "volume_uint64_nifti2_big_endian.nii",
        nifti2_bytes((NX, NY, NZ), 1280, 64, struct.pack(">%dQ" % len(VOLUME), *map(int, VOLUME)), big_endian=True))
    put("nifti", "image_uint8_nifti2.nii.gz", gzip.compress(nifti2_bytes((NX, NY), 2, 8, u8(IMAGE)), mtime=0))
    # Pairs (fuzz_nifti reads every input as a .hdr and as its .img too): a pair's magic, the
    # values at vox_offset in the same bytes.
    put("nifti", "pair_volume_float", nifti_bytes((NX, NY, NZ), 16, 32, f32(VOLUME), magic=b"ni1\0"))
    put("nifti", "pair_volume_float_nifti2.gz",
        gzip.compress(nifti2_bytes((NX, NY, NZ), 16, 32, f32(VOLUME), magic=b"ni2\0"), mtime=0))


def nrrd():
    def header(dims, type_, encoding, extra=""):
        return ("NRRD0004\ntype: %s\ndimension: %d\nsizes: %s\nendian: little\nencoding: %s\n%s\n"
                % (type_, len(dims), " ".join(map(str, dims)), encoding, extra)).encode()
    space = ("space: left-posterior-superior\nspace directions: (0.5,0,0) (0,0.5,0) (0,0,1)\n"
             "space origin: (1,2,3)\n")
    put("nrrd", "volume_raw.nrrd", header((NX, NY, NZ), "float", "raw", space) + f32(VOLUME))
    put("nrrd", "volume_gzip.nrrd", header((NX, NY, NZ), "float", "gzip", space) + gzip.compress(f32(VOLUME), mtime=0))
    put("nrrd", "image_ascii.nrrd", header((NX, NY), "uchar", "ascii", "spacings: 0.5 0.5\n")
        + " ".join(str(int(v)) for v in IMAGE).encode() + b"\n")
    put("nrrd", "volume_int64.nrrd", header((NX, NY, NZ), "long long", "raw", space)
        + struct.pack("<%dq" % len(VOLUME), *(int(v) << 33 for v in VOLUME)))
    put("nrrd", "volume_ras.nrrd",
        header((NX, NY, NZ), "short", "raw", "space: right-anterior-superior\nspace directions: (-1,0,0) (0,1,0) (0,0,2)\n")
        + struct.pack("<%dh" % len(VOLUME), *map(int, VOLUME)))


def inr():
    def file(dims, type_, pixsize, data):
        text = ("#INRIMAGE-4#{\nXDIM=%d\nYDIM=%d\nZDIM=%d\nVDIM=1\nVX=0.5\nVY=0.5\nVZ=1\nTYPE=%s\nPIXSIZE=%d bits\nCPU=decm\n"
                % (dims[0], dims[1], dims[2], type_, pixsize))
        text += "\n" * (252 - len(text)) + "##}\n"
        return text.encode() + data
    put("inr", "volume_float.inr", file((NX, NY, NZ), "float", 32, f32(VOLUME)))
    put("inr", "image_uchar.inr", file((NX, NY, 1), "unsigned fixed", 8, u8(IMAGE)))
    put("inr", "volume_float.inr.gz", gzip.compress(file((NX, NY, NZ), "float", 32, f32(VOLUME)), mtime=0))


def png(width, height, pixels):
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)
    rows = b"".join(b"\0" + bytes(pixels[y * width:(y + 1) * width]) for y in range(height))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def bmp(width, height, pixels):
    row = (width * 3 + 3) // 4 * 4
    data = b"".join(b"".join(bytes([p, p, p]) for p in pixels[y * width:(y + 1) * width]).ljust(row, b"\0")
                    for y in reversed(range(height)))
    return (b"BM" + struct.pack("<IHHI", 54 + len(data), 0, 0, 54)
            + struct.pack("<IiiHHIIiiII", 40, width, height, 1, 24, 0, len(data), 2835, 2835, 0, 0) + data)


def raster():
    pixels = [int(v) * 30 for v in IMAGE]
    put("raster", "image.png", png(NX, NY, pixels))
    put("raster", "image.bmp", bmp(NX, NY, pixels))


def contours():
    square = [(0, 0), (4, 0), (4, 3), (0, 3)]
    put("contour", "square.txt", "# a square\n" + "".join("%g %g\n" % p for p in square))
    put("contour", "square.json", json.dumps({"points": square, "landmarks": {"corner": 2}}))
    put("contour", "square.vtk",
        "# vtk DataFile Version 3.0\nsquare\nASCII\nDATASET POLYDATA\nPOINTS 4 double\n"
        + "".join("%g %g 0\n" % p for p in square) + "LINES 1 6\n5 0 1 2 3 0\n"
        + "POINT_DATA 4\nSCALARS template_id int 1\nLOOKUP_TABLE default\n0 1 2 3\n")


OCTA_V = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
OCTA_F = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]


def meshes():
    put("mesh", "octahedron.off", "OFF\n6 8 0\n" + "".join("%g %g %g\n" % v for v in OCTA_V)
        + "".join("3 %d %d %d\n" % f for f in OCTA_F))
    put("mesh", "octahedron.obj", "# octahedron\n" + "".join("v %g %g %g\n" % v for v in OCTA_V)
        + "".join("f %d %d %d\n" % tuple(i + 1 for i in f) for f in OCTA_F))
    put("mesh", "octahedron_ascii.ply",
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
        "element face 8\nproperty list uchar int vertex_indices\nend_header\n"
        + "".join("%g %g %g\n" % v for v in OCTA_V) + "".join("3 %d %d %d\n" % f for f in OCTA_F))
    put("mesh", "octahedron_binary.ply",
        b"ply\nformat binary_little_endian 1.0\nelement vertex 6\nproperty float x\nproperty float y\n"
        b"property float z\nelement face 8\nproperty list uchar int vertex_indices\nend_header\n"
        + b"".join(struct.pack("<3f", *v) for v in OCTA_V) + b"".join(struct.pack("<B3i", 3, *f) for f in OCTA_F))

    def normal(f):
        return (0.0, 0.0, 0.0)
    put("mesh", "octahedron_ascii.stl", "solid octa\n" + "".join(
        "facet normal 0 0 0\nouter loop\n" + "".join("vertex %g %g %g\n" % OCTA_V[i] for i in f) + "endloop\nendfacet\n"
        for f in OCTA_F) + "endsolid octa\n")
    put("mesh", "octahedron_binary.stl", b"binary octahedron".ljust(80, b" ") + struct.pack("<I", len(OCTA_F)) + b"".join(
        struct.pack("<3f", *normal(f)) + b"".join(struct.pack("<3f", *OCTA_V[i]) for i in f) + b"\0\0" for f in OCTA_F))
    put("mesh", "octahedron.vtk",
        "# vtk DataFile Version 3.0\noctahedron\nASCII\nDATASET POLYDATA\nPOINTS 6 double\n"
        + "".join("%g %g %g\n" % v for v in OCTA_V) + "POLYGONS 8 32\n" + "".join("3 %d %d %d\n" % f for f in OCTA_F))


def experiment_files():
    sources = ["experiments/paper/three_points_dsnake.json", "experiments/paper/star_gvf_snake.json",
               "experiments/paper/lung_slice_dsnake.json", "experiments/examples/dsnake_sphere_to_ellipsoid.json",
               "experiments/real/paper_3d.json", "experiments/ablation/global/tetris.json",
               "experiments/real/recipe_2d.json", "experiments/real/recipe_2d_with_atlas.json",
               "experiments/real/recipe_2d_without_atlas.json",
               "experiments/real/recipe_3d.json"]
    for s in sources:
        put("experiment_file", pathlib.Path(s).name, (ROOT / s).read_bytes())
    for s in ["experiments/paper/star_robustness.json", "experiments/real/liver/sweep.json",
              "experiments/ablation/star/energies_fields.json"]:
        put("sweep_file", s.replace("experiments/", "").replace("/", "_"), (ROOT / s).read_bytes())
    put("set_path", "energies.txt", "energies[0].alpha=0.3\nphases[0].iterations=5")
    put("set_path", "keys.txt", "output.figures=false\nseed=7\nwatchdog.max_move=2.5")
    put("set_path", "field.txt", 'field={"type": "gvf", "mu": 0.2}\ntemplate.transform.scale=1.5')
    put("set_path", "dimension.txt", "dimension=3\nimage.phantom=\"ellipsoid\"")


if __name__ == "__main__":
    for f in CORPUS.glob("*/seed_*"):
        f.unlink()
    metaimage(); nifti(); nrrd(); inr(); raster(); contours(); meshes(); experiment_files()
    print("seeds:", sum(1 for _ in CORPUS.glob("*/seed_*")), "files in", CORPUS)
