"""experiments/real/anatomy/scale_case.py: the copy's world is the case's scaled by S (voxels
kept, NIfTI transform scaled, template vertices scaled to full precision); bad input is one line
naming the file, exit code 2, nothing written."""
import os
import subprocess
import tempfile
import unittest

import nibabel as nib
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "experiments", "real", "anatomy", "scale_case.py")

OFF = """OFF
# a tetrahedron
4 4 0
0.1 0 0
2 0 0
0 3 0
0 0 4.000000000000001
3 0 2 1
3 0 1 3
3 0 3 2
3 1 2 3
"""


def make_case(folder):
    os.makedirs(folder)
    affine = np.array([[-1.0, 0, 0, 90], [0, 1, 0, -126], [0, 0, 2, -72], [0, 0, 0, 1]])
    data = np.arange(4 * 5 * 6, dtype=np.float32).reshape(4, 5, 6)
    for name in ("image.nii.gz", "truth.nii.gz"):
        nib.save(nib.Nifti1Image(data, affine), os.path.join(folder, name))
    open(os.path.join(folder, "template.off"), "w").write(OFF)
    return affine, data


class ScaleCaseTest(unittest.TestCase):
    def run_script(self, *args):
        return subprocess.run(["/usr/bin/python3", SCRIPT, *args], capture_output=True, text=True)

    def test_the_copy_is_the_case_scaled_about_the_origin(self):
        with tempfile.TemporaryDirectory() as d:
            affine, data = make_case(os.path.join(d, "c"))
            r = self.run_script("0.5", os.path.join(d, "out"), os.path.join(d, "c"))
            self.assertEqual(r.returncode, 0, r.stderr)
            for name in ("image.nii.gz", "truth.nii.gz"):
                im = nib.load(os.path.join(d, "out", "c", name))
                np.testing.assert_array_equal(np.asanyarray(im.dataobj), data)
                expected = np.diag([0.5, 0.5, 0.5, 1]) @ affine
                np.testing.assert_allclose(im.get_sform(), expected)
                np.testing.assert_allclose(im.get_qform(), expected)
                self.assertEqual(int(im.header["sform_code"]), 1)
            tokens = open(os.path.join(d, "out", "c", "template.off")).read().split()
            vertices = [float(x) for x in tokens[4:16]]
            self.assertEqual(vertices, [0.05, 0, 0, 1, 0, 0, 0, 1.5, 0, 0, 0, 0.5 * 4.000000000000001])
            self.assertEqual(tokens[16:20], ["3", "0", "2", "1"])
            self.assertFalse(os.path.exists(os.path.join(d, "out", "c", "reference.nii.gz")))

    def test_bad_input_is_one_line_naming_the_file_and_nothing_is_written(self):
        with tempfile.TemporaryDirectory() as d:
            make_case(os.path.join(d, "c"))
            open(os.path.join(d, "c", "template.off"), "w").write("OFF\n4 4 0\n0 0 0\n")
            for args, named in ((["0.5", os.path.join(d, "out"), os.path.join(d, "c")], "template.off"),
                                (["-1", os.path.join(d, "out"), os.path.join(d, "c")], "S"),
                                (["0.5", os.path.join(d, "out"), os.path.join(d, "none")], "image.nii.gz")):
                r = self.run_script(*args)
                self.assertEqual(r.returncode, 2)
                self.assertEqual(r.stderr.count("\n"), 1, r.stderr)
                self.assertIn(named, r.stderr)
                self.assertFalse(os.path.exists(os.path.join(d, "out", "c")))


if __name__ == "__main__":
    unittest.main()
