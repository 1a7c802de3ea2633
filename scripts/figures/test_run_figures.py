"""Tests of run_figures.py (run by CTest with /usr/bin/python3): the energy, convergence and
render figures of hand-made run folders, read back from the PNG's own metadata and pixels, its
errors through the command line, and one real 2D run of the dsnake CLI."""
import glob
import json
import math
import os
import re
import subprocess
import sys
import tempfile
import unittest
from unittest import mock

import numpy as np
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
SCRIPT = os.path.join(HERE, "run_figures.py")
sys.path.insert(0, HERE)
import run_figures  # noqa: E402

VIRIDIS_TOP = (253, 231, 37)  # viridis(1.0): the largest value
VIRIDIS_BOTTOM = (68, 1, 84)  # viridis(0.0)
GREY = tuple(round(255 * c) for c in run_figures.NO_TARGET_GREY)
UNIT = re.compile(r"\([^()]+\)")


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


def write_run(folder, name="synthetic_run", terms=None, phases=(("fit", 20), ("refine", 20)), vertices=None):
    """result.json and energy_trace.csv: terms maps a term's name to a function of the iteration
    (math.nan for no value); the total is the sum of the terms that have one."""
    terms = terms or {"internal": lambda i: 100.0 + i, "asap_mls": lambda i: 10.0 / i}
    write(os.path.join(folder, "result.json"),
          json.dumps({"name": name, "phases": [{"name": n, "iterations": k} for n, k in phases]}))
    rows = ["iteration,phase,phase_iteration,vertices,max_displacement," + ",".join(terms) + ",total"]
    i = 0
    for p, (_, count) in enumerate(phases):
        for k in range(1, count + 1):
            i += 1
            values = [f(i) for f in terms.values()]
            total = sum(v for v in values if not math.isnan(v))
            n = vertices(i) if vertices else 32
            rows.append(f"{i},{p},{k},{n},{1.0 / i}," + ",".join(str(v) for v in values) + f",{total}")
    write(os.path.join(folder, "energy_trace.csv"), "\n".join(rows) + "\n")


def octahedron(centre=(50, 50, 50), radius=10.0, first=0):
    """Points and outward-wound faces (each joins an x, a y and a z vertex); vertex first + 3 is
    the one at -y, nearest the viewer of the "from anterior" view."""
    points = np.array([[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]], float) * radius + centre
    faces = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
    return points, [tuple(first + v for v in f) for f in faces]


ANTERIOR = 3


def write_vtk(folder, has_target, error, displacement, mesh=None):
    points, faces = mesh or octahedron()
    n = len(points)
    lines = ["# vtk DataFile Version 3.0", "dsnake mesh", "ASCII", "DATASET POLYDATA", f"POINTS {n} double"]
    lines += [" ".join(str(c) for c in p) for p in points]
    lines.append(f"POLYGONS {len(faces)} {4 * len(faces)}")
    lines += [f"3 {a} {b} {c}" for a, b, c in faces]
    lines.append(f"POINT_DATA {n}")
    for name, values in (("template_id", range(n)), ("has_target", has_target), ("error", error),
                         ("displacement", displacement)):
        lines += [f"SCALARS {name} double 1", "LOOKUP_TABLE default"] + [str(float(v)) for v in values]
    lines.append("VECTORS displacement_vector double")
    lines += ["0 0 0"] * n
    write(os.path.join(folder, "final.vtk"), "\n".join(lines) + "\n")


def metadata(path):
    image = Image.open(path)
    image.load()
    return image.info["Title"], json.loads(image.info["dsnake:axes"]), image


def pixel_at(image, axes, x, y):
    """The mean RGB of the 5 x 5 pixels about data point (x, y) of the axes."""
    left, top, right, bottom = axes["bbox_px"]
    (x0, x1), (y0, y1) = axes["xlim"], axes["ylim"]
    px = left + (x - x0) / (x1 - x0) * (right - left)
    py = bottom - (y - y0) / (y1 - y0) * (bottom - top)
    rgb = np.asarray(image.convert("RGB"), dtype=float)
    return rgb[round(py) - 2:round(py) + 3, round(px) - 2:round(px) + 3].reshape(-1, 3).mean(axis=0)


