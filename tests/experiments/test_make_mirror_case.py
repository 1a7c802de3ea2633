"""experiments/real/anatomy/make_mirror_case.py: held-out AAL labels are refused before anything is
read or written, and bad arguments are one line, exit code 2, nothing written."""
import os
import subprocess
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "experiments", "real", "anatomy", "make_mirror_case.py")


class MakeMirrorCaseTest(unittest.TestCase):
    def run_script(self, *args):
        return subprocess.run(["/usr/bin/python3", SCRIPT, *args], capture_output=True, text=True)

    def assert_refused(self, r, words, out):
        self.assertEqual(r.returncode, 2, r.stderr)
        lines = r.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, r.stderr)
        self.assertTrue(lines[0].startswith("make_mirror_case.py: "), lines[0])
        for w in words:
            self.assertIn(w, lines[0])
        self.assertFalse(os.path.exists(out), "nothing may be written")

    def test_every_held_out_label_is_refused_on_either_side(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "out")
            for held in (37, 38, 71, 72, 73, 74, 77, 78):
                for left, right in ((held, 45), (45, held)):
                    r = self.run_script("/nonexistent/dsnake", out, "x", str(left), str(right))
                    self.assert_refused(r, ["held out", str(held)], out)

    def test_bad_arguments_are_one_line(self):
        with tempfile.TemporaryDirectory() as d:
            out = os.path.join(d, "out")
            self.assert_refused(self.run_script("dsnake", out), ["usage"], out)
            self.assert_refused(self.run_script("dsnake", out, "x", "left", "46"), ["integers", "'left'"], out)
            self.assert_refused(self.run_script("dsnake", out, "x", "45", "45"), ["two different"], out)
            self.assert_refused(self.run_script("dsnake", out, "a/b", "45", "46"), ["folder name"], out)


if __name__ == "__main__":
    unittest.main()
