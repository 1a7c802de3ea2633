"""Images dsnake writes from a user's image are on that image's grid, and NIfTI files are placed as
nibabel places them, checked with nibabel and numpy alone (no reorientation):

- result_mask.nii.gz (and image.nii.gz with "output": {"image": "always"}) of a run on a phantom
  stored as NIfTI (RAS, LAS, oblique RAS, oblique LAS), MetaImage and NRRD has the input's
  dimensions and header affine (for NIfTI: the input's affine and transform codes), and its Dice
  against the ground-truth label array, voxel by voxel, is result.json's metrics.dice; the NIfTI
  that `dsnake field` and `dsnake convert` write from a NIfTI has its dimensions and affine;
- a label map and an image written as the INIA19 macaque atlas pair is (the labels with a
  zero-offset qform and the origin in the sform, the image with an sform only) land on nibabel's
  affine (through `dsnake convert` to MetaImage), and the labels warn once that their transforms
  disagree; `--nifti-transform qform` reads the qform instead.

Environment: DSNAKE_EXE (the dsnake executable)."""
import json
import math
import os
import subprocess
import tempfile
import unittest

import nibabel as nib
import numpy as np

EXE = os.environ["DSNAKE_EXE"]
LPS = np.diag([-1.0, -1.0, 1.0])  # RAS <-> LPS
SHAPE = (26, 22, 18)


