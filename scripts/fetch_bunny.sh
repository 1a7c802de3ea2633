#!/usr/bin/env bash
# Fetches the Stanford bunny for the bunny experiment (Fig. 10 of Levi & Gotsman's D-Snake) and
# writes it as a closed OFF mesh: data/bunny/bunny.off (data/ is not committed).
#
# Source: the npm package "bunny" (version 1.0.1, by Mikola Lysenko,
# https://github.com/mikolalysenko/bunny, licence "Public Domain" in its package.json), which
# holds the Stanford 3D Scanning Repository's bunny (http://graphics.stanford.edu/data/3Dscanrep/,
# Stanford University Computer Graphics Laboratory; please credit it) at a reduced resolution:
# 1839 vertices, 3674 triangles, as `exports.positions=[[x,y,z],...]` and
# `exports.cells=[[i,j,k],...]` in index.js.
#
# The original scan is open at its base. This version is already closed (V - E + F = 2, checked:
# "0 holes closed"); should a boundary loop remain, the conversion closes it with a fan of
# triangles about a new vertex at the loop's centroid, oriented like the neighbouring triangles, so
# the OFF mesh is always closed and manifold. Non-manifold input (an edge used twice in one
# direction, boundary loops sharing a vertex) is an error.
#
# Usage: scripts/fetch_bunny.sh [OUT.off]            (default: data/bunny/bunny.off)
#        scripts/fetch_bunny.sh --from-index index.js OUT.off   (convert a local index.js, no
#                                                               network; used by the tests)
# Idempotent: does nothing if OUT exists. Needs npm (network) and /usr/bin/python3 (no packages).
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
PYTHON=/usr/bin/python3

convert() {  # convert INDEX_JS OUT_OFF
  "$PYTHON" - "$1" "$2" <<'PYEOF'
import json, os, re, sys

src, out = sys.argv[1], sys.argv[2]
text = open(src).read()

def array(name):
    m = re.search(r"exports\.%s\s*=\s*(\[.*?\]\])" % name, text, re.S)
    if not m:
        sys.exit("fetch_bunny: %s: no exports.%s array" % (src, name))
    return json.loads(m.group(1))

positions = [[float(c) for c in p] for p in array("positions")]
cells = [[int(i) for i in c] for c in array("cells")]
n = len(positions)
for c in cells:
    if len(c) != 3 or min(c) < 0 or max(c) >= n or len(set(c)) != 3:
        sys.exit("fetch_bunny: %s: bad triangle %s" % (src, c))

# Directed edges: a closed oriented manifold has each directed edge once and its reverse once.
directed = {}
for t, c in enumerate(cells):
    for k in range(3):
        e = (c[k], c[(k + 1) % 3])
        if e in directed:
            sys.exit("fetch_bunny: %s: edge %s used twice in the same direction" % (src, e))
        directed[e] = t
# Boundary: directed edges without their reverse. Walk them into loops (a -> b in a triangle:
# the hole's boundary runs b -> a, so the closing triangles use (b, a, centre)).
nxt = {}
for (a, b) in directed:
    if (b, a) not in directed:
        if b in nxt:
            sys.exit("fetch_bunny: %s: vertex %d on two boundary loops (non-manifold)" % (src, b))
        nxt[b] = a
loops, seen = [], set()
for start in sorted(nxt):
    if start in seen:
        continue
    loop, v = [], start
    while v not in seen:
        seen.add(v)
        loop.append(v)
        v = nxt.get(v)
        if v is None:
            sys.exit("fetch_bunny: %s: open boundary chain" % src)
    if v != start:
        sys.exit("fetch_bunny: %s: boundary loops share a vertex" % src)
    loops.append(loop)
for loop in loops:
    centre = [sum(positions[v][a] for v in loop) / len(loop) for a in range(3)]
    positions.append(centre)
    c = len(positions) - 1
    for i in range(len(loop)):
        a, b = loop[i], loop[(i + 1) % len(loop)]
        cells.append([a, b, c])  # loop runs a -> b along the hole: reverse of the mesh's b -> a

used = set(i for c in cells for i in c)
if len(used) != len(positions):
    sys.exit("fetch_bunny: %s: %d unreferenced vertices" % (src, len(positions) - len(used)))
edges = set(tuple(sorted(e)) for c in cells for e in ((c[0], c[1]), (c[1], c[2]), (c[2], c[0])))
chi = len(positions) - len(edges) + len(cells)
os.makedirs(os.path.dirname(os.path.abspath(out)), exist_ok=True)
tmp = out + ".tmp"
with open(tmp, "w") as f:
    f.write("OFF\n%d %d 0\n" % (len(positions), len(cells)))
    for p in positions:
        f.write("%.9g %.9g %.9g\n" % tuple(p))
    for c in cells:
        f.write("3 %d %d %d\n" % tuple(c))
os.replace(tmp, out)
print("fetch_bunny: wrote %s: %d vertices, %d triangles, %d holes closed, V-E+F = %d"
      % (out, len(positions), len(cells), len(loops), chi))
PYEOF
}

if [[ "${1:-}" == "--from-index" ]]; then
  [[ $# -eq 3 ]] || { echo "usage: $0 --from-index index.js OUT.off" >&2; exit 2; }
  convert "$2" "$3"
  exit 0
fi

OUT="${1:-$ROOT/data/bunny/bunny.off}"
if [[ -s "$OUT" ]]; then
  echo "fetch_bunny: $OUT exists, nothing to do"
  exit 0
fi
command -v npm >/dev/null || { echo "fetch_bunny: npm not found (apt-get install npm)" >&2; exit 1; }
TMP="$(mktemp -d)"
trap 'rm -rf "$TMP"' EXIT
if ! (cd "$TMP" && npm pack bunny@1.0.1 --silent >/dev/null 2>"$TMP/npm.log"); then
  echo "fetch_bunny: 'npm pack bunny@1.0.1' failed (is the npm registry reachable?):" >&2
  tail -n 5 "$TMP/npm.log" >&2
  exit 1
fi
tar -xzf "$TMP"/bunny-1.0.1.tgz -C "$TMP"
convert "$TMP/package/index.js" "$OUT"
