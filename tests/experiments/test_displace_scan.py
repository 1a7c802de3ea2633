"""experiments/real/anatomy/displace_scan.py: a scan and its labels placed in another world frame
keep their voxels, and their affine is the rigid map composed with theirs (so the labels move with
the scan exactly); a slab keeps its voxels' world positions; bad arguments are one line, exit
code 2, nothing written."""
import os
import subprocess
import tempfile
import unittest

import nibabel as nib
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "experiments", "real", "anatomy", "displace_scan.py")


class DisplaceScanTest(unittest.TestCase):
    def run_script(self, *args):
        return subprocess.run(["/usr/bin/python3", SCRIPT, *args], capture_output=True, text=True)

    def write(self, d, name, data, affine):
        path = os.path.join(d, name)
        nib.save(nib.Nifti1Image(data, affine), path)
        return path

    def test_voxels_kept_affine_moved_by_the_rigid_map(self):
        with tempfile.TemporaryDirectory() as d:
            data = np.arange(6 * 7 * 8, dtype=np.float32).reshape(6, 7, 8)
            affine = np.array([[1.2, 0, 0, -10], [0, 0.9, 0.1, 5], [0, 0, 1.5, 3], [0, 0, 0, 1]])
            scan = self.write(d, "scan.nii.gz", data, affine)
            label = self.write(d, "label.nii.gz", (data > 100).astype(np.uint8), affine)
            r = self.run_script(os.path.join(d, "m_"), "25", "40,30,-30", "--", scan, label)
            self.assertEqual(r.returncode, 0, r.stderr)
            moved = nib.load(os.path.join(d, "m_scan.nii.gz"))
            np.testing.assert_array_equal(np.asarray(moved.dataobj), data)
            m = moved.affine @ np.linalg.inv(affine)  # the map applied: a rotation of 25 degrees and the shift
            np.testing.assert_allclose(m[:3, 3], [40, 30, -30], atol=1e-4)
            np.testing.assert_allclose(m[:3, :3] @ m[:3, :3].T, np.eye(3), atol=1e-5)
            self.assertAlmostEqual(np.degrees(np.arccos((np.trace(m[:3, :3]) - 1) / 2)), 25.0, places=3)
            np.testing.assert_allclose(nib.load(os.path.join(d, "m_label.nii.gz")).affine, moved.affine)
            self.assertEqual(moved.header.get_sform(coded=True)[1], 1)
            self.assertEqual(moved.header.get_qform(coded=True)[1], 1)
            # a slab: voxel (i, j, k) of the slab is voxel (i, j, k + lo) of the scan, in the same world place
            r = self.run_script(os.path.join(d, "s_"), "0", "0,0,0", "2", "0.25", "0.75", "--", scan)
            self.assertEqual(r.returncode, 0, r.stderr)
            slab = nib.load(os.path.join(d, "s_scan.nii.gz"))
            self.assertEqual(slab.shape, (6, 7, 4))
            np.testing.assert_array_equal(np.asarray(slab.dataobj), data[:, :, 2:6])
            np.testing.assert_allclose(slab.affine @ [1, 2, 0, 1], affine @ [1, 2, 2, 1], atol=1e-5)

    def test_bad_arguments_are_one_line_and_write_nothing(self):
        with tempfile.TemporaryDirectory() as d:
            scan = self.write(d, "scan.nii.gz", np.zeros((3, 3, 3), np.float32), np.eye(4))
            prefix = os.path.join(d, "bad_")
            for args, words in ((["15", "1,2", "--", scan], ["SX,SY,SZ"]),
                                (["x", "1,2,3", "--", scan], ["numbers"]),
                                (["15", "1,2,3", "3", "0", "1", "--", scan], ["AXIS"]),
                                (["15", "1,2,3", "2", "0.8", "0.2", "--", scan], ["LO < HI"]),
                                (["15", "1,2,3", scan], ["usage"]),
                                (["15", "1,2,3", "--", scan, os.path.join(d, "missing.nii.gz")], ["missing.nii.gz"])):
                r = self.run_script(prefix, *args)
                self.assertEqual(r.returncode, 2, (args, r.stderr))
                lines = r.stderr.strip().splitlines()
                self.assertEqual(len(lines), 1, r.stderr)
                self.assertTrue(lines[0].startswith("displace_scan.py: "), lines[0])
                for w in words:
                    self.assertIn(w, lines[0])
                self.assertEqual([f for f in os.listdir(d) if f.startswith("bad_")], [], args)


if __name__ == "__main__":
    unittest.main()