def rotation(axis, angle):
    """The rotation by `angle` radians about `axis` (Rodrigues)."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def ras_affine(matrix, origin):
    a = np.eye(4)
    a[:3, :3] = matrix
    a[:3, 3] = origin
    return a


def phantom(affine):
    """An ellipsoid away from the grid's centre (so that a flipped array does not match itself)
    on the grid of `affine` (RAS): a blurred intensity image, its label array, and the centre in
    LPS mm."""
    idx = np.indices(SHAPE).reshape(3, -1).astype(float)
    centre_index = np.array([0.42, 0.55, 0.47]) * (np.array(SHAPE) - 1)
    world = affine[:3, :3] @ idx + affine[:3, 3:4]
    centre = affine[:3, :3] @ centre_index + affine[:3, 3]
    # semi-axes in the image's own index frame (mm), so the shape follows the grid's rotation
    axes_mm = np.array([7.0, 6.0, 5.5])
    unit = affine[:3, :3] / np.linalg.norm(affine[:3, :3], axis=0)
    local = unit.T @ (world - centre[:, None])
    r = np.sqrt(((local / axes_mm[:, None]) ** 2).sum(axis=0))
    image = (100.0 / (1.0 + np.exp((r - 1.0) * 8.0))).reshape(SHAPE).astype(np.float32)
    labels = (r <= 1.0).reshape(SHAPE).astype(np.uint8)
    return image, labels, LPS @ centre


def experiment(image_file, mask_file, centre_lps, extra=None):
    spec = {
        "dimension": 3,
        "name": "grid",
        "image": {"file": image_file},
        "template": {"phantom": "sphere", "radius": 8.0, "subdivisions": 2, "center": list(centre_lps)},
        "ground_truth": {"mask": mask_file},
        "field": {"type": "gradient", "sigma": 1.0, "region": {"extent": "whole"}},
        "energies": [{"type": "internal", "alpha": 0.1, "beta": 0.0},
                     {"type": "external", "tau": 2.0}],
        "phases": [{"iterations": 60, "tolerance": 0.001}],
        "output": {"figures": False},
    }
    spec.update(extra or {})
    return spec


def run(*args):
    p = subprocess.run([EXE, *args], capture_output=True, text=True, timeout=120)
    if p.returncode != 0:
        raise AssertionError("dsnake %s failed (%d): %s" % (" ".join(args), p.returncode, p.stderr))
    return p


def dice(a, b):
    a, b = a != 0, b != 0
    return 2.0 * np.logical_and(a, b).sum() / (a.sum() + b.sum())


def write_mha(path, array, lps_matrix, origin, element_type):
    spacing = np.linalg.norm(lps_matrix, axis=0)
    direction = lps_matrix / spacing
    # MetaIO's TransformMatrix: value [a * 3 + k] is world component k of index axis a
    header = ("ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
              "TransformMatrix = %s\nOffset = %s\nElementSpacing = %s\nDimSize = %d %d %d\n"
              "ElementType = %s\nElementDataFile = LOCAL\n") % (
        " ".join("%.17g" % v for v in direction.T.ravel()), " ".join("%.17g" % v for v in origin),
        " ".join("%.17g" % v for v in spacing), *array.shape, element_type)
    with open(path, "wb") as f:
        f.write(header.encode() + np.asfortranarray(array).tobytes(order="F"))


def write_nrrd(path, array, lps_matrix, origin, nrrd_type):
    vec = lambda v: "(%s)" % ",".join("%.17g" % x for x in v)
    header = ("NRRD0004\ntype: %s\ndimension: 3\nspace: left-posterior-superior\nsizes: %d %d %d\n"
              "space directions: %s %s %s\nkinds: domain domain domain\nendian: little\nencoding: raw\n"
              "space origin: %s\n\n") % (nrrd_type, *array.shape, vec(lps_matrix[:, 0]), vec(lps_matrix[:, 1]),
                                          vec(lps_matrix[:, 2]), vec(origin))
    with open(path, "wb") as f:
        f.write(header.encode() + np.asfortranarray(array).tobytes(order="F"))


class ResultMaskGridTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def run_case(self, name, image_file, mask_file, centre, extra=None):
        exp = os.path.join(self.dir, name + ".json")
        with open(exp, "w") as f:
            json.dump(experiment(image_file, mask_file, centre, extra), f)
        out = os.path.join(self.dir, "out_" + name)
        run("run", exp, "--out", out, "--quiet", "-j", "1")
        with open(os.path.join(out, "result.json")) as f:
            result = json.load(f)
        return out, result

    def check_mask(self, name, out, result, labels, affine):
        mask = nib.load(os.path.join(out, "result_mask.nii.gz"))
        self.assertEqual(mask.shape, labels.shape, name)
        self.assertEqual(mask.get_data_dtype(), np.uint8, name)
        np.testing.assert_allclose(mask.affine, affine, atol=1e-4, err_msg=name)
        ours = dice(np.asarray(mask.dataobj), labels)
        theirs = result["metrics"]["dice"]
        self.assertGreater(theirs, 0.5, name + ": the run registered")
        self.assertAlmostEqual(ours, theirs, delta=1e-3, msg=name)
        return mask

    def test_nifti_inputs(self):
        spacing = np.diag([1.0, 1.25, 1.5])
        cases = {
            "ras": ras_affine(spacing, [10, -20, 5]),
            "las": ras_affine(np.diag([-1.0, 1.0, 1.0]) @ spacing, [30, -20, 5]),
            "ras_oblique": ras_affine(rotation([1, 2, 3], 0.35) @ spacing, [10, -20, 5]),
            "las_oblique": ras_affine(rotation([0, 1, 1], 0.3) @ np.diag([-1.0, 1.0, 1.0]) @ spacing, [30, -20, 5]),
        }
        for name, affine in cases.items():
            with self.subTest(name):
                image, labels, centre = phantom(affine)
                img = nib.Nifti1Image(image, affine)
                img.set_sform(affine, code=2)
                img.set_qform(affine, code=1)
                lab = nib.Nifti1Image(labels, affine)
                lab.set_sform(affine, code=2)
                lab.set_qform(affine, code=1)
                nib.save(img, os.path.join(self.dir, name + ".nii.gz"))
                nib.save(lab, os.path.join(self.dir, name + "_truth.nii.gz"))
                extra = {"output": {"figures": False, "image": "always"}} if name == "las" else None
                out, result = self.run_case(name, name + ".nii.gz", name + "_truth.nii.gz", centre, extra)
                source = nib.load(os.path.join(self.dir, name + ".nii.gz"))
                mask = self.check_mask(name, out, result, labels, source.affine)
                self.assertTrue(np.array_equal(mask.affine, source.affine), name)
                for key in ("qform_code", "sform_code"):
                    self.assertEqual(int(mask.header[key]), int(source.header[key]), name + " " + key)
                np.testing.assert_array_equal(mask.header.get_qform(), source.header.get_qform())
                # `dsnake field` and `dsnake convert` write on the input's grid too.
                field = os.path.join(self.dir, name + "_field.nii.gz")
                run("field", "--image", os.path.join(self.dir, name + ".nii.gz"), "--type", "gradient", "--out", field)
                converted = os.path.join(self.dir, name + "_converted.nii.gz")
                run("convert", os.path.join(self.dir, name + ".nii.gz"), converted)
                for path in (field, converted):
                    written = nib.load(path)
                    self.assertEqual(written.shape[:3], labels.shape, path)
                    np.testing.assert_allclose(written.affine, source.affine, atol=1e-4, err_msg=path)
                np.testing.assert_array_equal(np.asarray(nib.load(converted).dataobj), image)
                if extra:  # image.nii.gz: the input's voxels in the input's order
                    written = nib.load(os.path.join(out, "image.nii.gz"))
                    self.assertTrue(np.array_equal(written.affine, source.affine))
                    np.testing.assert_array_equal(np.asarray(written.dataobj), image)

    def test_metaimage_and_nrrd_inputs(self):
        # LPS matrices (columns: index axes times spacing): a flip and a permutation of the axes
        # for MetaImage, a rotation about z for NRRD.
        mha = np.array([[-1.0, 0, 0], [0, 0, 1.5], [0, 1.25, 0]])
        nrrd = rotation([0, 0, 1], 0.4) @ np.diag([1.0, 1.25, 1.5])
        for name, lps, origin in (("mha", mha, np.array([20.0, 4.0, -7.0])),
                                  ("nrrd", nrrd, np.array([-3.0, 8.0, 2.0]))):
            with self.subTest(name):
                affine = ras_affine(LPS @ lps, LPS @ origin)  # the RAS affine nibabel should read
                image, labels, centre = phantom(affine)
                if name == "mha":
                    write_mha(os.path.join(self.dir, "in.mha"), image, lps, origin, "MET_FLOAT")
                    write_mha(os.path.join(self.dir, "truth.mha"), labels, lps, origin, "MET_UCHAR")
                else:
                    write_nrrd(os.path.join(self.dir, "in.nrrd"), image, lps, origin, "float")
                    write_nrrd(os.path.join(self.dir, "truth.nrrd"), labels, lps, origin, "uchar")
                ext = "." + name
                out, result = self.run_case(name, "in" + ext, "truth" + ext, centre)
                self.check_mask(name, out, result, labels, affine)


def atlas_pair(directory):
    """A label map and an image laid out as the INIA19 pair: 0.5 mm voxels; the labels' qform
    (code 1) without offset and their sform (code 2) with the origin (-42, -57.5, -30); the image
    with an sform only. Label 7 is a box off the grid's centre."""
    shape = (24, 28, 20)
    affine = ras_affine(np.diag([0.5, 0.5, 0.5]), [-42.0, -57.5, -30.0])
    labels = np.zeros(shape, np.uint8)
    labels[3:9, 15:22, 4:10] = 7
    lab = nib.Nifti1Image(labels, affine)
    lab.set_sform(affine, code=2)
    lab.set_qform(ras_affine(np.diag([0.5, 0.5, 0.5]), [0, 0, 0]), code=1)
    image = (np.arange(np.prod(shape)) % 251).reshape(shape).astype(np.float32)
    img = nib.Nifti1Image(image, affine)
    img.set_sform(affine, code=2)
    img.set_qform(None, code=0)
    paths = os.path.join(directory, "labels.nii.gz"), os.path.join(directory, "t1.nii.gz")
    nib.save(lab, paths[0])
    nib.save(img, paths[1])
    return paths


