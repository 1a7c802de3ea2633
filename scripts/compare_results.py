#!/usr/bin/env python3
"""Results-unchanged check: records what every single-experiment file gives, and compares two records.

    # 1. with the binary from before a change (one thread, experiments one at a time):
    python3 scripts/compare_results.py record --dsnake OLD_BIN --out /tmp/results_old
    # 2. with the binary after it:
    python3 scripts/compare_results.py record --dsnake build/release/experiments/dsnake --out /tmp/results_new
    # 3. compare: one line per experiment, exit status 1 if any differs beyond --tol
    python3 scripts/compare_results.py compare /tmp/results_old /tmp/results_new [--tol 1e-9]

record runs `BIN run FILE --out DIR/<name> --threads 1 --quiet [--set K=V ...]` for each experiment
file (default: every *.json under experiments/paper, experiments/examples and experiments/ablation;
sweep files, which have a "base" and a "grid" or "methods", are listed as skipped), and writes
DIR/index.json (per experiment: the file, its status, wall and CPU time, and from result.json the
"metrics" object, "success", "status", "iterations", the phases' iterations and statuses, the
vertex counts and the final energy) and DIR/TIMES.txt (the run times); an output folder left by an
earlier record (one holding a result.json) is removed before its experiment runs again, and
--resume keeps the experiments already recorded in DIR/index.json. An experiment whose input
files are missing (e.g. the Stanford bunny, fetched by scripts/fetch_bunny.sh) is skipped, and the
reason is printed and kept in index.json.

compare reads both index.json files and the final positions that dsnake wrote in each output
folder (2D: final.txt, one "x y" line per vertex; 3D: final.vtk, ASCII doubles, or final.ply if
there is no final.vtk), and prints per experiment "same" or "DIFFERENT" with the largest
difference: real numbers within --tol (absolute) are the same, counts and other values must be
equal; positions are compared coordinate by coordinate (largest absolute difference; the vertex
counts must agree).
Timings and the version string are not compared.

Python 3 standard library only.
"""
import argparse
import glob
import json
import math
import os
import resource
import shutil
import struct
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEFAULT_DIRS = ("experiments/paper", "experiments/examples", "experiments/ablation")
# Keys of an experiment file whose string values name input files (relative to the file's folder).
FILE_KEYS = ("mesh", "file", "path", "image_file", "volume", "template_file")
FILE_EXTS = (".off", ".obj", ".ply", ".stl", ".vtk", ".png", ".pgm", ".nii", ".nii.gz", ".mha",
             ".mhd", ".nrrd", ".raw", ".txt", ".csv")


# ----------------------------------------------------------------------------------------------
# record

def default_files():
    files = []
    for d in DEFAULT_DIRS:
        files += glob.glob(os.path.join(ROOT, d, "**", "*.json"), recursive=True)
    return sorted(files)


def is_sweep(cfg):
    return isinstance(cfg, dict) and "base" in cfg and ("grid" in cfg or "methods" in cfg)


def input_files(node, folder):
    """Every file named by the experiment (a string under one of FILE_KEYS or with a file-like
    extension), as a path resolved against the experiment file's folder."""
    found = []
    if isinstance(node, dict):
        for k, v in node.items():
            if isinstance(v, str) and (k in FILE_KEYS or v.lower().endswith(FILE_EXTS)):
                if not v.startswith("builtin:"):
                    found.append(os.path.normpath(os.path.join(folder, v)))
            else:
                found += input_files(v, folder)
    elif isinstance(node, list):
        for v in node:
            found += input_files(v, folder)
    return found


def unique_names(files):
    """Output folder name per file: the file's stem, or folder__stem where two stems collide."""
    stems = {}
    for f in files:
        stems.setdefault(os.path.splitext(os.path.basename(f))[0], []).append(f)
    names = {}
    for stem, fs in stems.items():
        for f in fs:
            if len(fs) == 1:
                names[f] = stem
            else:
                rel = os.path.relpath(os.path.splitext(f)[0], ROOT)
                names[f] = rel.replace(os.sep, "__")
    return names


