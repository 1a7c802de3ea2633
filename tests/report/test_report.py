"""report.html (scripts/report/make_report.py, docs/reports.md) opened in headless Chromium.

A 3D run's report and a small sweep's report are written and opened from a folder of their own
(so that nothing beside report.html can be loaded); each must load without a console error,
a page error or a request other than the page itself and data: URIs; the 3D view must have drawn
the mesh (the canvas's pixels, read back from a screenshot), and the sweep's tables must equal a
pandas computation from results.csv (sweep_summary.h's statistics) to the printed precision.

Chromium is driven through the DevTools protocol over a pipe (--remote-debugging-pipe), with the
standard library only; WebGL runs on SwiftShader, the CPU renderer, so no GPU or display is
needed. Environment: DSNAKE_EXE (the dsnake executable), DSNAKE_SOURCE_DIR (the repository),
DSNAKE_VIEWER_JS (the viewer bundle), CHROMIUM (the browser, default /usr/bin/chromium);
DSNAKE_REPORT_TEST_KEEP=1 keeps the temporary folder (its path is printed) with the screenshots.

    DSNAKE_EXE=build/release/experiments/dsnake /usr/bin/python3 -m unittest discover -s tests/report
"""
import fcntl
import io
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import unittest

SOURCE = (os.environ.get("DSNAKE_SOURCE_DIR")
          or os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
EXE = os.environ.get("DSNAKE_EXE") or os.path.join(SOURCE, "build", "release", "experiments", "dsnake")
VIEWER = os.environ.get("DSNAKE_VIEWER_JS") or os.path.join(SOURCE, "build", "release", "viewer", "dsnake_viewer.js")
CHROMIUM = os.environ.get("CHROMIUM") or "/usr/bin/chromium"
MAKE_REPORT = os.path.join(SOURCE, "scripts", "report", "make_report.py")
PYTHON = "/usr/bin/python3"
DIGITS = 4  # make_report.py's SWEEP_DIGITS: the sweep tables' significant digits
QUANTITIES = (("dice", "dice"), ("mean_surface_distance", "mean_surface_distance_mm"),
              ("hausdorff95", "hausdorff95_mm"), ("correspondence_error_mean", "correspondence_error_mean_mm"),
              ("total_s", "time_s"))
Z95 = 1.959963984540054  # the normal quantile of the Wilson interval (sweep_summary.cpp)


# ---------------------------------------------------------------------------------------------
# Headless Chromium over the DevTools protocol


class Chromium:
    """A headless Chromium driven through --remote-debugging-pipe: commands are written to its
    fd 3 and answers and events read from its fd 4, each a JSON message ending in a NUL byte."""

    def __init__(self, user_dir, width=1280, height=1000):
        to_browser, self._write = os.pipe()
        self._read, from_browser = os.pipe()
        # Its ends above fd 10 first, so that moving them to 3 and 4 in the child clobbers nothing.
        child_in, child_out = (fcntl.fcntl(fd, fcntl.F_DUPFD, 10) for fd in (to_browser, from_browser))
        os.close(to_browser)
        os.close(from_browser)

        def ends():
            os.dup2(child_in, 3)
            os.dup2(child_out, 4)

        self.process = subprocess.Popen(
            [CHROMIUM, "--headless=new", "--remote-debugging-pipe", "--no-sandbox", "--no-first-run",
             "--no-default-browser-check", "--disable-extensions", "--disable-background-networking",
             "--disable-component-update", "--disable-sync", "--mute-audio", f"--user-data-dir={user_dir}",
             # WebGL without a GPU: ANGLE on SwiftShader, allowed explicitly (no fallback warning).
             "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
             f"--window-size={width},{height}", "about:blank"],
            preexec_fn=ends, pass_fds=(3, 4), stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        os.close(child_in)
        os.close(child_out)
        self._next_id, self._answers, self.events = 0, {}, []
        self._cond = threading.Condition()
        self._reader = threading.Thread(target=self._read_messages, daemon=True)
        self._reader.start()
        self.session = None

    def _read_messages(self):
        buffer = b""
        while True:
            chunk = os.read(self._read, 1 << 16)
            if not chunk:
                break
            buffer += chunk
            *messages, buffer = buffer.split(b"\0")
            with self._cond:
                for m in messages:
                    message = json.loads(m)
                    if "id" in message:
                        self._answers[message["id"]] = message
                    else:
                        self.events.append(message)
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def send(self, method, params=None, timeout=30, session=True):
        with self._cond:
            self._next_id += 1
            call = self._next_id
        message = {"id": call, "method": method, "params": params or {}}
        if session and self.session:
            message["sessionId"] = self.session
        os.write(self._write, json.dumps(message).encode() + b"\0")
        deadline = time.monotonic() + timeout
        with self._cond:
            while call not in self._answers:
                left = deadline - time.monotonic()
                if left <= 0 or not self._reader.is_alive():
                    raise TimeoutError(f"Chromium did not answer {method}")
                self._cond.wait(left)
            answer = self._answers.pop(call)
        if "error" in answer:
            raise RuntimeError(f"{method}: {answer['error']}")
        return answer.get("result", {})

    def open_page(self, width, height):
        """A new tab with the runtime, log, page and network domains reporting to self.events."""
        target = self.send("Target.createTarget", {"url": "about:blank"}, session=False)["targetId"]
        self.session = self.send("Target.attachToTarget", {"targetId": target, "flatten": True},
                                 session=False)["sessionId"]
        for domain in ("Runtime", "Log", "Page", "Network"):
            self.send(f"{domain}.enable")
        self.send("Emulation.setDeviceMetricsOverride",
                  {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": False})

    def page_events(self):
        """The events of the tab opened last (each event names its session)."""
        with self._cond:
            return [e for e in self.events if e.get("sessionId") == self.session]

    def wait_event(self, method, timeout=30):
        deadline = time.monotonic() + timeout
        with self._cond:
            while not any(e.get("method") == method and e.get("sessionId") == self.session for e in self.events):
                left = deadline - time.monotonic()
                if left <= 0:
                    raise TimeoutError(f"no {method} from Chromium")
                self._cond.wait(left)

    def evaluate(self, expression):
        result = self.send("Runtime.evaluate", {"expression": expression, "returnByValue": True,
                                                "awaitPromise": True})
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    def wait_for(self, expression, timeout=30):
        deadline = time.monotonic() + timeout
        while not self.evaluate(f"!!({expression})"):
            if time.monotonic() > deadline:
                raise TimeoutError(f"never true: {expression}")
            time.sleep(0.05)

    def screenshot(self, path, clip=None):
        import base64
        params = {"format": "png", "captureBeyondViewport": clip is None}
        if clip:
            params["clip"] = dict(clip, scale=1)
        data = base64.b64decode(self.send("Page.captureScreenshot", params, timeout=60)["data"])
        with open(path, "wb") as f:
            f.write(data)
        return data

    def problems(self):
        """Console errors, page errors (uncaught exceptions) and error log entries so far."""
        out = []
        for e in self.page_events():
            method, params = e.get("method"), e.get("params", {})
            if method == "Runtime.exceptionThrown":
                details = params.get("exceptionDetails", {})
                out.append("page error: " + str(details.get("exception", {}).get("description") or details.get("text")))
            elif method == "Runtime.consoleAPICalled" and params.get("type") in ("error", "assert"):
                args = params.get("args", [])
                out.append("console.error: " + " ".join(str(a.get("value", a.get("description"))) for a in args))
            elif method == "Log.entryAdded" and params.get("entry", {}).get("level") == "error":
                out.append(f"log error: {params['entry'].get('text')} {params['entry'].get('url', '')}")
        return out

    def requests(self):
        return [e["params"]["request"]["url"] for e in self.page_events()
                if e.get("method") == "Network.requestWillBeSent"]

    def close(self):
        try:
            self.send("Browser.close", session=False, timeout=5)
        except (OSError, TimeoutError, RuntimeError):
            pass
        try:
            self.process.wait(timeout=10)
        except subprocess.TimeoutExpired:
            self.process.kill()
            self.process.wait()
        os.close(self._write)
        os.close(self._read)


# ---------------------------------------------------------------------------------------------
# What the sweep's tables should hold: summary.csv's statistics (experiments/sweep/sweep_summary.h)
# computed again with pandas from results.csv


def wilson(k, n):
    if n == 0:
        return 0.0, 1.0
    p, z2n = k / n, Z95 * Z95 / n
    centre = (p + z2n / 2) / (1 + z2n)
    half = Z95 / (1 + z2n) * math.sqrt(p * (1 - p) / n + z2n / (4 * n))
    return max(0.0, centre - half), min(1.0, centre + half)


def expected_summary(results_csv):
    """{(method, grid, corruption): {column: value}} with summary.csv's column names. A group is a
    method x grid point x corruption level; a run counts when its status is not "missing", a
    value when it is finite; the grid point is "key=value;..." over the columns between method
    and corruption_level."""
    import numpy as np
    import pandas as pd
    from scipy import stats
    df = pd.read_csv(results_csv, dtype=str, keep_default_na=False)
    columns = list(df.columns)
    grid_columns = columns[columns.index("method") + 1:columns.index("corruption_level")]
    df["grid"] = df[grid_columns].apply(lambda r: ";".join(f"{c}={r[c]}" for c in grid_columns), axis=1) \
        if grid_columns else ""
    out = {}
    groups = df.groupby(["method", "grid", "corruption_level", "corruption"], sort=False)
    for (method, grid, _, corruption), g in groups:
        f = g[g["status"] != "missing"]
        k, n = int((f["success"] == "true").sum()), len(f)
        low, high = wilson(k, n)
        row = {"runs": len(g), "finished": n, "stale": int((f["stale"] != "").sum()), "successes": k,
               "success_rate": k / n if n else None, "success_ci95_low": low if n else None,
               "success_ci95_high": high if n else None}
        for column, name in QUANTITIES:
            v = pd.to_numeric(f[column], errors="coerce")
            v = v[np.isfinite(v)]
            m = len(v)
            sd = v.std(ddof=1) if m >= 2 else None
            half = stats.t.ppf(0.975, m - 1) * sd / math.sqrt(m) if m >= 2 else None
            row.update({f"{name}_n": m, f"{name}_mean": v.mean() if m else None, f"{name}_sd": sd,
                        f"{name}_ci95_low": v.mean() - half if m >= 2 else None,
                        f"{name}_ci95_high": v.mean() + half if m >= 2 else None})
        out[(method, grid or "–", corruption)] = row
    return out


def agrees(text, value, scale=1.0):
    """Whether a table cell shows `value` to DIGITS significant digits ("–" for none). Beyond
    exact agreement of the formatted text, it allows half a unit of the last printed digit (a
    value on a rounding boundary) and 1e-9 of the quantity's scale (the SD of equal values is 0
    or a rounding residue such as 1e-16, depending on the order of the sums)."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return text == "–"
    if text == "–":
        return False
    if f"{value:.{DIGITS}g}" == text:
        return True
    shown = float(text)
    unit = 10 ** (math.floor(math.log10(abs(shown))) - DIGITS + 1) if shown else 0.0
    return abs(shown - value) <= 0.5 * unit * (1 + 1e-9) + 1e-9 * max(abs(scale), 1e-300)


# ---------------------------------------------------------------------------------------------
# The tests


def run(command, timeout=120, env=None, check=True):
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=timeout,
                          env=env)
    if check and done.returncode != 0:
        raise AssertionError(f"{' '.join(command)} exited {done.returncode}:\n{done.stderr[-3000:]}")
    return done


CANVAS_PIXELS = """(() => {
  const c = document.querySelector('#dsnake-view canvas');
  const copy = document.createElement('canvas');
  copy.width = c.width; copy.height = c.height;
  const ctx = copy.getContext('2d');
  ctx.drawImage(c, 0, 0);
  const d = ctx.getImageData(0, 0, copy.width, copy.height).data;
  let drawn = 0, coloured = 0;
  for (let i = 0; i < d.length; i += 4) {
    const hi = Math.max(d[i], d[i + 1], d[i + 2]), lo = Math.min(d[i], d[i + 1], d[i + 2]);
    if (lo < 245) drawn++;
    if (hi - lo > 60) coloured++;
  }
  return {drawn, coloured, total: copy.width * copy.height};
})()"""

TABLE_CELLS = ("[...document.querySelectorAll('#%s tbody tr')]"
               ".map(tr => [...tr.cells].map(td => td.textContent.trim()))")
TABLE_HEADERS = """[...document.querySelectorAll('#%s thead th')].map(th => th.textContent.trim())"""


class ReportTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        for path, what in ((EXE, "the dsnake executable (DSNAKE_EXE)"), (VIEWER, "the viewer bundle (DSNAKE_VIEWER_JS; "
                           "the CMake target dsnake_viewer)"), (CHROMIUM, "Chromium (scripts/setup.sh installs it)")):
            if not os.path.exists(path):
                raise AssertionError(f"{path}: missing: {what}")
        cls.tmp = tempfile.mkdtemp(prefix="dsnake-report-test-")
        cls.browser = None

    @classmethod
    def tearDownClass(cls):
        if cls.browser:
            cls.browser.close()
        if os.environ.get("DSNAKE_REPORT_TEST_KEEP") == "1":
            print(f"\nkept {cls.tmp}", file=sys.stderr)
        else:
            shutil.rmtree(cls.tmp, ignore_errors=True)

    def open(self, report, name):
        """Opens a copy of `report` alone in a folder of its own; returns the browser after the load."""
        alone = os.path.join(self.tmp, f"alone-{name}")
        os.makedirs(alone)
        shutil.copy(report, alone)
        if type(self).browser is None:
            type(self).browser = Chromium(os.path.join(self.tmp, "profile"))
        b = self.browser
        b.open_page(1280, 1000)
        url = "file://" + os.path.join(alone, "report.html")
        b.send("Page.navigate", {"url": url})
        b.wait_event("Page.loadEventFired")
        return b, url

    def wait_drawn(self, b, timeout=30):
        """Until the view has drawn its first frame; fails at once on a console or page error."""
        deadline = time.monotonic() + timeout
        while not b.evaluate("!!document.querySelector('#dsnake-view[data-dsnake-viewer=drawn]')"):
            self.assertEqual(b.problems(), [], "console or page errors")
            if time.monotonic() > deadline:
                view = b.evaluate("(document.querySelector('#dsnake-view') || {outerHTML: 'no #dsnake-view'})"
                                  ".outerHTML.slice(0, 300)")
                self.fail(f"the view did not draw within {timeout} s: {view}")
            time.sleep(0.05)
        self.assertEqual(b.problems(), [], "console or page errors")

    def assert_clean(self, b, url):
        time.sleep(0.2)  # events of the last frame
        self.assertEqual(b.problems(), [], "console or page errors")
        foreign = [u for u in b.requests() if u != url and not u.startswith("data:")]
        self.assertEqual(foreign, [], "the page loaded something besides itself and data: URIs")

    def test_run_report_3d(self):
        """A 3D run (the lung phantom, remeshed): its report loads cleanly offline, and its view
        draws the mesh, coloured, and the placed template when ticked."""
        out = os.path.join(self.tmp, "lung")
        run([EXE, "run", os.path.join(SOURCE, "experiments", "paper", "lung_dsnake.json"), "--out", out, "--quiet",
             "--set", "output.report=false", "--set", "phases[0].iterations=100", "--set", "phases[1].iterations=40"])
        made = run([PYTHON, MAKE_REPORT, out, "--viewer", VIEWER])
        report = os.path.join(out, "report.html")
        self.assertTrue(os.path.isfile(report))
        self.assertEqual([n for n in os.listdir(out) if n.endswith(".tmp")], [], "a temporary file was left")
        with open(os.path.join(out, "result.json")) as f:
            result = json.load(f)
        b, url = self.open(report, "run")
        self.wait_drawn(b)
        self.assertEqual(b.evaluate("document.title"), result["name"])
        metrics = b.evaluate(TABLE_CELLS % "metrics-table")
        dice = [row for row in metrics if row[0] == "Dice"][0]
        self.assertEqual(dice[1], f"{result['metrics']['dice']:.4g}")
        self.assertIn("mm", [row[2] for row in metrics if row[0] == "HD95"][0])
        pixels = b.evaluate(CANVAS_PIXELS)
        # The mesh covers a good part of the canvas, and the colour map shows on it (the template
        # vertices' error: coloured dots on the grey of the inserted vertices).
        self.assertGreater(pixels["drawn"], 0.05 * pixels["total"], pixels)
        self.assertGreater(pixels["coloured"], 500, pixels)
        rect = b.evaluate("(() => { const c = document.querySelector('#dsnake-view canvas'); c.scrollIntoView();"
                          " const r = c.getBoundingClientRect();"
                          " return {x: r.x + scrollX, y: r.y + scrollY, width: r.width, height: r.height}; })()")
        before = self.pixels_of(b.screenshot(os.path.join(self.tmp, "run_view.png"), rect))
        b.evaluate("document.querySelector('#dsnake-view .dsnake-initial').click()")
        time.sleep(0.2)
        after = self.pixels_of(b.screenshot(os.path.join(self.tmp, "run_view_template.png"), rect))
        pngs = sorted(n for n in os.listdir(out) if n.endswith(".png"))
        self.assertEqual(b.evaluate("[...document.querySelectorAll('#figures figcaption code')]"
                                    ".map(c => c.textContent).sort()"), pngs, "a PNG of the run is not in the report")
        b.screenshot(os.path.join(self.tmp, "run_page.png"))
        self.assert_clean(b, url)
        h, w = before.shape[:2]
        middle = (slice(h // 4, 3 * h // 4), slice(w // 4, 3 * w // 4))  # clear of the toolbar and legend
        self.assertGreater((before[middle].min(axis=2) < 0.96).mean(), 0.1, "the screenshot shows no mesh")
        yellow = lambda p: ((p[..., 0] > 0.75) & (p[..., 1] > 0.55) & (p[..., 2] < 0.35))[middle].sum()
        self.assertGreater(yellow(after) - yellow(before), 200, "ticking the placed template drew nothing yellow")
        self.assertNotIn("no interactive view", made.stderr)

    @staticmethod
    def pixels_of(png):
        import matplotlib.image
        return matplotlib.image.imread(io.BytesIO(png), format="png")[..., :3]

    def make_sweep(self):
        """24 runs: D-Snake and the GVF snake on the 3D star (shortened) x field.mu 0.2, 0.25 x clean
        and 1% outliers x 3 seeds; then one run's result removed, as if it had failed, and the
        tables written again (`dsnake sweep --aggregate-only`), and one run given its own report."""
        paper = os.path.join(SOURCE, "experiments", "paper")
        sweep = {"base": os.path.join(paper, "star_dsnake.json"),
                 "methods": {"dsnake": {"overrides": {"phases[0].iterations": 150}},
                             "gvf_snake": {"base": os.path.join(paper, "star_gvf_snake.json"),
                                           "overrides": {"phases[0].iterations": 100}}},
                 "grid": {"field.mu": [0.2, 0.25]},
                 "corruptions": [[], [{"type": "outliers", "fraction": 0.01}]],
                 "seeds": {"count": 3, "first": 0}}
        path = os.path.join(self.tmp, "sweep.json")
        with open(path, "w") as f:
            json.dump(sweep, f)
        out = os.path.join(self.tmp, "sweep")
        run([EXE, "sweep", path, "--out", out, "-j", "2", "--quiet"], timeout=300)
        runs = sorted(os.listdir(os.path.join(out, "runs")))
        self.assertEqual(len(runs), 24)
        os.remove(os.path.join(out, "runs", runs[-1], "result.json"))
        run([EXE, "sweep", path, "--out", out, "--aggregate-only", "--quiet"], check=False)
        run([PYTHON, MAKE_REPORT, os.path.join(out, "runs", runs[0]), "--no-figures", "--viewer", VIEWER])
        return out, runs

    def test_sweep_report(self):
        """The sweep's report loads cleanly offline, its tables equal pandas' statistics of
        results.csv to the printed digits, it counts the runs, and it links the run report."""
        out, runs = self.make_sweep()
        run([PYTHON, MAKE_REPORT, out])
        expected = expected_summary(os.path.join(out, "results.csv"))
        self.assertEqual(sum(g["runs"] for g in expected.values()), 24)
        self.assertEqual(sum(g["finished"] for g in expected.values()), 23)
        b, url = self.open(os.path.join(out, "report.html"), "sweep")
        b.screenshot(os.path.join(self.tmp, "sweep_page.png"))
        self.check_success_table(b.evaluate(TABLE_CELLS % "summary-success"), expected)
        for column, name in QUANTITIES:
            headers = b.evaluate(TABLE_HEADERS % f"summary-{name}")
            self.assertIn("(s)" if name == "time_s" else "(mm)" if name.endswith("_mm") else "mean", headers[3])
            self.check_quantity_table(b.evaluate(TABLE_CELLS % f"summary-{name}"), expected, name)
        self.check_overview(b.evaluate(TABLE_CELLS % "summary-overview"), expected)
        counts = b.evaluate("document.querySelector('#run-counts').textContent")
        met = sum(g["successes"] for g in expected.values())
        self.assertRegex(counts, rf"^24 runs: 23 finished \({met} met their thresholds; 0 stopped by the watchdog.*\), "
                                 r"1 failed without a result .*, 0 not run yet, 0 stale")
        links = b.evaluate("[...document.querySelectorAll('#runs-table a')].map(a => a.getAttribute('href'))")
        self.assertEqual(links, [f"runs/{runs[0]}/report.html"])
        self.assertTrue(os.path.isfile(os.path.join(out, links[0])))
        self.assert_clean(b, url)

    def check_success_table(self, rows, expected):
        self.assertEqual(len(rows), len(expected))
        for row in rows:
            want = expected[tuple(row[:3])]
            for text, column in zip(row[3:], ("runs", "finished", "stale", "successes")):
                self.assertEqual(text, str(want[column]), (row, column))
            for text, column in zip(row[7:], ("success_rate", "success_ci95_low", "success_ci95_high")):
                self.assertTrue(agrees(text, want[column]), (row, column, want[column]))

    def check_quantity_table(self, rows, expected, name):
        self.assertEqual(len(rows), len(expected))
        for row in rows:
            want = expected[tuple(row[:3])]
            scale = want[f"{name}_mean"] or 1.0
            for text, part in zip(row[3:7], ("mean", "sd", "ci95_low", "ci95_high")):
                self.assertTrue(agrees(text, want[f"{name}_{part}"], scale), (name, row, part, want[f"{name}_{part}"]))
            self.assertEqual(row[7], str(want[f"{name}_n"]))

    def check_overview(self, rows, expected):
        for row in rows:
            want = expected[tuple(row[:3])]
            n = f"{want['finished']}" + (f" of {want['runs']}" if want["finished"] != want["runs"] else "")
            self.assertEqual(row[3], n)
            self.assertTrue(row[4].startswith(f"{want['successes']}/{want['finished']} ["), row)
            for text, (_, name) in zip(row[5:], QUANTITIES):
                mean, _, sd = text.partition(" ± ")
                scale = want[f"{name}_mean"] or 1.0
                self.assertTrue(agrees(mean, want[f"{name}_mean"], scale), (row, name))
                shown = agrees(sd, want[f"{name}_sd"], scale) if sd else want[f"{name}_sd"] is None
                self.assertTrue(shown, (row, name))

    def run_2d(self, name):
        """The built-in default experiment (2D, a fraction of a second) into a folder of its own."""
        out = os.path.join(self.tmp, name)
        run([EXE, "run", "builtin:default", "--out", out, "--quiet", "--set", "output.report=false"])
        return out

    def test_run_report_2d(self):
        """A 2D run's report shows the contours in the view, without errors."""
        out = self.run_2d("default2d")
        run([PYTHON, MAKE_REPORT, out, "--viewer", VIEWER, "--no-figures"])
        b, url = self.open(os.path.join(out, "report.html"), "run2d")
        self.wait_drawn(b)
        pixels = b.evaluate(CANVAS_PIXELS)
        self.assertGreater(pixels["drawn"], 1000, pixels)
        self.assertGreater(pixels["coloured"], 100, pixels)
        rect = b.evaluate("(() => { const c = document.querySelector('#dsnake-view canvas'); c.scrollIntoView();"
                          " const r = c.getBoundingClientRect();"
                          " return {x: r.x + scrollX, y: r.y + scrollY, width: r.width, height: r.height}; })()")
        b.screenshot(os.path.join(self.tmp, "run2d_view.png"), rect)
        self.assert_clean(b, url)

    def test_without_viewer(self):
        """Without a bundle the report is written with a note in place of the view, and says so."""
        out = self.run_2d("noviewer")
        env = dict(os.environ, DSNAKE_VIEWER_JS=os.path.join(self.tmp, "no-such-bundle.js"))
        made = run([PYTHON, MAKE_REPORT, out, "--no-figures"], env=env)
        self.assertIn("no interactive view", made.stderr)
        self.assertEqual(len(made.stderr.strip().splitlines()), 1, made.stderr)
        with open(os.path.join(out, "report.html")) as f:
            text = f.read()
        self.assertIn('id="no-viewer"', text)
        self.assertNotIn("DsnakeViewer", text)

    def assert_refused(self, folder, names, *extra):
        """make_report.py exits 2 with one line on stderr naming `names`, and writes nothing."""
        before = sorted(os.listdir(folder)) if os.path.isdir(folder) else None
        done = run([PYTHON, MAKE_REPORT, folder, "--no-figures", *extra], check=False)
        self.assertEqual(done.returncode, 2, done.stderr)
        lines = done.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, done.stderr)
        self.assertIn(names, lines[0])
        if before is not None:
            self.assertEqual(sorted(os.listdir(folder)), before, "a file was written")

    def test_bad_input(self):
        empty = os.path.join(self.tmp, "empty")
        os.makedirs(empty)
        self.assert_refused(empty, empty)
        self.assert_refused(os.path.join(self.tmp, "nowhere"), os.path.join(self.tmp, "nowhere"))
        good = self.run_2d("bad")
        self.assert_refused(good, "no-such.js", "--viewer", os.path.join(self.tmp, "no-such.js"))
        for name, damage in (("result.json", lambda t: t[:len(t) // 2]),
                             ("final.vtk", lambda t: t.replace("POINT_DATA", "POINT_DATA x", 1)),
                             ("final.vtk", lambda t: re.sub(r"\n[-0-9.e]+ ", "\nabc ", t, count=1)),
                             ("correspondence.csv", lambda t: t.replace("\n1,", "\n1,2,", 1))):
            folder = os.path.join(self.tmp, f"bad-{name}-{len(os.listdir(self.tmp))}")
            shutil.copytree(good, folder)
            path = os.path.join(folder, name)
            with open(path) as f:
                text = f.read()
            with open(path, "w") as f:
                f.write(damage(text))
            self.assert_refused(folder, path)
        sweep = os.path.join(self.tmp, "bad-sweep")
        os.makedirs(sweep)
        header = "run_id,method,corruption_level,corruption,seed,status,success\n"
        with open(os.path.join(sweep, "results.csv"), "w") as f:
            f.write(header + "a,m,0,clean,0,converged\n")
        self.assert_refused(sweep, os.path.join(sweep, "results.csv"))
        with open(os.path.join(sweep, "results.csv"), "w") as f:
            f.write(header + "a,m,0,clean,0,converged,true\n")
        self.assert_refused(sweep, os.path.join(sweep, "summary.csv"))
