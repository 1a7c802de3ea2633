#!/usr/bin/python3
"""Splits every triangle of a closed OFF mesh 1 -> 4 at its edges' midpoints (the same surface,
four times the triangles): the denser-template control of REPRODUCTION.md's real-anatomy section,
which asks whether the recipe's Dice is limited by the template's resolution.

  subdivide_template.py IN.off OUT.off

The first vertices are IN's, in order; each edge's midpoint follows, in the order the triangles
first reach the edge. Bad input: one line naming the file, exit 2, nothing written.
"""
import os
import sys


def fail(message):
    print(f"subdivide_template.py: {message}", file=sys.stderr)
    sys.exit(2)


def read_off(path):
    try:
        tokens = open(path).read().split()
        if not tokens or tokens[0] != "OFF":
            raise ValueError("not an OFF file")
        nv, nf = int(tokens[1]), int(tokens[2])
        points = [tuple(float(x) for x in tokens[4 + 3 * i:7 + 3 * i]) for i in range(nv)]
        at = 4 + 3 * nv
        faces = []
        for _ in range(nf):
            if int(tokens[at]) != 3:
                raise ValueError(f"face {len(faces)} is not a triangle")
            face = tuple(int(x) for x in tokens[at + 1:at + 4])
            if len(face) != 3 or not all(0 <= v < nv for v in face):
                raise ValueError(f"face {len(faces)} has a vertex index out of range")
            faces.append(face)
            at += 4
        if any(len(p) != 3 for p in points):
            raise ValueError("too few vertex coordinates")
        return points, faces
    except IndexError:
        fail(f"{path}: truncated (fewer numbers than its header counts)")
    except (OSError, ValueError) as e:
        fail(f"{path}: {e}")


def main():
    if len(sys.argv) != 3:
        fail("usage: subdivide_template.py IN.off OUT.off")
    points, faces = read_off(sys.argv[1])
    midpoint = {}

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in midpoint:
            midpoint[key] = len(points)
            points.append(tuple(0.5 * (x + y) for x, y in zip(points[a], points[b])))
        return midpoint[key]

    out = []
    for a, b, c in faces:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    tmp = sys.argv[2] + ".part"
    with open(tmp, "w") as f:
        f.write(f"OFF\n{len(points)} {len(out)} 0\n")
        f.writelines("%.9g %.9g %.9g\n" % p for p in points)
        f.writelines("3 %d %d %d\n" % t for t in out)
    os.replace(tmp, sys.argv[2])


if __name__ == "__main__":
    main()