def summarize(result):
    """The parts of result.json that must not change (no timings, no version, no config echo)."""
    return {
        "metrics": result.get("metrics"),
        "success": result.get("success"),
        "status": result.get("status"),
        "iterations": result.get("iterations"),
        "phases": [{k: p.get(k) for k in ("name", "iterations", "status")}
                   for p in result.get("phases", [])],
        "vertices": result.get("vertices"),
        "energy": result.get("energy"),
    }


def fmt_time(s):
    return "%.1f s" % s if s < 120 else "%.1f s (%.1f min)" % (s, s / 60.0)


def record(args):
    dsnake = os.path.abspath(args.dsnake)
    if not os.access(dsnake, os.X_OK):
        sys.exit("compare_results: %s is not an executable" % dsnake)
    files = [os.path.abspath(f) for f in (args.files or default_files())]
    names = unique_names(files)
    os.makedirs(args.out, exist_ok=True)
    index_path = os.path.join(args.out, "index.json")
    index = {"dsnake": dsnake, "set": args.set, "threads": args.threads, "experiments": {}}
    if args.resume and os.path.exists(index_path):
        with open(index_path) as f:
            index["experiments"] = json.load(f).get("experiments", {})
    version = subprocess.run([dsnake, "--version"], capture_output=True, text=True).stdout.strip()
    index["version"] = version
    print("compare_results: recording with %s (%s) into %s" % (dsnake, version or "?", args.out))

    for path in files:
        name = names[path]
        rel = os.path.relpath(path, ROOT)
        entry = {"file": rel}
        with open(path) as f:
            cfg = json.load(f)
        if is_sweep(cfg):
            entry["state"] = "sweep"
            entry["reason"] = "sweep file (not a single experiment)"
            print("  %-28s skipped: sweep file" % name)
            index["experiments"][name] = entry
            continue
        old = index["experiments"].get(name)
        if args.resume and old and old.get("state") == "ok":
            print("  %-28s kept from the earlier record (%s)" % (name, fmt_time(old["wall_s"])))
            continue
        missing = sorted(set(p for p in input_files(cfg, os.path.dirname(path)) if not os.path.exists(p)))
        if missing:
            entry["state"] = "skipped"
            hint = " (scripts/fetch_bunny.sh fetches it)" if any("bunny" in m for m in missing) else ""
            entry["reason"] = "missing input " + ", ".join(os.path.relpath(m, ROOT) for m in missing) + hint
            print("  %-28s SKIPPED: %s" % (name, entry["reason"]))
            index["experiments"][name] = entry
            continue
        out = os.path.join(args.out, name)
        if os.path.exists(os.path.join(out, "result.json")):
            shutil.rmtree(out)  # an earlier dsnake output folder: no stale files may remain
        cmd = [dsnake, "run", path, "--out", out, "--threads", str(args.threads), "--quiet"]
        for s in args.set:
            cmd += ["--set", s]
        print("  %-28s running ..." % name, end="", flush=True)
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.monotonic()
        try:
            proc = subprocess.run(cmd, capture_output=True, text=True, timeout=args.timeout)
            rc, err = proc.returncode, proc.stderr
        except subprocess.TimeoutExpired as e:
            rc, err = "timeout", (e.stderr or b"").decode(errors="replace") if isinstance(e.stderr, bytes) else (e.stderr or "")
        wall = time.monotonic() - t0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        entry["command"] = cmd
        entry["wall_s"] = round(wall, 3)
        entry["cpu_s"] = round((after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), 3)
        entry["max_rss_mb"] = round(after.ru_maxrss / 1024.0, 1)  # the largest child so far (Linux: KiB)
        result_path = os.path.join(out, "result.json")
        if rc != 0 or not os.path.exists(result_path):
            entry["state"] = "failed"
            entry["reason"] = "exit status %s: %s" % (rc, err.strip().splitlines()[-1] if err.strip() else "")
            print(" FAILED after %s: %s" % (fmt_time(wall), entry["reason"]))
        else:
            with open(result_path) as f:
                entry.update(summarize(json.load(f)))
            entry["state"] = "ok"
            entry["positions"] = positions_file(out)
            long_note = "  (longer than 3 min)" if wall > 180 else ""
            print(" %s, success %s, %s iterations%s"
                  % (fmt_time(wall), entry["success"], entry["iterations"], long_note))
        index["experiments"][name] = entry
        with open(index_path, "w") as f:  # after each experiment, so an interrupted record keeps its part
            json.dump(index, f, indent=1, sort_keys=True)

    with open(index_path, "w") as f:
        json.dump(index, f, indent=1, sort_keys=True)
    write_times(args.out, index)
    bad = [n for n, e in index["experiments"].items() if e["state"] in ("failed", "skipped")]
    if bad:
        print("compare_results: not recorded: " + ", ".join(sorted(bad)))
    print("compare_results: wrote %s and %s" % (index_path, os.path.join(args.out, "TIMES.txt")))
    return 1 if any(e["state"] == "failed" for e in index["experiments"].values()) else 0


