#!/bin/bash
# Runs one real experiment of issue 20 and prints its table:
#   experiments/real/run.sh CASE        (CASE: a folder experiments/real/CASE/ holding sweep.json)
# Makes the inputs (data/real/CASE/, not committed) if they are missing, runs the sweep's runs one
# at a time into out/real/CASE/ (resumable: a finished run is skipped), and prints per method:
# Dice, mean surface distance, HD95 (mm), self-intersections, Euler characteristic, wall time and
# peak memory of the run (/usr/bin/time), and for the fixed_point methods the centroid's shift.
# Environment: DSNAKE (default build/release/experiments/dsnake), THREADS (OpenMP threads per run,
# default 2), PYTHON (default /usr/bin/python3: Debian's, with numpy and scipy).
#
# The runs are those of `dsnake sweep experiments/real/CASE/sweep.json --out out/real/CASE -j 1`,
# executed from its --manifest under /usr/bin/time so that each run's peak memory is known, then
# aggregated with --aggregate-only (out/real/CASE/results.csv).
#
# A run's id hashes its experiment, not its input files: after remaking the inputs, delete
# out/real/CASE/ (the inputs script is only run when data/real/CASE/ lacks them).
set -euo pipefail
cd "$(dirname "$0")/../.."
CASE=${1:?usage: experiments/real/run.sh CASE}
DSNAKE=$(realpath "${DSNAKE:-build/release/experiments/dsnake}")
THREADS=${THREADS:-2}
PYTHON=${PYTHON:-/usr/bin/python3}
SWEEP=experiments/real/$CASE/sweep.json
OUT=out/real/$CASE
[ -f "$SWEEP" ] || { echo "run.sh: no $SWEEP" >&2; exit 2; }

case $CASE in
  liver | femur) [ -f data/real/$CASE/inputs.json ] || "$PYTHON" experiments/real/make_3d_inputs.py "$DSNAKE" . "$CASE" ;;
  *) [ -d data/real/$CASE ] || "$PYTHON" experiments/real/make_2d_inputs.py "$DSNAKE" . ;;
esac

mkdir -p "$OUT/configs" "$OUT/time" "$OUT/logs"

"$DSNAKE" sweep "$SWEEP" --out "$OUT" --manifest parallel >/dev/null
while read -r line; do
  [ -n "$line" ] || continue
  id=$(sed -E 's|.* --out [^ ]*/runs/([^ ]+) .*|\1|' <<<"$line")
  echo "run.sh: $id" >&2
  cmd=${line/--threads 1/--threads $THREADS}
  cmd=${cmd/ --quiet/}
  if ! /usr/bin/time -f "%e %M" -o "$OUT/time/$id.txt" bash -c "$cmd" 2>"$OUT/logs/$id.log"; then
    echo "run.sh: $id failed: $(tail -1 "$OUT/logs/$id.log")" >&2
  fi
done <"$OUT/manifest.txt"
"$DSNAKE" sweep "$SWEEP" --out "$OUT" --aggregate-only >/dev/null

"$PYTHON" - "$OUT" <<'EOF'
import json, os, sys
import numpy as np

out = sys.argv[1]


