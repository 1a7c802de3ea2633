"""experiments/real/anatomy/acquire_case.py: the copy's scan is the case's scan at the same world
positions on the new grid (voxel size, turn, intensity scale), everything else copied byte for
byte; bad input is one line naming the file or option, exit code 2, nothing written."""
import math
import os
import subprocess
import tempfile
import unittest

import nibabel as nib
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "experiments", "real", "anatomy", "acquire_case.py")

AFFINE = np.array([[-1.0, 0, 0, 20], [0, 1, 0, -16], [0, 0, 1.5, -12], [0, 0, 0, 1]])


def read(path):
    with open(path, "rb") as f:
        return f.read()


def write(path, content):
    with open(path, "wb") as f:
        f.write(content)


def linear(xyz):
    """A linear function of the world position, which a cubic spline reproduces exactly."""
    return 100.0 + 2.0 * xyz[0] - 1.5 * xyz[1] + 0.5 * xyz[2]


def make_case(folder):
    os.makedirs(folder)
    ijk = np.indices((24, 30, 20), dtype=float).reshape(3, -1)
    xyz = AFFINE[:3, :3] @ ijk + AFFINE[:3, 3:4]
    data = linear(xyz).reshape(24, 30, 20).astype(np.float32)
    nib.save(nib.Nifti1Image(data, AFFINE), os.path.join(folder, "image.nii.gz"))
    nib.save(nib.Nifti1Image((data > 100).astype(np.uint8), AFFINE), os.path.join(folder, "truth.nii.gz"))
    write(os.path.join(folder, "template.off"), b"OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")


class AcquireCaseTest(unittest.TestCase):
    def run_script(self, *args):
        return subprocess.run(["/usr/bin/python3", SCRIPT, *args], capture_output=True, text=True)

    def test_the_scan_keeps_its_world_on_a_turned_finer_grid(self):
        with tempfile.TemporaryDirectory() as d:
            make_case(os.path.join(d, "c"))
            r = self.run_script(os.path.join(d, "out"), os.path.join(d, "c"), "--spacing", "0.8", "0.8", "1.2",
                                "--rotate", "20", "--gain", "10", "--offset", "-50")
            self.assertEqual(r.returncode, 0, r.stderr)
            im = nib.load(os.path.join(d, "out", "c", "image.nii.gz"))
            self.assertEqual(im.get_data_dtype(), np.int16)
            a = im.affine
            np.testing.assert_allclose(np.sqrt((a[:3, :3] ** 2).sum(axis=0)), [0.8, 0.8, 1.2], atol=1e-6)
            # Turned by 20 degrees about (1, 1, 1) / sqrt(3): the trace of the rotation is 1 + 2 cos 20.
            rotation = (a[:3, :3] / [0.8, 0.8, 1.2]) @ np.linalg.inv(AFFINE[:3, :3] / [1.0, 1.0, 1.5])
            self.assertAlmostEqual(np.trace(rotation), 1 + 2 * math.cos(math.radians(20)), places=6)
            np.testing.assert_allclose(im.get_sform(), a)
            np.testing.assert_allclose(im.get_qform(), a, atol=1e-5)
            # Well inside the old grid (two voxels from its border), a voxel holds 10 * f(x) - 50.
            data = np.asanyarray(im.dataobj).astype(float)
            ijk = np.indices(data.shape, dtype=float).reshape(3, -1)
            xyz = a[:3, :3] @ ijk + a[:3, 3:4]
            old = np.linalg.solve(AFFINE[:3, :3], xyz - AFFINE[:3, 3:4])
            inner = np.all((old >= 2) & (old <= np.array([[21], [27], [17]])), axis=0)
            self.assertGreater(inner.sum(), 1000)
            np.testing.assert_allclose(data.reshape(-1)[inner], np.rint(10 * linear(xyz[:, inner]) - 50), atol=1.0)
            for name in ("truth.nii.gz", "template.off"):
                self.assertEqual(read(os.path.join(d, "c", name)), read(os.path.join(d, "out", "c", name)), name)
            self.assertFalse(os.path.exists(os.path.join(d, "out", "c", "reference.nii.gz")))

    def test_without_options_the_scan_is_the_same(self):
        with tempfile.TemporaryDirectory() as d:
            make_case(os.path.join(d, "c"))
            r = self.run_script(os.path.join(d, "out"), os.path.join(d, "c"))
            self.assertEqual(r.returncode, 0, r.stderr)
            im = nib.load(os.path.join(d, "out", "c", "image.nii.gz"))
            np.testing.assert_allclose(im.affine, AFFINE, atol=1e-9)
            np.testing.assert_allclose(np.asanyarray(im.dataobj),
                                       np.asanyarray(nib.load(os.path.join(d, "c", "image.nii.gz")).dataobj), atol=1e-3)

    def test_the_bias_field_multiplies_the_scan_by_a_ramp_from_1_minus_b_to_1_plus_b(self):
        with tempfile.TemporaryDirectory() as d:
            make_case(os.path.join(d, "c"))
            for name, extra in (("plain", []), ("biased", ["--bias", "0.3"])):
                r = self.run_script(os.path.join(d, name), os.path.join(d, "c"), *extra)
                self.assertEqual(r.returncode, 0, r.stderr)
            plain = nib.load(os.path.join(d, "plain", "c", "image.nii.gz"))
            biased = np.asanyarray(nib.load(os.path.join(d, "biased", "c", "image.nii.gz")).dataobj)
            ratio = biased / np.asanyarray(plain.dataobj)
            self.assertAlmostEqual(float(ratio.max()), 1.3, places=4)
            self.assertAlmostEqual(float(ratio.min()), 0.7, places=4)
            # The ramp runs along (1, 2, 2) / 3 in RAS world: constant across it, linear along it.
            a = plain.affine
            step = np.linalg.solve(a[:3, :3], np.array([2.0, -1.0, 0.0]))  # a world move orthogonal to the ramp
            self.assertTrue(np.allclose(step, np.rint(step)))
            i = np.array([5, 5, 5]) + np.rint(step).astype(int)
            self.assertAlmostEqual(float(ratio[5, 5, 5]), float(ratio[tuple(i)]), places=5)

    def test_bad_input_is_one_line_naming_the_file_or_option_and_nothing_is_written(self):
        with tempfile.TemporaryDirectory() as d:
            make_case(os.path.join(d, "c"))
            out = os.path.join(d, "out")
            for args, named in (([out, os.path.join(d, "none")], "image.nii.gz"),
                                ([out, os.path.join(d, "c"), "--spacing", "1", "0", "1"], "--spacing"),
                                ([out, os.path.join(d, "c"), "--rotate", "x"], "--rotate"),
                                ([out, os.path.join(d, "c"), "--gain", "0"], "--gain"),
                                ([out, os.path.join(d, "c"), "--bias", "1"], "--bias")):
                r = self.run_script(*args)
                self.assertEqual(r.returncode, 2, args)
                self.assertEqual(r.stderr.count("\n"), 1, r.stderr)
                self.assertIn(named, r.stderr)
                self.assertFalse(os.path.exists(os.path.join(out, "c")))
            write(os.path.join(d, "c", "image.nii.gz"), b"not a nifti")
            r = self.run_script(out, os.path.join(d, "c"))
            self.assertEqual(r.returncode, 2)
            self.assertEqual(r.stderr.count("\n"), 1, r.stderr)
            self.assertIn("image.nii.gz", r.stderr)
            self.assertFalse(os.path.exists(os.path.join(out, "c")))


if __name__ == "__main__":
    unittest.main()