def write_times(out, index):
    lines = ["# Run times of `dsnake run FILE --threads 1 --quiet`, one experiment at a time",
             "# binary: %s (%s)" % (index["dsnake"], index.get("version", "")),
             "# %-26s %-10s %10s %10s  %s" % ("experiment", "state", "wall_s", "cpu_s", "file / note")]
    total = 0.0
    for name, e in sorted(index["experiments"].items()):
        if e["state"] in ("ok", "failed"):
            total += e["wall_s"]
            note = e["file"]
            if e["state"] == "failed":
                note += "  FAILED: " + e.get("reason", "")
            elif e["wall_s"] > 180:
                note += "  (longer than 3 min)"
            lines.append("%-28s %-10s %10.1f %10.1f  %s" % (name, e["state"], e["wall_s"], e["cpu_s"], note))
        else:
            lines.append("%-28s %-10s %10s %10s  %s: %s" % (name, e["state"], "-", "-", e["file"], e.get("reason", "")))
    lines.append("# total wall time: %.1f s (%.1f min)" % (total, total / 60.0))
    with open(os.path.join(out, "TIMES.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")


# ----------------------------------------------------------------------------------------------
# final positions

def positions_file(folder):
    for fname in ("final.txt", "final.vtk", "final.ply"):
        if os.path.exists(os.path.join(folder, fname)):
            return fname
    return None


def read_txt(path):
    pts = []
    with open(path) as f:
        for line in f:
            line = line.split("#", 1)[0].strip()
            if line:
                pts.append([float(v) for v in line.replace(",", " ").split()])
    return pts


def read_vtk(path):
    with open(path, "rb") as f:
        data = f.read()
    header = data[:1024].decode("ascii", errors="replace").splitlines()
    if len(header) < 3 or header[2].strip().upper() != "ASCII":
        raise ValueError("%s: only ASCII legacy VTK is read" % path)
    tokens = data.decode("ascii", errors="replace").split()
    i = tokens.index("POINTS")
    n = int(tokens[i + 1])
    vals = [float(v) for v in tokens[i + 3:i + 3 + 3 * n]]
    return [vals[3 * k:3 * k + 3] for k in range(n)]


PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
             "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
             "float": "f", "float32": "f", "double": "d", "float64": "d"}


def read_ply(path):
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header")
    end = data.index(b"\n", end) + 1
    header = data[:end].decode("ascii").splitlines()
    fmt, elements = None, []
    for line in header:
        w = line.split()
        if not w:
            continue
        if w[0] == "format":
            fmt = w[1]
        elif w[0] == "element":
            elements.append((w[1], int(w[2]), []))
        elif w[0] == "property":
            elements[-1][2].append(w[1:])
    if not elements or elements[0][0] != "vertex":
        raise ValueError("%s: the first element is not 'vertex'" % path)
    name, n, props = elements[0]
    if any(p[0] == "list" for p in props):
        raise ValueError("%s: list property in the vertex element" % path)
    names = [p[1] for p in props]
    axes = [names.index(a) for a in ("x", "y", "z") if a in names]
    if fmt == "ascii":
        lines = data[end:].decode("ascii").split("\n")
        rows = [[float(v) for v in lines[k].split()[:len(props)]] for k in range(n)]
    else:
        order = "<" if fmt == "binary_little_endian" else ">"
        st = struct.Struct(order + "".join(PLY_TYPES[p[0]] for p in props))
        rows = [st.unpack_from(data, end + k * st.size) for k in range(n)]
    return [[float(r[a]) for a in axes] for r in rows]