def lit(rgb, colour):
    """Whether rgb is colour under some light: a positive multiple of it, the shading being a
    factor on the colour."""
    rgb, colour = np.asarray(rgb, float), np.asarray(colour, float)
    return rgb.max() > 20 and rgb @ colour / (np.linalg.norm(rgb) * np.linalg.norm(colour)) > 0.998


def run_cli(*args):
    return subprocess.run([sys.executable, SCRIPT, *args], capture_output=True, text=True)


class RunFiguresTest(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def assertLabelled(self, axes):
        """Every plot or render axes has x and y labels with a unit in parentheses, and a legend
        entry per line when it has more than one."""
        for ax in axes:
            if ax["role"] == "colorbar":
                self.assertRegex(ax["xlabel"] + ax["ylabel"], UNIT)
                continue
            self.assertRegex(ax["xlabel"], UNIT, ax)
            self.assertRegex(ax["ylabel"], UNIT, ax)
            if len(ax["lines"]) > 1:
                self.assertEqual(ax["legend"], ax["lines"])

    def test_energy_figure_lists_every_term_and_says_which_have_no_value(self):
        write_run(self.dir, terms={"internal": lambda i: 100.0 + i, "external": lambda i: math.nan,
                                   "asap_mls": lambda i: math.nan if i <= 5 else 10.0 / i})
        written = run_figures.draw_run_figures(self.dir)
        self.assertEqual([os.path.basename(p) for p in written], ["energy.png", "convergence.png"])
        title, axes, image = metadata(os.path.join(self.dir, "energy.png"))
        self.assertEqual(title, "synthetic_run — energy")
        self.assertEqual(round(image.info["dpi"][0]), 150)
        self.assertLabelled(axes)
        terms = axes[0]
        self.assertEqual(terms["legend"], ["internal", "external (no value)",
                                           "asap_mls (no value in 5 of 40 iterations)"])
        self.assertEqual(terms["yscale"], "log")
        self.assertIn("log scale", terms["ylabel"])
        self.assertEqual(terms["phase_boundaries"], [20.5])
        self.assertEqual(terms["annotations"], ["phase 0: fit", "phase 1: refine"])
        self.assertEqual(axes[1]["lines"], ["total"])
        self.assertEqual(axes[1]["phase_boundaries"], [20.5])
        self.assertEqual(glob.glob(os.path.join(self.dir, ".*tmp*")), [])

    def test_an_empty_field_is_a_missing_value(self):
        write_run(self.dir, terms={"internal": lambda i: 100.0 + i, "external": lambda i: math.nan})
        trace = os.path.join(self.dir, "energy_trace.csv")
        write(trace, open(trace).read().replace(",nan,", ",,"))
        run_figures.draw_run_figures(self.dir)
        _, axes, _ = metadata(os.path.join(self.dir, "energy.png"))
        self.assertEqual(axes[0]["legend"], ["internal", "external (no value)"])

    def test_a_run_without_an_iteration_has_no_curves(self):
        write_run(self.dir, phases=(("fit", 0),))
        self.assertEqual(len(open(os.path.join(self.dir, "energy_trace.csv")).read().splitlines()), 1)
        self.assertEqual(run_figures.draw_run_figures(self.dir), [])
        self.assertFalse(os.path.exists(os.path.join(self.dir, "energy.png")))

    def test_a_term_at_or_below_zero_is_drawn_on_a_linear_scale(self):
        write_run(self.dir, terms={"balloon": lambda i: -1.0 + 0.05 * i, "asap_mls": lambda i: 0.5})
        run_figures.draw_run_figures(self.dir)
        _, axes, _ = metadata(os.path.join(self.dir, "energy.png"))
        self.assertEqual(axes[0]["yscale"], "linear")
        self.assertNotIn("log", axes[0]["ylabel"])
        self.assertEqual(len(axes[0]["legend"]), 2)

    def test_convergence_has_a_vertex_panel_only_when_remeshing_changes_the_count(self):
        write_run(self.dir)
        run_figures.draw_run_figures(self.dir)
        title, axes, _ = metadata(os.path.join(self.dir, "convergence.png"))
        self.assertEqual(title, "synthetic_run — convergence")
        self.assertEqual(len(axes), 1)
        self.assertEqual(axes[0]["yscale"], "log")
        self.assertIn("(mm)", axes[0]["ylabel"])
        self.assertLabelled(axes)
        write_run(self.dir, vertices=lambda i: 32 if i <= 20 else 32 + 4 * i)
        run_figures.draw_run_figures(self.dir)
        _, axes, _ = metadata(os.path.join(self.dir, "convergence.png"))
        self.assertEqual(len(axes), 2)
        self.assertEqual(axes[1]["ylabel"], "vertices (count)")
        self.assertEqual(axes[1]["phase_boundaries"], [20.5])
        self.assertLabelled(axes)

    def render(self, has_target, error, displacement, mesh=None):
        write_run(self.dir)
        write_vtk(self.dir, has_target, error, displacement, mesh)
        written = run_figures.draw_run_figures(self.dir)
        self.assertIn(os.path.join(self.dir, "render.png"), written)
        title, axes, image = metadata(os.path.join(self.dir, "render.png"))
        self.assertEqual(title, "synthetic_run — final mesh")
        self.assertLabelled(axes)
        anterior = next(a for a in axes if a["title"] == "from anterior")
        colour = json.loads(image.info["dsnake:colour"])
        # The vertex at -y faces the anterior view: its projection is (x, z) = (50, 50).
        return colour, next(a for a in axes if a["role"] == "colorbar"), image, anterior

    def test_render_colours_by_error_where_a_vertex_has_a_target(self):
        error = [0.0] * 6
        error[ANTERIOR] = 2.0
        colour, bar, image, anterior = self.render([1] * 6, error, [5.0] * 6)
        self.assertEqual((colour["scalar"], colour["max"], colour["vertices"]), ("error", 2.0, 6))
        self.assertTrue(bar["xlabel"].startswith("error (mm)"))
        self.assertLess(np.abs(pixel_at(image, anterior, 50, 50) - VIRIDIS_TOP).max(), 30)
        rgb = np.asarray(image.convert("RGB"))
        left, top, right, bottom = anterior["bbox_px"]
        self.assertGreater((rgb[top:bottom, left:right] < 200).any(axis=2).mean(), 0.2)  # not blank
        # The same error on the hidden vertex (+y): the front vertex shows its own error, 0.
        error = [0.0] * 6
        error[2] = 2.0
        _, _, image, anterior = self.render([1] * 6, error, [5.0] * 6)
        self.assertLess(np.abs(pixel_at(image, anterior, 50, 50) - VIRIDIS_BOTTOM).max(), 30)

    def test_render_draws_a_vertex_without_a_target_grey(self):
        has_target = [1] * 6
        has_target[ANTERIOR] = 0
        colour, _, image, anterior = self.render(has_target, [1.0] * 6, [0.0] * 6)
        self.assertEqual((colour["scalar"], colour["vertices"], colour["of"]), ("error", 5, 6))
        self.assertLess(np.abs(pixel_at(image, anterior, 50, 50) - GREY).max(), 12)
        # Within the vertex's share of a face (barycentric 0.6, 0.2, 0.2 toward +x and +z) it is
        # still grey, only darker where the face turns from the light: not blended with yellow.
        rgb = pixel_at(image, anterior, 52, 52)
        self.assertLess(rgb.max() - rgb.min(), 12, rgb)
        self.assertGreater(rgb.min(), 80)

    def test_render_draws_the_nearer_of_two_overlapping_surfaces(self):
        front, front_faces = octahedron(centre=(50, 30, 50), radius=5.0)
        back, back_faces = octahedron(centre=(50, 70, 50), radius=10.0, first=6)
        mesh = (np.concatenate([front, back]), front_faces + back_faces)
        colour, _, image, anterior = self.render([1] * 12, [0.0] * 6 + [3.0] * 6, [0.0] * 12, mesh)
        self.assertEqual(colour["max"], 3.0)
        self.assertLess(np.abs(pixel_at(image, anterior, 50, 50) - VIRIDIS_BOTTOM).max(), 30)
        self.assertTrue(lit(pixel_at(image, anterior, 50, 56), VIRIDIS_TOP))  # the far one, beyond the near

    def test_render_colours_by_displacement_when_no_vertex_has_a_target(self):
        displacement = [1.0] * 6
        displacement[ANTERIOR] = 4.0
        colour, bar, image, anterior = self.render([0] * 6, [-1.0] * 6, displacement)
        self.assertEqual((colour["scalar"], colour["max"]), ("displacement", 4.0))
        self.assertTrue(bar["xlabel"].startswith("displacement (mm)"))
        self.assertLess(np.abs(pixel_at(image, anterior, 50, 50) - VIRIDIS_TOP).max(), 30)

    def test_bad_input_gives_one_line_exit_2_and_writes_nothing(self):
        cases = (
            ("energy_trace.csv", lambda: os.remove(os.path.join(self.dir, "energy_trace.csv"))),
            ("energy_trace.csv", lambda: write(os.path.join(self.dir, "energy_trace.csv"), "")),
            ("result.json", lambda: write(os.path.join(self.dir, "result.json"), "{not json")),
            ("final.vtk", lambda: write(os.path.join(self.dir, "final.vtk"),
                                        "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n"
                                        "0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 9\n")),
            # a triangle naming a vertex that does not exist, in a file that is otherwise whole
            ("final.vtk", lambda: write(os.path.join(self.dir, "final.vtk"),
                                        "# vtk DataFile Version 3.0\nx\nASCII\nDATASET POLYDATA\nPOINTS 3 double\n"
                                        "0 0 0 1 0 0 0 1 0\nPOLYGONS 1 4\n3 0 1 9\nPOINT_DATA 3\n"
                                        "SCALARS displacement double 1\nLOOKUP_TABLE default\n0 0 0\n")),
        )
        for culprit, spoil in cases:
            for f in os.listdir(self.dir):
                os.remove(os.path.join(self.dir, f))
            write_run(self.dir)
            spoil()
            r = run_cli(self.dir)
            self.assertEqual(r.returncode, 2, culprit)
            self.assertEqual(r.stdout, "")
            lines = r.stderr.strip().splitlines()
            self.assertEqual(len(lines), 1, r.stderr)
            self.assertIn(os.path.join(self.dir, culprit), lines[0])
            self.assertEqual(glob.glob(os.path.join(self.dir, "*.png")) + glob.glob(os.path.join(self.dir, ".*")), [])

    def test_a_figure_that_cannot_be_written_leaves_no_temporary_file(self):
        write_run(self.dir)
        with mock.patch("os.replace", side_effect=OSError(28, "No space left on device")):
            with self.assertRaisesRegex(run_figures.OutputError, "energy.png: No space left on device"):
                run_figures.draw_run_figures(self.dir)
        self.assertEqual(sorted(os.listdir(self.dir)), ["energy_trace.csv", "result.json"])

    def test_a_real_2d_run_through_the_cli(self):
        exe = os.environ.get("DSNAKE_EXE") or os.path.join(REPO, "build/release/experiments/dsnake")
        if not os.access(exe, os.X_OK):
            self.skipTest(f"no dsnake executable at {exe}")
        out = os.path.join(self.dir, "run")
        r = subprocess.run([exe, "run", "--quiet", "--out", out, "builtin:default"], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)
        r = run_cli(out)
        self.assertEqual((r.returncode, r.stdout, r.stderr), (0, "", ""))
        with open(os.path.join(out, "result.json")) as f:
            name = json.load(f)["name"]
        with open(os.path.join(out, "energy_trace.csv")) as f:
            phases = {int(line.split(",")[1]) for line in f.readlines()[1:]}
        for figure in ("energy", "convergence"):
            title, axes, _ = metadata(os.path.join(out, f"{figure}.png"))
            self.assertEqual(title, f"{name} — {figure}")
            self.assertLabelled(axes)
            self.assertEqual(len(axes[0]["phase_boundaries"]), len(phases) - 1)
        self.assertFalse(os.path.exists(os.path.join(out, "render.png")))  # 2D: overlay.png instead
        r = run_cli(out, "--verbose")
        self.assertEqual(r.stdout.split(), [os.path.join(out, "energy.png"), os.path.join(out, "convergence.png")])


if __name__ == "__main__":
    unittest.main()
