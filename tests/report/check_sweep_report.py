#!/usr/bin/python3
"""Checks the report.html of a finished sweep, as the report test checks its small sweep: opened
alone in headless Chromium, it loads with no console or page error and no request besides itself
and data: URIs, and its tables equal pandas' statistics of the sweep's results.csv to the printed
digits. For sweeps too long for the test suite (the paper's star sweep, REPRODUCTION.md):

    /usr/bin/python3 tests/report/check_sweep_report.py SWEEP_DIR [--screenshot PNG]

Exit code 0 when every check passes.
"""
import argparse
import os
import sys
import unittest

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import test_report  # noqa: E402


class GivenSweep(test_report.ReportTest):
    folder = ""
    screenshot = ""

    def test_the_given_sweep(self):
        expected = test_report.expected_summary(os.path.join(self.folder, "results.csv"))
        b, url = self.open(os.path.join(self.folder, "report.html"), "given")
        if self.screenshot:
            b.screenshot(self.screenshot)
        self.check_success_table(b.evaluate(test_report.TABLE_CELLS % "summary-success"), expected)
        for _, name in test_report.QUANTITIES:
            self.check_quantity_table(b.evaluate(test_report.TABLE_CELLS % f"summary-{name}"), expected, name)
        self.check_overview(b.evaluate(test_report.TABLE_CELLS % "summary-overview"), expected)
        self.assert_clean(b, url)
        groups = len(expected)
        runs = sum(g["runs"] for g in expected.values())
        print(f"{self.folder}/report.html: {groups} groups, {runs} runs: tables equal pandas' statistics; "
              "no console or page error; nothing loaded besides the page")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("sweep_dir")
    ap.add_argument("--screenshot", default="")
    args = ap.parse_args()
    GivenSweep.folder = os.path.abspath(args.sweep_dir)
    GivenSweep.screenshot = os.path.abspath(args.screenshot) if args.screenshot else ""
    suite = unittest.defaultTestLoader.loadTestsFromName("test_the_given_sweep", GivenSweep)
    ok = unittest.TextTestRunner(verbosity=1).run(suite).wasSuccessful()
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