def read_positions(folder, fname):
    path = os.path.join(folder, fname)
    if fname.endswith(".txt"):
        return read_txt(path)
    if fname.endswith(".vtk"):
        return read_vtk(path)
    return read_ply(path)


# ----------------------------------------------------------------------------------------------
# compare

def diff_values(a, b, key, tol, out):
    """Appends (difference, key, a, b) for every leaf that differs; numbers within tol are equal."""
    num = (int, float)
    if isinstance(a, bool) or isinstance(b, bool) or not (isinstance(a, num) and isinstance(b, num)):
        if isinstance(a, dict) and isinstance(b, dict):
            for k in sorted(set(a) | set(b)):
                diff_values(a.get(k, "<absent>"), b.get(k, "<absent>"), key + "." + k if key else k, tol, out)
        elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
            for i, (x, y) in enumerate(zip(a, b)):
                diff_values(x, y, "%s[%d]" % (key, i), tol, out)
        elif a != b:
            out.append((math.inf, key, a, b))
        return
    if isinstance(a, int) and isinstance(b, int):  # counts (iterations, vertices): exactly
        if a != b:
            out.append((abs(a - b), key, a, b))
        return
    if math.isnan(a) and math.isnan(b):
        return
    d = abs(a - b)
    if math.isnan(d) or d > tol:
        out.append((d if not math.isnan(d) else math.inf, key, a, b))


def load_index(folder):
    path = os.path.join(folder, "index.json")
    if os.path.exists(path):
        with open(path) as f:
            return json.load(f)["experiments"]
    # A folder of dsnake output folders without an index: read each result.json.
    exps = {}
    for d in sorted(os.listdir(folder)):
        rp = os.path.join(folder, d, "result.json")
        if os.path.exists(rp):
            with open(rp) as f:
                e = summarize(json.load(f))
            e.update(state="ok", file=d, positions=positions_file(os.path.join(folder, d)))
            exps[d] = e
    return exps


def compare_positions(old_dir, new_dir, e_old, e_new):
    """(largest difference, description); inf if the positions cannot be compared."""
    for d, side in ((old_dir, "OLD"), (new_dir, "NEW")):
        if not os.path.isdir(d):
            return math.inf, "no output folder %s in %s" % (os.path.basename(d), side)
    f_old = positions_file(old_dir)
    f_new = positions_file(new_dir)
    if f_old is None and f_new is None:
        return 0.0, "no final positions"
    if f_old is None or f_new is None:
        return math.inf, "final positions: %s vs %s" % (f_old, f_new)
    # Same kind of file on both sides: final.txt (2D) or final.vtk / final.ply (3D).
    fname = f_old if os.path.exists(os.path.join(new_dir, f_old)) else None
    if fname is None:
        return math.inf, "final positions in %s (old) vs %s (new)" % (f_old, f_new)
    p_old = read_positions(old_dir, fname)
    p_new = read_positions(new_dir, fname)
    if len(p_old) != len(p_new):
        return math.inf, "%s: %d vertices vs %d" % (fname, len(p_old), len(p_new))
    worst, where = 0.0, None
    for i, (a, b) in enumerate(zip(p_old, p_new)):
        if len(a) != len(b):
            return math.inf, "%s: vertex %d has %d vs %d coordinates" % (fname, i, len(a), len(b))
        for c, (x, y) in enumerate(zip(a, b)):
            d = abs(x - y)
            if math.isnan(d):
                d = 0.0 if (math.isnan(x) and math.isnan(y)) else math.inf
            if d > worst:
                worst, where = d, (i, "xyz"[c], x, y)
    desc = "%s, %d vertices" % (fname, len(p_old))
    if where:
        desc += ", largest at vertex %d %s: %.17g vs %.17g" % where
    return worst, desc