def mha_grid(path):
    """The LPS affine of a MetaImage file dsnake wrote, and its voxels (x fastest)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"ElementDataFile = LOCAL\n") + len(b"ElementDataFile = LOCAL\n")
    fields = dict(line.split(" = ", 1) for line in data[:end].decode().splitlines())
    size = [int(v) for v in fields["DimSize"].split()]
    spacing = np.array([float(v) for v in fields["ElementSpacing"].split()])
    direction = np.array([float(v) for v in fields["TransformMatrix"].split()]).reshape(3, 3).T
    origin = np.array([float(v) for v in fields["Offset"].split()])
    voxels = np.frombuffer(data[end:], np.float32).reshape(size, order="F")
    return ras_affine(direction * spacing, origin), voxels


class NiftiAsNibabelReadsItTest(unittest.TestCase):
    def expect_voxels_at(self, path, affine, *options):
        """`dsnake convert PATH x.mha OPTIONS` puts every voxel of PATH at the world position
        `affine` (RAS) gives it, to 1e-4 mm, with its value. Returns dsnake's stderr."""
        out = os.path.join(os.path.dirname(path), "as_read.mha")
        p = run("convert", path, out, *options)
        lps_affine, voxels = mha_grid(out)
        source = nib.load(path)
        idx = np.indices(source.shape).reshape(3, -1)  # C order
        world = LPS @ (affine[:3, :3] @ idx + affine[:3, 3:4])
        cont = np.linalg.solve(lps_affine[:3, :3], world - lps_affine[:3, 3:4])
        whole = np.rint(cont)
        self.assertLess(np.abs(cont - whole).max() * 0.5, 1e-4)  # mm: 0.5 mm voxels
        w = whole.astype(int)
        np.testing.assert_array_equal(voxels[w[0], w[1], w[2]], np.asarray(source.dataobj).reshape(-1))
        return p.stderr

    def test_atlas_pair_lands_on_nibabels_affine(self):
        with tempfile.TemporaryDirectory() as d:
            labels_path, image_path = atlas_pair(d)
            err = self.expect_voxels_at(labels_path, nib.load(labels_path).affine)
            lines = err.splitlines()
            self.assertEqual(len(lines), 1, err)
            self.assertTrue(lines[0].startswith("dsnake: warning: %s: sform and qform disagree by 77.3 mm / 0 degrees; "
                                                "using the sform (image.nifti_transform" % labels_path), lines[0])
            self.assertEqual(self.expect_voxels_at(image_path, nib.load(image_path).affine), "")

            # --nifti-transform qform: the labels at the qform's zero offset, no warning.
            qform = nib.load(labels_path).header.get_qform()
            np.testing.assert_array_equal(qform[:3, 3], [0, 0, 0])
            self.assertEqual(self.expect_voxels_at(labels_path, qform, "--nifti-transform", "qform"), "")

            # `dsnake template` places its template on the structure nibabel sees.
            tmpl = os.path.join(d, "t.off")
            p = run("template", "--mask", labels_path, "--label", "7", "--vertices", "100", "--out", tmpl)
            self.assertIn("sform and qform disagree", p.stderr)
            with open(tmpl) as f:
                f.readline()
                nv = int(f.readline().split()[0])
                points = np.array([[float(x) for x in f.readline().split()] for _ in range(nv)])
            box = np.array([[3, 8], [15, 21], [4, 9]], float)
            lo = LPS @ (0.5 * box[:, 0] + [-42.0, -57.5, -30.0])
            hi = LPS @ (0.5 * box[:, 1] + [-42.0, -57.5, -30.0])
            np.testing.assert_allclose(points.mean(axis=0), (lo + hi) / 2, atol=0.5)


if __name__ == "__main__":
    unittest.main()
