"""experiments/real/anatomy/subdivide_template.py: the 1 -> 4 midpoint split keeps the surface (its
volume, its orientation, a closed manifold) and the input's vertices first; bad input is one line
naming the file, exit code 2, nothing written."""
import os
import subprocess
import tempfile
import unittest

HERE = os.path.dirname(os.path.abspath(__file__))
SCRIPT = os.path.join(HERE, "..", "..", "experiments", "real", "anatomy", "subdivide_template.py")

TETRA = """OFF
4 4 0
0 0 0
2 0 0
0 3 0
0 0 4
3 0 2 1
3 0 1 3
3 0 3 2
3 1 2 3
"""


def read_off(path):
    t = open(path).read().split()
    nv, nf = int(t[1]), int(t[2])
    points = [tuple(float(x) for x in t[4 + 3 * i:7 + 3 * i]) for i in range(nv)]
    at = 4 + 3 * nv
    faces = [tuple(int(x) for x in t[at + 4 * k + 1:at + 4 * k + 4]) for k in range(nf)]
    return points, faces


def volume(points, faces):  # signed, positive when the triangles face outwards
    v = 0.0
    for a, b, c in faces:
        (ax, ay, az), (bx, by, bz), (cx, cy, cz) = points[a], points[b], points[c]
        v += ax * (by * cz - bz * cy) - ay * (bx * cz - bz * cx) + az * (bx * cy - by * cx)
    return v / 6.0


class SubdivideTemplate(unittest.TestCase):
    def run_script(self, text):
        d = tempfile.mkdtemp()
        src, dst = os.path.join(d, "in.off"), os.path.join(d, "out.off")
        open(src, "w").write(text)
        r = subprocess.run(["/usr/bin/python3", SCRIPT, src, dst], capture_output=True, text=True)
        return r, src, dst, d

    def test_the_split_keeps_the_surface(self):
        r, src, dst, _ = self.run_script(TETRA)
        self.assertEqual(r.returncode, 0, r.stderr)
        p0, f0 = read_off(src)
        p1, f1 = read_off(dst)
        self.assertEqual((len(p1), len(f1)), (4 + 6, 16))  # V + E vertices, 4 F triangles
        self.assertEqual(p1[:4], p0)  # the input's vertices first, in order
        self.assertAlmostEqual(volume(p0, f0), 4.0)  # 2 * 3 * 4 / 6
        self.assertAlmostEqual(volume(p1, f1), volume(p0, f0), places=12)
        # closed and consistently oriented: every directed edge once, its reverse once
        directed = [(f[k], f[(k + 1) % 3]) for f in f1 for k in range(3)]
        self.assertEqual(len(set(directed)), len(directed))
        self.assertTrue(all((b, a) in set(directed) for a, b in directed))
        # every new vertex is the midpoint of an input edge
        edges = {(min(a, b), max(a, b)) for f in f0 for a, b in ((f[0], f[1]), (f[1], f[2]), (f[2], f[0]))}
        mids = {tuple(0.5 * (x + y) for x, y in zip(p0[a], p0[b])) for a, b in edges}
        self.assertEqual(set(p1[4:]), mids)

    def test_bad_input_is_one_line_and_exit_2(self):
        for text, words in [("OFF\n4 4 0\n0 0 0\n", "truncated"),
                            (TETRA.replace("3 1 2 3", "3 1 2 9"), "face 3"),
                            (TETRA.replace("3 1 2 3", "4 1 2 3 0"), "not a triangle"),
                            ("PLY\n", "not an OFF file")]:
            r, src, dst, d = self.run_script(text)
            self.assertEqual(r.returncode, 2, text)
            self.assertEqual(len(r.stderr.strip().splitlines()), 1, r.stderr)
            self.assertIn(src, r.stderr)
            self.assertIn(words, r.stderr)
            self.assertEqual(sorted(os.listdir(d)), ["in.off"])


if __name__ == "__main__":
    unittest.main()
