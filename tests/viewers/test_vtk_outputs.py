"""Every VTK file that dsnake writes loads in VTK's own legacy reader (Debian's python3-vtk9, the
reader ParaView uses), with finite arrays of the documented names; result_mask.nii.gz and
image.nii.gz load in VTK's NIfTI reader with the image's grid. Runs the built-in 2D and 3D
experiments (snapshots on), `dsnake template` and `dsnake convert`.

Environment: DSNAKE_EXE (the dsnake executable), DSNAKE_SOURCE_DIR (for data/scans)."""
import glob
import json
import math
import os
import subprocess
import tempfile
import unittest

import vtk
from vtk.util.numpy_support import vtk_to_numpy

EXE = os.environ["DSNAKE_EXE"]
SCANS = os.path.join(os.environ["DSNAKE_SOURCE_DIR"], "data", "scans")


class ErrorCatcher:
    """Collects the messages a VTK reader reports as errors or warnings."""

    def __init__(self, reader):
        self.messages = []
        for event in ("ErrorEvent", "WarningEvent"):
            reader.AddObserver(event, self.on_event)
        # VTK also prints to its output window; keep it quiet and use the observer.
        vtk.vtkObject.GlobalWarningDisplayOff()

    def on_event(self, obj, event):
        self.messages.append("%s from %s" % (event, obj.GetClassName()))


def read_polydata(path):
    reader = vtk.vtkPolyDataReader()
    catcher = ErrorCatcher(reader)
    reader.SetFileName(path)
    reader.ReadAllScalarsOn()
    reader.ReadAllVectorsOn()
    reader.Update()
    return reader.GetOutput(), catcher.messages


def point_arrays(poly):
    data = poly.GetPointData()
    return {data.GetArrayName(i): vtk_to_numpy(data.GetArray(i)) for i in range(data.GetNumberOfArrays())}


def run(*args):
    p = subprocess.run([EXE, *args], capture_output=True, text=True)
    if p.returncode != 0:
        raise AssertionError("dsnake %s failed (%d): %s" % (" ".join(args), p.returncode, p.stderr))
    return p


class VtkOutputsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.runs = {}
        for name in ("default", "ellipsoid"):
            out = os.path.join(cls.tmp.name, name)
            run("run", "builtin:" + name, "-o", out, "-j", "1", "--quiet", "--set", "output.snapshot_every=100")
            cls.runs[name] = out

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def check_vtk(self, path, dimension):
        poly, messages = read_polydata(path)
        self.assertEqual(messages, [], path)
        self.assertGreater(poly.GetNumberOfPoints(), 3, path)
        cells = poly.GetNumberOfPolys() if dimension == 3 else poly.GetNumberOfLines()
        self.assertGreater(cells, 0, path)
        for name, values in point_arrays(poly).items():
            self.assertEqual(len(values), poly.GetNumberOfPoints(), (path, name))
            self.assertTrue(all(math.isfinite(float(v)) for v in values.ravel()), (path, name))
        return poly

    def test_every_vtk_file_of_a_run_loads(self):
        for name, dimension in (("default", 2), ("ellipsoid", 3)):
            files = glob.glob(os.path.join(self.runs[name], "**", "*.vtk"), recursive=True)
            self.assertIn(os.path.join(self.runs[name], "final.vtk"), files)
            self.assertIn(os.path.join(self.runs[name], "initial.vtk"), files)
            self.assertTrue(any("snapshots" in f for f in files), name)
            for f in files:
                with self.subTest(file=f):
                    self.check_vtk(f, dimension)

    def test_final_vtk_has_the_documented_arrays(self):
        for name in ("default", "ellipsoid"):
            poly = self.check_vtk(os.path.join(self.runs[name], "final.vtk"), 3 if name == "ellipsoid" else 2)
            arrays = point_arrays(poly)
            self.assertEqual(sorted(arrays), sorted(["template_id", "has_target", "error", "displacement",
                                                     "displacement_vector"]), name)
            self.assertEqual(arrays["displacement_vector"].shape, (poly.GetNumberOfPoints(), 3))
            ids, has, err = arrays["template_id"], arrays["has_target"], arrays["error"]
            self.assertTrue(set(has.tolist()) <= {0.0, 1.0})
            # error: the sentinel -1 exactly where there is no target, else a distance
            self.assertTrue(all((e == -1.0) == (h == 0.0) for e, h in zip(err, has)))
            self.assertTrue(all(e >= 0 for e, h in zip(err, has) if h == 1.0))
            # |displacement_vector| is the displacement; free vertices (id -1) have 0
            for i in range(poly.GetNumberOfPoints()):
                norm = math.sqrt(sum(float(c) ** 2 for c in arrays["displacement_vector"][i]))
                self.assertAlmostEqual(norm, float(arrays["displacement"][i]), places=9)
                if ids[i] < 0:
                    self.assertEqual(norm, 0.0)

    def test_result_mask_and_image_load_with_the_image_grid(self):
        out = self.runs["ellipsoid"]
        masks = {}
        for name in ("result_mask.nii.gz", "image.nii.gz"):
            reader = vtk.vtkNIFTIImageReader()
            catcher = ErrorCatcher(reader)
            reader.SetFileName(os.path.join(out, name))
            reader.Update()
            self.assertEqual(catcher.messages, [], name)
            image = reader.GetOutput()
            self.assertEqual(image.GetDimensions(), (64, 64, 64), name)
            masks[name] = vtk_to_numpy(image.GetPointData().GetScalars())
            # dsnake writes LPS as NIfTI's RAS: an axis-aligned grid is a half turn about z
            q = reader.GetQFormMatrix()
            self.assertEqual([q.GetElement(0, 0), q.GetElement(1, 1), q.GetElement(2, 2)], [-1, -1, 1], name)
        mask = masks["result_mask.nii.gz"] > 0
        self.assertEqual(set(masks["result_mask.nii.gz"].tolist()), {0, 1})
        # The phantom's object: the image's half-way level, on the side of the centre voxel
        # (x fastest: the centre is at index 32 + 64 * (32 + 64 * 32)).
        image = masks["image.nii.gz"]
        mid = 0.5 * (image.min() + image.max())
        centre = image[32 + 64 * (32 + 64 * 32)]
        truth = image < mid if centre < mid else image > mid
        self.assertAlmostEqual(truth.sum() / (4 / 3 * math.pi * 24 * 18 * 14), 1.0, delta=0.03)
        dice = 2 * (truth & mask).sum() / (truth.sum() + mask.sum())
        with open(os.path.join(out, "result.json")) as f:
            reported = json.load(f)["metrics"]["dice"]
        self.assertAlmostEqual(dice, reported, delta=0.01)  # the overlay matches the metric
        self.assertGreater(dice, 0.9)

    def test_template_and_convert_outputs_load(self):
        labels = os.path.join(self.tmp.name, "ball.mha")
        # a ball label through the NRRD writer and back, then a template of it in VTK
        run("convert", os.path.join(self.runs["ellipsoid"], "result_mask.nii.gz"), labels)
        mesh = os.path.join(self.tmp.name, "ball.vtk")
        run("template", "--mask", labels, "--label", "1", "--vertices", "300", "--out", mesh)
        self.check_vtk(mesh, 3)
        femur = os.path.join(self.tmp.name, "femur.vtk")
        run("convert", os.path.join(SCANS, "cgal", "meshes", "femur.off"), femur)
        poly = self.check_vtk(femur, 3)
        # a closed genus-2 triangle mesh: F = 2V + 4g - 4 = 2V + 4
        self.assertEqual(poly.GetNumberOfPolys(), 2 * poly.GetNumberOfPoints() + 4)


if __name__ == "__main__":
    unittest.main()
