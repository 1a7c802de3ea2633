"""Tests of the figure scripts (run by CTest with /usr/bin/python3): each script on hand-made
inputs, checking what it computes (breakdown levels, error maxima, energy totals) and that the
picture holds what it should (the colour of a template vertex appears in both panels)."""
import os
import subprocess
import sys
import tempfile
import unittest

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from PIL import Image  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))


def run(script, *args):
    r = subprocess.run([sys.executable, os.path.join(HERE, script), *args], capture_output=True, text=True)
    if r.returncode != 0:
        raise AssertionError(f"{script} failed: {r.stderr}")
    return r.stdout


def write(path, text):
    with open(path, "w") as f:
        f.write(text)


class FigureScripts(unittest.TestCase):
    def setUp(self):
        self.tmp = tempfile.TemporaryDirectory()
        self.dir = self.tmp.name

    def tearDown(self):
        self.tmp.cleanup()

    def test_success_rates_marks_the_breakdown_levels(self):
        rows = ["method,grid,corruption_type,level,corruption,magnitude,runs,finished,successes,success_rate,breakdown"]
        for method, rates in (("gvf_snake", (1.0, 0.3, 0.0)), ("dsnake", (1.0, 0.9, 0.1))):
            for level, (mag, rate) in enumerate(zip((0, 0.01, 0.03), rates)):
                rows.append(f"{method},0,outliers,{level},outliers {mag},{mag},10,10,{int(rate * 10)},{rate},x")
            for level, (mag, rate) in enumerate(zip((0, 30, 35), (1.0, 1.0, 1.0))):
                rows.append(f"{method},0,noise,{level},noise {mag},{mag},10,10,10,{rate},none")
        write(os.path.join(self.dir, "breakdown.csv"), "\n".join(rows) + "\n")
        out = run("success_rates.py", self.dir)
        lines = set(out.split())
        self.assertIn("gvf_snake,0,outliers,0.01", lines)
        self.assertIn("dsnake,0,outliers,0.03", lines)
        self.assertIn("dsnake,0,noise,none", lines)
        image = mpimg.imread(os.path.join(self.dir, "success_rates.png"))
        self.assertEqual(image.shape[1], int(2 * 4.2 * 110))  # two panels: outliers, noise

    def test_success_rates_wilson_band_and_curves_that_coincide(self):
        sys.path.insert(0, HERE)
        import success_rates
        # Published 95% Wilson intervals (Newcombe 1998): 5/10 and 0/10.
        low, high = success_rates.wilson(5, 10)
        self.assertAlmostEqual(low, 0.2366, places=4)
        self.assertAlmostEqual(high, 0.7634, places=4)
        self.assertEqual(success_rates.wilson(0, 10)[0], 0.0)
        self.assertAlmostEqual(success_rates.wilson(0, 10)[1], 0.2775, places=4)
        # Two methods with the same rates (as ARAP and D-Snake on the clean star): both curves are
        # drawn, apart, with n in their labels and the unit on the axis.
        rows = ["method,grid,corruption_type,level,corruption,magnitude,runs,finished,successes,success_rate,breakdown"]
        for method in ("arap", "dsnake"):
            for level, (mag, k) in enumerate(((0, 4), (0.01, 2), (0.03, 0))):
                rows.append(f"{method},,outliers,{level},outliers={mag},{mag},4,4,{k},{k / 4},x")
        write(os.path.join(self.dir, "breakdown.csv"), "\n".join(rows) + "\n")
        fig_texts = []
        original = plt.Figure.savefig

        def capture(fig, *a, **kw):
            ax = fig.axes[0]
            fig_texts.append((ax.get_xlabel(), [t.get_text() for t in ax.get_legend().get_texts()],
                              [list(l.get_xdata()) for l in ax.get_lines() if l.get_label() in ("arap (n = 4)", "dsnake (n = 4)")],
                              len(ax.collections), ax.get_ylabel(), fig._suptitle.get_text()))
            return original(fig, *a, **kw)

        plt.Figure.savefig = capture
        try:
            sys.argv = ["success_rates.py", self.dir]
            success_rates.main()
        finally:
            plt.Figure.savefig = original
        xlabel, legend, xs, bands, ylabel, title = fig_texts[0]
        self.assertEqual(ylabel, "success rate (fraction of runs; 95% Wilson band)")
        self.assertEqual(title, os.path.basename(self.dir) + " — success rate")
        self.assertEqual(Image.open(os.path.join(self.dir, "success_rates.png")).info["Title"], title)
        self.assertEqual(xlabel, "outliers: fraction of voxels flipped")
        self.assertEqual(legend, ["arap (n = 4)", "dsnake (n = 4)"])
        self.assertEqual(len(xs), 2)
        self.assertTrue(all(a < b for a, b in zip(xs[0], xs[1])))  # offset sideways, not on top
        self.assertEqual(bands, 2)  # one Wilson band per curve

    def test_correspondence_colours_each_template_vertex_alike_in_both_panels(self):
        run_dir = os.path.join(self.dir, "run")
        os.makedirs(run_dir)
        square = [(10, 10), (30, 10), (30, 30), (10, 30)]
        rows = ["template_id,landmark,initial_x,initial_y,final_x,final_y,displacement,target_x,target_y,error"]
        for i, (x, y) in enumerate(square):
            fx, fy = 2 * x, 2 * y + (0.5 if i == 2 else 0)
            rows.append(f"{i},{'corner' if i == 0 else ''},{x},{y},{fx},{fy},1,{2 * x},{2 * y},{0.5 if i == 2 else 0}")
        write(os.path.join(run_dir, "correspondence.csv"), "\n".join(rows) + "\n")
        for name, scale in (("initial.vtk", 1), ("final.vtk", 2)):
            pts = "\n".join(f"{scale * x} {scale * y} 0" for x, y in square)
            write(os.path.join(run_dir, name), "# vtk DataFile Version 3.0\nt\nASCII\nDATASET POLYDATA\n"
                  f"POINTS 4 double\n{pts}\nLINES 4 12\n2 0 1\n2 1 2\n2 2 3\n2 3 0\n")
        write(os.path.join(run_dir, "result.json"), '{"name": "square_run"}')
        out = run("correspondence.py", run_dir)
        self.assertIn("4 template vertices; max error 0.5", out)
        self.assertEqual(Image.open(os.path.join(run_dir, "correspondence.png")).info["Title"],
                         "square_run — correspondence: one colour per template vertex (max error 0.50 mm)")
        image = mpimg.imread(os.path.join(run_dir, "correspondence.png"))[:, :, :3]
        width = image.shape[1]
        # vertex 2's colour (hsv at 2/4: cyan) appears in the left and the right panel
        target = plt.get_cmap("hsv")(2 / 4)[:3]
        close = (abs(image - target).sum(axis=2) < 0.15)
        cols = close.any(axis=0).nonzero()[0]
        self.assertTrue((cols < width // 2).any() and (cols > width // 2).any())

    def test_energy_curves_report_first_and_last_totals(self):
        runs = []
        for name, totals in (("snake", (10.0, 4.0, 2.0)), ("global", (10.0, 1.5))):
            d = os.path.join(self.dir, name)
            os.makedirs(d)
            rows = ["iteration,phase,phase_iteration,vertices,max_displacement,internal,external,total"]
            for k, t in enumerate(totals):
                rows.append(f"{k + 1},0,{k + 1},10,0.1,{t / 2},{t / 2},{t}")
            write(os.path.join(d, "energy_trace.csv"), "\n".join(rows) + "\n")
            runs.append(d)
        out = run("energy_curves.py", *runs, "--out", os.path.join(self.dir, "e.png"), "--labels", "snake,global")
        self.assertEqual(out.split(), ["snake,3,10,2", "global,2,10,1.5"])
        self.assertTrue(os.path.getsize(os.path.join(self.dir, "e.png")) > 5000)
        self.assertEqual(Image.open(os.path.join(self.dir, "e.png")).info["Title"], "energy: snake, global")


if __name__ == "__main__":
    unittest.main()