def compare(args):
    old = load_index(args.old)
    new = load_index(args.new)
    if not old:
        sys.exit("compare_results: %s holds no recorded experiments" % args.old)
    n_diff = 0
    n_same = 0
    for name in sorted(set(old) | set(new)):
        eo, en = old.get(name), new.get(name)
        if eo is None or en is None:
            n_diff += 1
            print("DIFFERENT %-28s only in %s" % (name, "NEW" if eo is None else "OLD"))
            continue
        if eo["state"] != "ok" or en["state"] != "ok":
            if eo["state"] == en["state"] and eo["state"] in ("sweep", "skipped"):
                print("skipped   %-28s %s" % (name, eo.get("reason", eo["state"])))
            elif eo["state"] == en["state"] == "failed" and eo.get("reason") == en.get("reason"):
                # a run that fails on purpose (the classical snake collapsing under the watchdog)
                # must fail the same way
                print("same      %-28s both failed alike (%s)" % (name, eo.get("reason", "")))
            else:
                n_diff += 1
                print("DIFFERENT %-28s old %s, new %s (%s)"
                      % (name, eo["state"], en["state"], en.get("reason") or eo.get("reason", "")))
            continue
        diffs = []
        for key in ("metrics", "success", "status", "iterations", "phases", "vertices", "energy"):
            diff_values(eo.get(key), en.get(key), key, args.tol, diffs)
        pos_d, pos_desc = compare_positions(os.path.join(args.old, name), os.path.join(args.new, name), eo, en)
        if diffs or pos_d > args.tol:
            n_diff += 1
            parts = []
            if pos_d > args.tol:
                parts.append("positions max |d| %.3g (%s)" % (pos_d, pos_desc))
            diffs.sort(key=lambda t: -t[0])
            for d, key, a, b in diffs[:4]:
                parts.append("%s: %r -> %r%s" % (key, a, b, "" if math.isinf(d) else " (|d| %.3g)" % d))
            if len(diffs) > 4:
                parts.append("... %d more result.json values" % (len(diffs) - 4))
            print("DIFFERENT %-28s %s" % (name, "; ".join(parts)))
        else:
            n_same += 1
            print("same      %-28s positions max |d| %.3g (%s)" % (name, pos_d, pos_desc.split(", largest")[0]))
    print("compare_results: %d same, %d different (tol %g)" % (n_same, n_diff, args.tol))
    return 1 if n_diff else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter,
                                 epilog="\n".join(__doc__.splitlines()[1:]))
    sub = ap.add_subparsers(dest="mode", required=True)
    r = sub.add_parser("record", help="run every single-experiment file and keep its results")
    r.add_argument("--dsnake", default=os.path.join(ROOT, "build/release/experiments/dsnake"),
                   help="the dsnake binary (default: build/release/experiments/dsnake)")
    r.add_argument("--out", required=True, help="folder for the output folders, index.json and TIMES.txt")
    r.add_argument("--files", nargs="+", help="experiment files (default: experiments/{paper,examples,ablation}/**/*.json)")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="passed to every run as --set KEY=VALUE (repeatable)")
    r.add_argument("--threads", type=int, default=1, help="--threads for dsnake (default 1)")
    r.add_argument("--timeout", type=float, default=None, help="seconds per experiment (default: none)")
    r.add_argument("--resume", action="store_true",
                   help="keep the experiments already recorded in OUT/index.json, run the others")
    c = sub.add_parser("compare", help="compare two records; exit status 1 if any experiment differs")
    c.add_argument("old")
    c.add_argument("new")
    c.add_argument("--tol", type=float, default=1e-9, help="largest absolute difference taken as equal (default 1e-9)")
    args = ap.parse_args()
    return record(args) if args.mode == "record" else compare(args)


if __name__ == "__main__":
    sys.exit(main())