def read_ply_or_off(path):
    """Vertices and triangles of final.ply / initial.ply (ASCII or binary little-endian) or .off."""
    raw = open(path, "rb").read()
    if path.endswith(".off"):
        tok = raw.decode().split()
        nv, nf = int(tok[1]), int(tok[2])
        v = np.array(tok[4:4 + 3 * nv], float).reshape(nv, 3)
        f = np.array(tok[4 + 3 * nv:4 + 3 * nv + 4 * nf], int).reshape(nf, 4)[:, 1:]
        return v, f
    end = raw.index(b"end_header\n") + len(b"end_header\n")
    head = raw[:end].decode().splitlines()
    fmt = next(l.split()[1] for l in head if l.startswith("format"))
    elems, cur = [], None
    for l in head:
        p = l.split()
        if p[0] == "element":
            cur = [p[1], int(p[2]), []]
            elems.append(cur)
        elif p[0] == "property":
            cur[2].append(p[1:])
    sizes = {"float": 4, "float32": 4, "double": 8, "float64": 8, "uchar": 1, "uint8": 1, "char": 1, "int8": 1,
             "int": 4, "int32": 4, "uint": 4, "uint32": 4, "short": 2, "int16": 2, "ushort": 2, "uint16": 2}
    codes = {"float": "f4", "float32": "f4", "double": "f8", "float64": "f8", "uchar": "u1", "uint8": "u1",
             "char": "i1", "int8": "i1", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
             "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2"}
    if fmt == "ascii":
        lines, k, v, f = raw[end:].decode().split("\n"), 0, None, None
        for name, n, props in elems:
            rows = [l.split() for l in lines[k:k + n]]
            k += n
            if name == "vertex":
                v = np.array([[float(x) for x in r[:3]] for r in rows])
            elif name == "face":
                f = np.array([[int(x) for x in r[1:4]] for r in rows])
        return v, f
    pos, v, f = end, None, None
    for name, n, props in elems:
        if name == "vertex":
            dt = np.dtype([(p[-1], "<" + codes[p[0]]) for p in props])
            a = np.frombuffer(raw, dt, n, pos)
            pos += n * dt.itemsize
            v = np.stack([a["x"], a["y"], a["z"]], 1).astype(float)
        elif name == "face":
            p = props[0]
            cnt, idx = codes[p[1]], codes[p[2]]
            step = sizes[p[1]] + 3 * sizes[p[2]]
            dt = np.dtype([("n", "<" + cnt), ("i", "<" + idx, 3)])
            a = np.frombuffer(raw, dt, n, pos)
            pos += n * step
            f = a["i"].astype(int)
    return v, f


def centroid(v, f):
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    w = np.einsum("ij,ij->i", a, np.cross(b, c))
    return (w[:, None] * (a + b + c)).sum(0) / (4.0 * w.sum())


def euler(f, nv):
    e = {tuple(sorted((t[i], t[(i + 1) % 3]))) for t in f for i in range(3)}
    return nv - len(e) + len(f)


import csv

rows = []
for run in csv.DictReader(open(f"{out}/results.csv")):  # the sweep's current runs (not stale ones in runs/)
    rid, method = run["run_id"], run["method"]
    d = f"{out}/runs/{rid}"
    if not os.path.exists(f"{d}/result.json"):
        print(f"{method:<18} missing")
        continue
    r = json.load(open(f"{d}/result.json"))
    m = r["metrics"]
    t = open(f"{out}/time/{rid}.txt").read().split() if os.path.exists(f"{out}/time/{rid}.txt") else ["nan", "0"]
    final = next((p for p in (f"{d}/final.ply", f"{d}/final.vtk") if os.path.exists(p) and p.endswith(".ply")), None)
    chi, shift = "-", "-"
    if "pose" in r:
        shift = f"{r['pose']['centroid_shift']:.2f}"
    if final:
        v, f = read_ply_or_off(final)
        chi = euler(f, len(v)) if f is not None else "-"
        if os.path.exists(f"{d}/initial.ply"):
            v0, f0 = read_ply_or_off(f"{d}/initial.ply")
            shift = f"{np.linalg.norm(centroid(v, f) - centroid(v0, f0)):.2f}"
    start = r.get("start", {}).get("metrics", {})
    if start:
        print(f"{method:<18} started at Dice {start['dice']:.4f}, msd {start['mean_surface_distance']:.3f} mm")
    rows.append((method, m.get("dice"), m.get("mean_surface_distance"), m.get("hausdorff95"), m.get("self_intersections"),
                 chi, r["vertices"]["final"], r.get("iterations"), float(t[0]), int(t[1]) / 1024.0,
                 r["timings"].get("metrics_s", 0.0), shift))
order = ["start", "classical", "paper", "recipe", "fixed_point_start", "fixed_point"]
rows.sort(key=lambda x: (order.index(x[0]) if x[0] in order else len(order), x[0]))
fmt = lambda x, p: "-" if x is None else (f"{x:.{p}f}" if isinstance(x, float) else str(x))
print(f"{'method':<18} {'Dice':>6} {'msd mm':>7} {'HD95 mm':>8} {'SI':>4} {'chi':>4} {'verts':>6} {'iters':>6} "
      f"{'wall s':>7} {'peak MB':>8} {'metrics s':>9} {'centroid shift mm':>17}")
for x in rows:
    print(f"{x[0]:<18} {fmt(x[1], 4):>6} {fmt(x[2], 3):>7} {fmt(x[3], 3):>8} {fmt(x[4], 0):>4} {x[5]:>4} {x[6]:>6} "
          f"{fmt(x[7], 0):>6} {x[8]:>7.1f} {x[9]:>8.0f} {x[10]:>9.1f} {x[11]:>17}")
EOF
