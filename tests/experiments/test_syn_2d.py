"""experiments/real/syn.py in 2D (a .txt contour on 2D NIfTI images): dipy's SyN registers a disk
moved 3 mm and scaled 1.1 onto its truth, its warped mask's Dice and the template's carried
vertices measured by dsnake as in 3D."""
import json
import os
import subprocess
import tempfile
import unittest

import nibabel as nib
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.realpath(os.path.join(HERE, "..", ".."))
SCRIPT = os.path.join(ROOT, "experiments", "real", "syn.py")


class Syn2dTest(unittest.TestCase):
    def test_a_moved_disk_is_registered(self):
        exe = os.environ.get("DSNAKE_EXE", os.path.join(ROOT, "build", "release", "experiments", "dsnake"))
        with tempfile.TemporaryDirectory() as d:
            affine = np.diag([0.5, 0.5, 1.0, 1.0])
            affine[:3, 3] = [-30, -30, 4]  # RAS; a slice at z = 4
            ij = np.stack(np.meshgrid(np.arange(120), np.arange(120), indexing="ij"), -1) * 0.5 - 30
            def disk(cx, cy, r):  # RAS centre
                return np.hypot(ij[..., 0] - cx, ij[..., 1] - cy) <= r
            moving, fixed = disk(-2, 1, 10), disk(1, 1, 11)
            for name, m in (("moving", moving), ("fixed", fixed)):
                img = np.where(m, 100.0, 20.0).astype(np.float32)
                nib.save(nib.Nifti1Image(img, affine), os.path.join(d, f"{name}.nii.gz"))
            nib.save(nib.Nifti1Image(fixed.astype(np.uint8), affine), os.path.join(d, "truth.nii.gz"))
            t = 2 * np.pi * np.arange(32) / 32  # the template on the moving disk, LPS
            np.savetxt(os.path.join(d, "template.txt"), np.c_[2 + 10 * np.cos(t), -1 + 10 * np.sin(t)])
            out = os.path.join(d, "syn")
            r = subprocess.run(["/usr/bin/python3", SCRIPT, *(os.path.join(d, f) for f in
                                ("fixed.nii.gz", "moving.nii.gz", "template.txt", "truth.nii.gz")), out],
                               capture_output=True, text=True, env=dict(os.environ, DSNAKE=exe, THREADS="1",
                                                                        VERTICES="64"))
            self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
            s = json.load(open(os.path.join(out, "summary.json")))
            self.assertGreater(s["metrics"]["dice"], 0.97)
            self.assertGreater(s["carried_template_metrics"]["dice"], 0.95)
            carried = np.loadtxt(os.path.join(out, "syn_points.txt"))
            # the carried vertices on the fixed disk: radius 11 about (-1, -1) LPS
            np.testing.assert_allclose(np.hypot(carried[:, 0] + 1, carried[:, 1] + 1), 11, atol=0.6)


if __name__ == "__main__":
    unittest.main()
