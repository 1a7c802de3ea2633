"""experiments/real/anatomy/make_slice_case.py: on a ball (a label, an image, a sphere mesh), the
slice is the one where the label is largest, the images are that slice with its world position,
and the template is the sphere's cut there: a circle of the ball's radius at that height, vertices
2 mm apart, counter-clockwise; a coronal slice takes the world's z as its second axis; bad
arguments are one line, exit code 2, nothing written."""
import os
import subprocess
import tempfile
import unittest

import nibabel as nib
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "experiments", "real", "anatomy", "make_slice_case.py")


def sphere_off(path, centre, r, n=24):
    """A UV sphere (LPS mm): n rings of 2n vertices and the poles."""
    v = [centre + [0, 0, -r]]
    for i in range(1, n):
        t = np.pi * i / n
        for j in range(2 * n):
            p = 2 * np.pi * j / (2 * n)
            v.append(centre + r * np.array([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), -np.cos(t)]))
    v.append(centre + [0, 0, r])
    f, m = [], 2 * n
    for j in range(m):
        f.append([0, 1 + (j + 1) % m, 1 + j])
    for i in range(n - 2):
        for j in range(m):
            a, b = 1 + i * m + j, 1 + i * m + (j + 1) % m
            f += [[a, b, b + m], [a, b + m, a + m]]
    top = len(v) - 1
    for j in range(m):
        f.append([top, 1 + (n - 2) * m + j, 1 + (n - 2) * m + (j + 1) % m])
    with open(path, "w") as out:
        out.write(f"OFF\n{len(v)} {len(f)} 0\n")
        out.writelines(f"{x[0]} {x[1]} {x[2]}\n" for x in v)
        out.writelines(f"3 {a} {b} {c}\n" for a, b, c in f)


class MakeSliceCaseTest(unittest.TestCase):
    def run_script(self, *args):
        return subprocess.run(["/usr/bin/python3", SCRIPT, *args], capture_output=True, text=True)

    def make_case(self, d):
        # 1 mm voxels, RAS affine; the ball's centre (world RAS) (2, -3, 10.2), radius 8 mm
        affine = np.array([[1.0, 0, 0, -20], [0, 1, 0, -25], [0, 0, 1, -5], [0, 0, 0, 1]])
        ijk = np.stack(np.meshgrid(np.arange(40), np.arange(44), np.arange(30), indexing="ij"), -1)
        world = ijk @ affine[:3, :3].T + affine[:3, 3]
        centre_ras = np.array([2.0, -3.0, 10.2])
        inside = np.linalg.norm(world - centre_ras, axis=-1) <= 8
        image = (50 + 100 * inside + world[..., 0]).astype(np.float32)
        for name, data in (("image.nii.gz", image), ("reference.nii.gz", image + 1),
                           ("truth.nii.gz", inside.astype(np.uint8))):
            nib.save(nib.Nifti1Image(data, affine), os.path.join(d, name))
        sphere_off(os.path.join(d, "template.off"), centre_ras * [-1, -1, 1], 8.0)  # LPS
        return affine, image, inside

    def test_the_largest_slice_and_the_sphere_cut_there(self):
        with tempfile.TemporaryDirectory() as d:
            affine, image, inside = self.make_case(d)
            out = os.path.join(d, "out")
            r = self.run_script(d, out)
            self.assertEqual(r.returncode, 0, r.stderr)
            k = int(np.argmax(inside.sum(axis=(0, 1))))
            z = -5 + k  # the slice's world z
            self.assertLessEqual(abs(z - 10.2), 1.5)
            im = nib.load(os.path.join(out, "image.nii.gz"))
            np.testing.assert_array_equal(np.asarray(im.dataobj), image[:, :, k])
            np.testing.assert_allclose(im.affine @ [3, 4, 0, 1], affine @ [3, 4, k, 1])
            np.testing.assert_array_equal(np.asarray(nib.load(os.path.join(out, "truth.nii.gz")).dataobj),
                                          inside[:, :, k].astype(np.uint8))
            c = np.loadtxt(os.path.join(out, "template.txt"))
            # the cut of the sphere at z: a circle about the centre's LPS x, y (-2, 3), within the UV
            # sphere's chords
            rz = np.sqrt(64 - (z - 10.2) ** 2)
            radius = np.linalg.norm(c - [-2, 3], axis=1)
            np.testing.assert_allclose(radius, rz, atol=0.25)
            steps = np.linalg.norm(np.diff(np.vstack([c, c[:1]]), axis=0), axis=1)
            self.assertLessEqual(abs(len(c) - 2 * np.pi * rz / 2), 1)
            np.testing.assert_allclose(steps, 2 * np.pi * rz / len(c), rtol=0.05)
            area = 0.5 * np.sum(c[:, 0] * np.roll(c[:, 1], -1) - np.roll(c[:, 0], -1) * c[:, 1])
            self.assertGreater(area, 0)

    def test_a_coronal_slice_has_the_world_z_as_its_second_axis(self):
        with tempfile.TemporaryDirectory() as d:
            affine, image, inside = self.make_case(d)
            out = os.path.join(d, "out")
            r = self.run_script(d, out, "--axis", "y")
            self.assertEqual(r.returncode, 0, r.stderr)
            k = int(np.argmax(inside.sum(axis=(0, 2))))
            y = -25 + k  # the slice's world (RAS) y
            self.assertLessEqual(abs(y + 3), 1.5)
            im = nib.load(os.path.join(out, "image.nii.gz"))
            np.testing.assert_array_equal(np.asarray(im.dataobj), image[:, k, :])
            # pixel (i, j): RAS x = -20 + i, z = -5 + j, the 2D image's x and y
            np.testing.assert_allclose(im.affine @ [3, 4, 0, 1], [-17, -1, y, 1])
            c = np.loadtxt(os.path.join(out, "template.txt"))
            # the 2D points are LPS x and -z: the ball's centre (-2, -10.2) there
            ry = np.sqrt(64 - (y + 3) ** 2)
            np.testing.assert_allclose(np.linalg.norm(c - [-2, -10.2], axis=1), ry, atol=0.25)
            area = 0.5 * np.sum(c[:, 0] * np.roll(c[:, 1], -1) - np.roll(c[:, 0], -1) * c[:, 1])
            self.assertGreater(area, 0)

    def test_bad_arguments_one_line_exit_2_nothing_written(self):
        with tempfile.TemporaryDirectory() as d:
            self.make_case(d)
            for args, needle in (((os.path.join(d, "none"), os.path.join(d, "o1")), "file not found"),
                                 ((d, os.path.join(d, "o2"), "--spacing", "0"), "--spacing"),
                                 ((d, os.path.join(d, "o4"), "--axis", "x"), "--axis"),
                                 ((d, os.path.join(d, "o3"), "--template", "missing.off"), "missing.off")):
                r = self.run_script(*args)
                self.assertEqual(r.returncode, 2, r.stderr)
                self.assertEqual(r.stderr.count("\n"), 1, r.stderr)
                self.assertIn(needle, r.stderr)
                self.assertFalse(os.path.exists(args[1]))


if __name__ == "__main__":
    unittest.main()
