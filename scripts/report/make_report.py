#!/usr/bin/python3
"""report.html for a dsnake output folder: one self-contained page (docs/reports.md).

    /usr/bin/python3 scripts/report/make_report.py DIR [--viewer BUNDLE] [--no-figures]

DIR is a run folder (`dsnake run`: result.json) or a sweep folder (`dsnake sweep`: results.csv,
summary.csv). The page needs no network and no other file: the figures are embedded as data:
URIs, the viewer's JavaScript and the mesh are inlined.

- Run: the run's name and description, its metrics with units against its success thresholds,
  iterations, phases, timings, energy, provenance (build, host, command line, input files with
  their SHA-256), every PNG of the folder with a caption, and an interactive view of final.vtk
  (3D: the mesh, rotatable, coloured by error or displacement in mm; 2D: the contours), with
  initial.vtk on request. The figures (energy.png, convergence.png, render.png) are drawn first
  by scripts/figures/run_figures.py unless --no-figures.
- Sweep: summary.csv's tables (per method x grid point x corruption level: n, mean, SD and 95%
  confidence interval of Dice, MSD, HD95, correspondence error and time; success rate with its
  Wilson interval), breakdown.csv's levels, the figures in the folder, the count of finished,
  unfinished and stale runs, and every run with a relative link to its report.html if it has one.

The viewer bundle (viewer/, built by the CMake target dsnake_viewer) is --viewer, else
$DSNAKE_VIEWER_JS, else <repo>/build/release/viewer/dsnake_viewer.js; without one the page says
so where the view would be, and one line on stderr says so too.

report.html is written atomically (a temporary file in DIR, then renamed). Exit codes: 0 written;
2 bad input (no result.json or results.csv, a malformed file, a --viewer that cannot be read):
one line on stderr naming the file, nothing written; 1 report.html could not be written.
"""
import argparse
import base64
import datetime
import html
import json
import math
import os
import re
import shlex
import struct
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
DEFAULT_VIEWER = os.path.join(REPO, "build", "release", "viewer", "dsnake_viewer.js")
# The figure scripts and their readers of dsnake's files (scripts/figures/common.py: InputError,
# read_csv_records, read_polydata), shared with this script.
sys.path.insert(0, os.path.join(HERE, "..", "figures"))
from common import InputError, read_csv_records, read_polydata  # noqa: E402
import run_figures  # noqa: E402  (matplotlib is imported when a figure is drawn)
SWEEP_DIGITS = 4  # significant digits of the sweep's numbers (summary.csv holds ten)
RUN_DIGITS = 4    # and of a run's metrics

# result.json's metrics: key, name, unit, what it measures. Lengths are world millimetres
# (docs/output.md: all positions are LPS mm); Dice is a fraction of the interiors.
METRICS = (
    ("dice", "Dice", "", "overlap of the result's interior with the ground truth's (1: identical)"),
    ("mean_surface_distance", "mean surface distance", "mm", "symmetric mean distance between the surfaces"),
    ("hausdorff95", "HD95", "mm", "95th percentile of the symmetric surface distances"),
    ("hausdorff", "Hausdorff distance", "mm", "largest surface distance"),
    ("correspondence_error_mean", "mean correspondence error", "mm",
     "template vertices' mean distance to their true positions"),
    ("correspondence_error_max", "largest correspondence error", "mm", "the same, largest"),
    ("self_intersections", "self-intersections", "count", "crossing edges (2D) or intersecting triangles (3D)"),
)
# The thresholds without a "success" object (docs/experiment-file.md), each where the ground
# truth gives the metric.
DEFAULT_THRESHOLDS = {"mean_surface_distance": 1.0, "hausdorff95": 2.0, "correspondence_error_max": 2.0,
                      "dice": 0.9, "self_intersections": 0}
# summary.csv's quantities: column prefix, heading, unit.
QUANTITIES = (("dice", "Dice", ""), ("mean_surface_distance_mm", "mean surface distance", "mm"),
              ("hausdorff95_mm", "HD95", "mm"), ("correspondence_error_mean_mm", "mean correspondence error", "mm"),
              ("time_s", "time", "s"))
SUCCESS_COLUMNS = ("method", "grid", "corruption_level", "corruption", "runs", "finished", "stale", "successes",
                   "success_rate", "success_ci95_low", "success_ci95_high")
RESULTS_COLUMNS = ("run_id", "method", "corruption_level", "corruption", "seed", "status", "success")
FIGURE_CAPTIONS = {
    "overlay.png": "The image with the placed template (yellow), the result (red) and the ground truth (cyan) "
                   "when there is one; thin green lines join template vertices to where they landed.",
    "slices.png": "Three orthogonal slices through the result (radiological convention of LPS): the placed "
                  "template in yellow, the result in red, the ground truth in cyan; each panel gives its "
                  "position in mm.",
    "render.png": "The final mesh from three sides, coloured by each vertex's error (mm) where the ground truth "
                  "gives its true position (grey elsewhere), else by its displacement (mm).",
    "energy.png": "The weighted energy terms and their total per iteration (energy_trace.csv); the terms do "
                  "not share a unit.",
    "convergence.png": "The largest vertex move (mm) per iteration, and the vertex count where remeshing "
                       "changes it.",
    "success_rates.png": "Success rate per corruption level and method (scripts/figures/success_rates.py).",
}
FIGURE_ORDER = ("overlay.png", "slices.png", "render.png", "energy.png", "convergence.png")


# ---------------------------------------------------------------------------------------------
# Reading


def read_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        raise InputError(f"{path}: cannot be read: {e.strerror}") from None
    except ValueError as e:
        raise InputError(f"{path}: not JSON ({e})") from None


def read_csv(path, needed=()):
    """(header, rows as dicts) of a CSV file whose rows all have the header's length."""
    header, records = read_csv_records(path)
    for column in needed:
        if column not in header:
            raise InputError(f'{path}: no column "{column}"')
    rows = []
    for number, record in records:
        if len(record) != len(header):
            raise InputError(f"{path}: row {number} has {len(record)} fields, the header {len(header)}")
        rows.append(dict(zip(header, record)))
    return header, rows


# ---------------------------------------------------------------------------------------------
# HTML helpers


def esc(value):
    return html.escape(str(value), quote=True)


def fmt(value, digits):
    """A number to `digits` significant digits ("–" for none); other values as they are."""
    if value is None or value == "":
        return "–"
    if isinstance(value, bool):
        return "yes" if value else "no"
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not math.isfinite(x):
        return "–"
    return f"{x:.{digits}g}"


def number_cell(value, digits):
    """A <td> with the number to `digits` significant digits and its full value as its title."""
    text = fmt(value, digits)
    title = "" if text == "–" else f' title="{esc(value)}"'
    return f'<td class="num"{title}>{esc(text)}</td>'


def table(headers, rows, table_id=None, caption=None):
    """An HTML table; each row is a list of ready <td> strings or of plain values (escaped)."""
    parts = [f'<table{f" id={chr(34)}{esc(table_id)}{chr(34)}" if table_id else ""}>']
    if caption:
        parts.append(f"<caption>{caption}</caption>")
    parts.append("<thead><tr>" + "".join(f"<th>{esc(h)}</th>" for h in headers) + "</tr></thead><tbody>")
    for row in rows:
        cells = (c if isinstance(c, str) and c.startswith("<td") else f"<td>{esc(c)}</td>" for c in row)
        parts.append("<tr>" + "".join(cells) + "</tr>")
    parts.append("</tbody></table>")
    return "".join(parts)


def png_info(path):
    """(data: URI, width, height) of a PNG file; InputError when it is not one."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError as e:
        raise InputError(f"{path}: cannot be read: {e.strerror}") from None
    if len(data) < 24 or data[:8] != b"\x89PNG\r\n\x1a\n" or data[12:16] != b"IHDR":
        raise InputError(f"{path}: not a PNG image")
    width, height = struct.unpack(">II", data[16:24])
    return "data:image/png;base64," + base64.b64encode(data).decode("ascii"), width, height


def figures_section(folder, names):
    """Every PNG of `names` (in the report's order) as an embedded figure with its caption."""
    ordered = [n for n in FIGURE_ORDER if n in names] + sorted(n for n in names if n not in FIGURE_ORDER)
    if not ordered:
        return "<section id=\"figures\"><h2>Figures</h2><p>The folder holds no PNG figure.</p></section>"
    parts = ['<section id="figures"><h2>Figures</h2>']
    for name in ordered:
        uri, width, height = png_info(os.path.join(folder, name))
        caption = FIGURE_CAPTIONS.get(name, "")
        parts.append(f'<figure><img src="{uri}" width="{width}" height="{height}" alt="{esc(name)}">'
                     f"<figcaption><code>{esc(name)}</code>{': ' + esc(caption) if caption else ''}"
                     "</figcaption></figure>")
    parts.append("</section>")
    return "".join(parts)


STYLE = """
body{font:14px/1.45 system-ui,sans-serif;margin:0 auto;max-width:1200px;padding:12px 20px;color:#222}
h1{font-size:22px;margin:8px 0 4px}h2{font-size:18px;border-bottom:1px solid #ccc;margin-top:28px}
table{border-collapse:collapse;margin:8px 0 14px;font-size:13px}caption{text-align:left;padding:2px 0;color:#444}
th,td{border:1px solid #ccc;padding:3px 7px;vertical-align:top}th{background:#f2f2f2;text-align:left}
td.num{text-align:right;font-variant-numeric:tabular-nums}.ok{color:#17701a;font-weight:600}
.bad{color:#b00020;font-weight:600}.note{background:#fff6d6;border:1px solid #e5cf7a;padding:6px 10px}
figure{margin:12px 0 20px}figure img{max-width:100%;height:auto;border:1px solid #ddd}
figcaption{color:#444;font-size:13px}pre{background:#f6f6f6;padding:8px;overflow:auto;font-size:12px}
.viewer{width:100%;height:560px;border:1px solid #ccc}.muted{color:#666}.wide{overflow-x:auto}
#summary-overview td{white-space:nowrap}
"""


def page(title, subtitle, body):
    made = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M:%S UTC")
    return ("<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<meta name=\"viewport\" content=\"width=device-width,initial-scale=1\"><title>{esc(title)}</title>"
            f"<style>{STYLE}</style></head><body><header><h1>{esc(title)}</h1>"
            f"<p class=\"muted\">{subtitle}</p></header>{body}"
            f"<footer class=\"muted\"><hr>Written {made} by scripts/report/make_report.py (docs/reports.md).</footer>"
            "</body></html>\n")


# ---------------------------------------------------------------------------------------------
# The interactive view


def encode(array, dtype):
    """{dtype, b64}: a little-endian typed array for the viewer (viewer/src/viewer.js)."""
    import numpy as np
    names = {"<f4": "f32", "<u2": "u16", "<u4": "u32"}
    data = np.ascontiguousarray(array, dtype=np.dtype(dtype)).tobytes()
    return {"dtype": names[dtype], "b64": base64.b64encode(data).decode("ascii")}


def mesh_arrays(mesh):
    cells = mesh.get("triangles", mesh.get("segments"))
    return {"vertex_count": int(len(mesh["points"])),
            "positions": encode(mesh["points"], "<f4"),
            "cells": encode(cells.ravel(), "<u2" if len(mesh["points"]) < 65536 else "<u4"),
            "cell_type": "triangles" if "triangles" in mesh else "segments",
            "cell_count": int(len(cells))}


def mesh_payload(final, initial, dimension):
    """The viewer's data: the final shape with its scalars, the placed template, the colour
    scale. Error where has_target is 1, displacement where the vertex is a template vertex; NaN
    (no value) elsewhere."""
    import numpy as np
    arrays = final["arrays"]
    n = len(final["points"])
    scalars, values = {}, {}
    has_target = arrays.get("has_target")
    if has_target is not None and "error" in arrays and np.any(has_target > 0.5):
        values["error"] = np.where((has_target > 0.5) & (arrays["error"] >= 0), arrays["error"], np.nan)
        scalars["error"] = {"name": "error", "label": "distance to the vertex's true position",
                            "no_value": "no true position (a vertex that remeshing inserted)"}
    if "displacement" in arrays:
        # final.vtk writes displacement 0 for a vertex that remeshing inserted (template_id -1: it
        # has no template position, docs/output.md); the view shows such vertices as "no value".
        template_id = arrays.get("template_id")
        free = template_id < 0 if template_id is not None else np.zeros(n, dtype=bool)
        values["displacement"] = np.where(free, np.nan, arrays["displacement"])
        scalars["displacement"] = {"name": "displacement", "label": "distance from the vertex's template position",
                                   "no_value": "no template position (a vertex that remeshing inserted)"}
    if not values:  # a mesh without dsnake's arrays: one colour
        values["none"] = np.zeros(n)
        scalars["none"] = {"name": "none", "label": "the file has no per-vertex values"}
    for name, v in values.items():
        finite = v[np.isfinite(v)]
        top = float(finite.max()) if finite.size else 1.0
        scalars[name].update(min=0.0, max=top if top > 0 else 1.0, vertices=int(finite.size))
    meshes = {"final": dict(mesh_arrays(final), scalars={k: encode(v, "<f4") for k, v in values.items()})}
    if initial is not None:
        meshes["initial"] = mesh_arrays(initial)
    return {"dimension": dimension, "unit": "mm", "colour_by": next(iter(values)), "scalars": scalars,
            "meshes": meshes}


def inline_script(text):
    """JavaScript or JSON made safe inside <script>: no "</script" and no "<!--" (both are
    rewritten with a backslash, which JavaScript strings and JSON read the same)."""
    text = re.sub(r"</(script)", r"<\\/\1", text, flags=re.IGNORECASE)
    return text.replace("<!--", "<\\!--")


def view_section(payload, bundle_text, bundle_note):
    heading = "Interactive 3D view" if payload["dimension"] == 3 else "Interactive view of the contours"
    if bundle_text is None:
        return (f'<section id="view"><h2>{heading}</h2><p class="note" id="no-viewer">No interactive view: '
                f"{esc(bundle_note)}</p></section>")
    scalars = payload["scalars"]
    how = ("Drag to rotate, wheel to zoom, right-drag to pan; “reset view” frames it again."
           if payload["dimension"] == 3 else "The view from above the image plane (y down, as in overlay.png): "
           "wheel to zoom, drag to pan.")
    colour = "; ".join(f"<b>{esc(k)}</b> ({esc(v['label'])}; {v['vertices']} vertices, 0 to {fmt(v['max'], 3)} mm)"
                       for k, v in scalars.items())
    data = json.dumps(payload, separators=(",", ":")).replace("<", "\\u003c")
    return (f'<section id="view"><h2>{heading}</h2><div id="dsnake-view" class="viewer"></div>'
            f"<p class=\"caption\">final.vtk, coloured per vertex by {colour}; grey: no value. "
            f"Tick “placed template” to show initial.vtk (yellow). {how}</p>"
            f"<script>{inline_script(bundle_text)}</script>"
            f'<script type="application/json" id="dsnake-mesh">{data}</script>'
            "<script>DsnakeViewer.show(document.getElementById('dsnake-view'),"
            "JSON.parse(document.getElementById('dsnake-mesh').textContent));</script></section>")


def find_viewer(explicit):
    """(bundle text or None, why not). --viewer must be readable; the environment's or the
    build's bundle may be absent."""
    if explicit:
        try:
            with open(explicit, encoding="utf-8") as f:
                return f.read(), ""
        except (OSError, UnicodeDecodeError) as e:
            raise InputError(f"{explicit}: the viewer bundle (--viewer) cannot be read: "
                             f"{getattr(e, 'strerror', None) or e}") from None
    path = os.environ.get("DSNAKE_VIEWER_JS") or DEFAULT_VIEWER
    try:
        with open(path, encoding="utf-8") as f:
            return f.read(), ""
    except (OSError, UnicodeDecodeError):
        return None, (f"the viewer bundle {path} is missing (build the CMake target dsnake_viewer, or give "
                      "--viewer or $DSNAKE_VIEWER_JS).")


# ---------------------------------------------------------------------------------------------
# A run's report


def read_run(run_dir):
    """result.json, checked for what the report reads."""
    path = os.path.join(run_dir, "result.json")
    result = read_json(path)
    if not isinstance(result, dict) or not isinstance(result.get("name"), str):
        raise InputError(f'{path}: not a dsnake result: no "name"')
    for key, kind in (("metrics", dict), ("config", dict), ("timings", dict), ("phases", list),
                      ("provenance", dict), ("vertices", dict)):
        if key in result and not isinstance(result[key], kind):
            raise InputError(f'{path}: "{key}" is not a JSON {"object" if kind is dict else "array"}')
    return result


def thresholds_of(result):
    """{metric: (comparison, threshold)} of the run and whether they are the defaults."""
    config = result.get("config") or {}
    given = config.get("success")
    limits = given if isinstance(given, dict) else DEFAULT_THRESHOLDS
    out = {k: (">=" if k == "dice" else "<=", v) for k, v in limits.items() if isinstance(v, (int, float))}
    return out, not isinstance(given, dict)


def outcome_section(result):
    success, status = result.get("success"), result.get("status", "?")
    verdict = ('<span class="ok">met its thresholds</span>' if success is True
               else '<span class="bad">did not meet its thresholds</span>')
    rows = [("success", verdict), ("status", esc(status))]
    if result.get("failure"):
        rows.append(("why", esc(result["failure"])))
    divergence = result.get("divergence")
    if isinstance(divergence, dict):
        rows.append(("stopped by the watchdog", esc(json.dumps(divergence))))
    return ('<section id="outcome"><h2>Outcome</h2><table>'
            + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in rows) + "</table></section>")


def metrics_section(result):
    metrics = result.get("metrics") or {}
    limits, defaults = thresholds_of(result)
    failed = {f.get("metric") for f in result.get("failed_thresholds") or [] if isinstance(f, dict)}
    rows = []
    for key, name, unit, what in METRICS:
        if key not in metrics and key not in limits:
            continue
        value = metrics.get(key)
        limit = limits.get(key)
        if limit is None:
            met = "–"
        elif key in failed:
            met = '<td class="bad">no</td>'
        else:
            met = '<td class="ok">yes</td>' if value is not None else '<td>not measured</td>'
        value_cell = number_cell(value, RUN_DIGITS) if value is not None else "no ground truth"
        rows.append([name, value_cell, unit or "–", f"{limit[0]} {limit[1]:g}" if limit else "–", met, what])
    note = ("the default thresholds (no <code>success</code> object), each where the ground truth gives the metric"
            if defaults else "thresholds from the experiment's <code>success</code> object")
    return ('<section id="metrics"><h2>Metrics against the ground truth</h2>'
            + table(["metric", "value", "unit", "threshold", "met", "what it measures"], rows, "metrics-table",
                    f"result.json's <code>metrics</code>, to {RUN_DIGITS} significant digits (hover for the "
                    f"full value); {note}. Lengths are world millimetres (LPS).")
            + "</section>")


def phases_table(result):
    rows = []
    for p in result.get("phases") or []:
        if not isinstance(p, dict):
            continue
        guard = p.get("collision_guard") or {}
        remesh = ", ".join(f"{r.get('stage')} {r.get('vertices_before')}→{r.get('vertices_after')}"
                           for r in p.get("remesh") or [] if isinstance(r, dict))
        rows.append([p.get("name", ""), number_cell(p.get("iterations"), 10), p.get("status", ""),
                     p.get("converged_on", "–"), number_cell(p.get("last_displacement"), RUN_DIGITS),
                     f"{guard.get('shortened', '–')} / {guard.get('refused', '–')}", remesh or "–"])
    return table(["phase", "iterations", "status", "converged on", "last largest move (mm)",
                  "collision guard: moves shortened / refused", "remeshing (vertices before→after)"], rows,
                 "phases-table")


def iteration_section(result):
    v = result.get("vertices") or {}
    t = result.get("timings") or {}
    pose = result.get("pose") or {}
    dimension = (result.get("config") or {}).get("dimension")
    measure = "area" if dimension == 2 else "volume"
    facts = [("iterations (all phases)", number_cell(result.get("iterations"), 10)),
             ("vertices: placed template → result", esc(f"{v.get('initial', '–')} → {v.get('final', '–')}")
              + esc(f" ({v.get('deformation')} governed by the deformation energy)" if "deformation" in v else "")),
             ("seed", esc(result.get("seed", "–"))),
             ("centroid shift (mm)", number_cell(pose.get("centroid_shift"), RUN_DIGITS)),
             (f"{measure} at the end / at the start", number_cell(pose.get("measure_ratio"), RUN_DIGITS))]
    timing_rows = [[k[:-2], number_cell(t[k], 3)] for k in ("field_s", "potential_s", "evolve_s", "metrics_s",
                                                             "total_s") if k in t]
    parts = ['<section id="run"><h2>Iterations, phases and timings</h2><table>',
             "".join(f"<tr><th>{esc(k)}</th>{c if c.startswith('<td') else f'<td>{c}</td>'}</tr>"
                     for k, c in facts), "</table>", phases_table(result),
             table(["step", "wall time (s)"], timing_rows, "timings-table")]
    energy = result.get("energy")
    if isinstance(energy, dict) and isinstance(energy.get("terms"), dict):
        start = energy.get("start") if isinstance(energy.get("start"), dict) else None
        columns = ([start.get("terms") or {}] if start else []) + [energy["terms"]]
        rows = [[k] + [number_cell(c.get(k), RUN_DIGITS) for c in columns] for k in energy["terms"]]
        totals = ([start] if start else []) + [energy]
        rows.append(["total"] + [number_cell(c.get("total"), RUN_DIGITS) for c in totals])
        parts.append(table(["term (weight × energy; units differ by term)"]
                           + (["at the placed template"] if start else []) + ["at the end"], rows, "energy-table",
                           "result.json's <code>energy</code>; a term without a value: –"))
    parts.append("</section>")
    return "".join(parts)


def provenance_section(result):
    p = result.get("provenance") or {}
    build = p.get("build") or {}
    command = p.get("command_line")
    rows = [("version", result.get("version") or build.get("version")),
            ("build", ", ".join(f"{k} {build[k]}" for k in ("compiler", "flags", "build_type") if k in build)),
            ("host", p.get("host")), ("OpenMP threads", p.get("threads")),
            ("peak memory (MB)", fmt(p.get("peak_memory_mb"), 4)),
            ("command line", shlex.join(command) if isinstance(command, list) else command),
            ("started (UTC)", p.get("started")), ("finished (UTC)", p.get("finished"))]
    inputs = p.get("inputs") if isinstance(p.get("inputs"), dict) else {}
    input_rows = [[key, f.get("path", ""), number_cell(f.get("bytes"), 15), f"<td><code>{esc(f.get('sha256', ''))}"
                   "</code></td>"] for key, f in inputs.items() if isinstance(f, dict)]
    files = (table(["input", "path", "bytes", "SHA-256"], input_rows, "inputs-table")
             if input_rows else "<p>No input file: the image and template are made in code (phantoms).</p>")
    return ('<section id="provenance"><h2>Provenance</h2><table>'
            + "".join(f"<tr><th>{esc(k)}</th><td>{esc('–' if v is None else v)}</td></tr>" for k, v in rows)
            + "</table>" + files + "</section>")


def landmarks_section(run_dir):
    """The named template vertices of correspondence.csv: where they went and their error."""
    path = os.path.join(run_dir, "correspondence.csv")
    if not os.path.exists(path):
        return ""
    header, rows = read_csv(path, ("template_id", "landmark", "displacement", "error"))
    named = [r for r in rows if r["landmark"]]
    if not named:
        return ""
    body = [[r["landmark"], r["template_id"], number_cell(r["displacement"], RUN_DIGITS),
             number_cell(r["error"] or None, RUN_DIGITS)] for r in named]
    return ('<section id="landmarks"><h2>Landmarks</h2>'
            + table(["landmark", "template vertex", "displacement (mm)", "error (mm)"], body, "landmarks-table",
                    "correspondence.csv's named vertices; error: distance to the true position, where the "
                    "ground truth gives it")
            + "</section>")


def config_section(result):
    config = result.get("config")
    if not isinstance(config, dict):
        return ""
    return ('<section id="experiment"><h2>The experiment as run</h2><details><summary>result.json\'s '
            "<code>config</code> (the experiment file after <code>--set</code>)</summary><pre>"
            + esc(json.dumps(config, indent=2)) + "</pre></details></section>")


def draw_figures(run_dir):
    """energy.png, convergence.png and render.png by scripts/figures/run_figures.py. Its
    InputError (a malformed energy_trace.csv or final.vtk) is bad input here too; when drawing
    fails otherwise (no matplotlib), the report embeds the PNGs that exist and says so."""
    try:
        run_figures.draw_run_figures(run_dir)
    except InputError:
        raise
    except Exception as e:  # noqa: BLE001 - a figure that cannot be drawn must not lose the report
        print(f"make_report.py: note: figures not drawn (run_figures.py: {type(e).__name__}: {e}); "
              "embedding the PNGs that exist", file=sys.stderr)


def run_view(run_dir, dimension, bundle):
    """The view's section: final.vtk (and initial.vtk) through the viewer, or a note."""
    final_path = os.path.join(run_dir, "final.vtk")
    if not os.path.exists(final_path):
        return '<section id="view"><p class="note" id="no-viewer">No view: the run wrote no final.vtk.</p></section>'
    final = read_polydata(final_path)
    initial_path = os.path.join(run_dir, "initial.vtk")
    initial = read_polydata(initial_path) if os.path.exists(initial_path) else None
    if dimension not in (2, 3):
        dimension = 3 if "triangles" in final else 2
    bundle_text, why = bundle
    return view_section(mesh_payload(final, initial, dimension), bundle_text, why)


def run_report(run_dir, bundle, figures):
    result = read_run(run_dir)
    dimension = (result.get("config") or {}).get("dimension")
    view = run_view(run_dir, dimension, bundle)  # reads (and checks) the meshes before any figure
    landmarks = landmarks_section(run_dir)
    if figures:
        draw_figures(run_dir)
    pngs = [n for n in os.listdir(run_dir) if n.lower().endswith(".png") and os.path.isfile(os.path.join(run_dir, n))]
    description = (result.get("config") or {}).get("description") or ""
    kind = {2: "2D run", 3: "3D run"}.get(dimension, "run")
    subtitle = (f"dsnake {kind} report of <code>{esc(os.path.abspath(run_dir))}</code>"
                + (f"<br>{esc(description)}" if description else ""))
    body = (outcome_section(result) + metrics_section(result) + landmarks + view + figures_section(run_dir, pngs)
            + iteration_section(result) + provenance_section(result) + config_section(result))
    return page(result["name"], subtitle, body)


# ---------------------------------------------------------------------------------------------
# A sweep's report


def read_sweep(sweep_dir):
    """results.csv and summary.csv (and breakdown.csv when present), checked for their columns."""
    results_path = os.path.join(sweep_dir, "results.csv")
    results_header, results = read_csv(results_path, RESULTS_COLUMNS)
    summary_path = os.path.join(sweep_dir, "summary.csv")
    if not os.path.exists(summary_path):
        raise InputError(f"{summary_path}: missing (`dsnake report {sweep_dir}` writes it from results.csv)")
    needed = SUCCESS_COLUMNS + tuple(f"{q}_{p}" for q, _, _ in QUANTITIES
                                     for p in ("n", "mean", "sd", "ci95_low", "ci95_high"))
    _, summary = read_csv(summary_path, needed)
    for number, row in enumerate(summary, start=2):
        for column in needed[4:]:
            if row[column] != "" and not _is_number(row[column]):
                raise InputError(f"{summary_path}: row {number}, {column}: not a number: {row[column]!r}")
    breakdown_path = os.path.join(sweep_dir, "breakdown.csv")
    breakdown = read_csv(breakdown_path)[1] if os.path.exists(breakdown_path) else []
    grid_columns = results_header[results_header.index("method") + 1:results_header.index("corruption_level")]
    return {"results": results, "summary": summary, "breakdown": breakdown, "grid_columns": grid_columns}


def _is_number(text):
    try:
        float(text)
        return True
    except ValueError:
        return False


def _quantity_heading(name, unit, part):
    return f"{name} {part}" + (f" ({unit})" if unit else "")


def summary_tables(summary):
    """The overview (mean ± SD), the success rates and one table per quantity, from summary.csv."""
    d = SWEEP_DIGITS
    key = lambda r: [r["method"], r["grid"] or "–", r["corruption"]]
    overview, success = [], []
    for r in summary:
        runs = f"{r['finished']}" + (f" of {r['runs']}" if r["finished"] != r["runs"] else "")
        rate = (f"{r['successes']}/{r['finished']} [{fmt(r['success_ci95_low'], d)}, {fmt(r['success_ci95_high'], d)}]"
                if r["finished"] not in ("", "0") else "–")
        cells = [f"{fmt(r[q + '_mean'], d)} ± {fmt(r[q + '_sd'], d)}" if r[q + "_n"] not in ("", "0", "1")
                 else fmt(r[q + "_mean"], d) for q, _, _ in QUANTITIES]
        overview.append(key(r) + [runs, rate] + cells)
        success.append(key(r) + [number_cell(r[c], 10) for c in ("runs", "finished", "stale", "successes")]
                       + [number_cell(r[c], d) for c in ("success_rate", "success_ci95_low", "success_ci95_high")])
    parts = [table(["method", "grid", "corruption", "n", "success [95% Wilson]"]
                   + [_quantity_heading(n, u, "mean ± SD") for _, n, u in QUANTITIES], overview, "summary-overview",
                   "Overview: n, finished runs (of all runs when some did not finish); success: finished runs that met "
                   "their thresholds [95% Wilson score interval]; mean ± sample SD over the finished runs."),
             table(["method", "grid", "corruption", "runs", "finished", "stale", "successes", "success rate",
                    "95% Wilson low", "95% Wilson high"], success, "summary-success",
                   "Success: the share of finished runs that met their thresholds, with its 95% Wilson score "
                   "interval.")]
    for q, name, unit in QUANTITIES:
        rows = [key(r) + [number_cell(r[f"{q}_{p}"], d) for p in ("mean", "sd", "ci95_low", "ci95_high")]
                + [number_cell(r[f"{q}_n"], 10)] for r in summary]
        parts.append(table(["method", "grid", "corruption"]
                           + [_quantity_heading(name, unit, p) for p in ("mean", "SD", "95% CI low", "95% CI high")]
                           + ["n"], rows, f"summary-{q}",
                           f"{esc(name)}{f' ({unit})' if unit else ''}: mean, sample SD and the 95% confidence "
                           "interval "
                           "of the mean (Student's t, n − 1 degrees of freedom; none below two values)."))
    return "".join(parts)


def breakdown_table(breakdown):
    """Per method × grid point × corruption type, the breakdown level of breakdown.csv."""
    seen, rows = set(), []
    for r in breakdown:
        k = (r.get("method"), r.get("grid"), r.get("corruption_type"))
        if k in seen or "breakdown" not in r:
            continue
        seen.add(k)
        rows.append([r.get("method", ""), r.get("grid") or "–", r.get("corruption_type", ""), r["breakdown"]])
    if not rows:
        return ""
    return table(["method", "grid", "corruption type", "breakdown level"], rows, "breakdown-table",
                 "breakdown.csv: the first level, by increasing severity, whose success rate is below 50% "
                 "(none: no such level; incomplete: an unfinished level comes first).")


def last_log_line(sweep_dir, run_id):
    try:
        with open(os.path.join(sweep_dir, "logs", f"{run_id}.log"), encoding="utf-8", errors="replace") as f:
            lines = [line.strip() for line in f if line.strip()]
        return lines[-1] if lines else ""
    except OSError:
        return ""


def run_counts(sweep_dir, results):
    """{finished, met, diverged, failed, not_run, stale} of results.csv. A run without a result
    failed (its process failed or was stopped) when it has a log, else it has not run yet."""
    finished = [r for r in results if r["status"] != "missing"]
    missing = [r["run_id"] for r in results if r["status"] == "missing"]
    failed = sum(os.path.isfile(os.path.join(sweep_dir, "logs", f"{i}.log")) for i in missing)
    return {"finished": len(finished), "met": sum(r["success"] == "true" for r in finished),
            "diverged": sum(r["status"] == "diverged" for r in finished), "failed": failed,
            "not_run": len(missing) - failed, "stale": sum(bool(r.get("stale")) for r in results)}


def runs_table(sweep_dir, results, grid_columns):
    """Every run of results.csv, its id linking to runs/<id>/report.html when that exists."""
    metric_columns = (("dice", "Dice"), ("mean_surface_distance", "MSD (mm)"), ("hausdorff95", "HD95 (mm)"),
                      ("correspondence_error_mean", "corr. error (mm)"), ("total_s", "time (s)"))
    rows, linked = [], 0
    for r in results:
        run_id = r["run_id"]
        report = os.path.join("runs", run_id, "report.html")
        if os.path.isfile(os.path.join(sweep_dir, report)):
            linked += 1
            id_cell = f'<td><a href="{esc(report)}">{esc(run_id)}</a></td>'
        else:
            id_cell = f"<td>{esc(run_id)}</td>"
        note = r.get("stale", "")
        if r["status"] == "missing":
            line = last_log_line(sweep_dir, run_id)
            note = f"logs/{run_id}.log ends: {line}" if line else "no log: not run yet"
        rows.append([id_cell, r["method"]] + [r[c] for c in grid_columns]
                    + [r["corruption"], r["seed"], r["status"], r["success"] or "–"]
                    + [number_cell(r.get(c), SWEEP_DIGITS) for c, _ in metric_columns] + [note or "–"])
    headers = (["run", "method"] + grid_columns + ["corruption", "seed", "status", "success"]
               + [h for _, h in metric_columns] + ["note (stale: why; not finished: its log's last line)"])
    caption = (f"results.csv, one row per run; {linked} of {len(results)} runs have a report.html (linked); "
               "a run's own report: make_report.py on its folder, or output.report in the sweep's experiment.")
    return table(headers, rows, "runs-table", caption)


def sweep_report(sweep_dir):
    data = read_sweep(sweep_dir)
    results = data["results"]
    c = run_counts(sweep_dir, results)
    counts = (f"<p id=\"run-counts\"><b>{len(results)} runs</b>: {c['finished']} finished ({c['met']} met their "
              f"thresholds; {c['diverged']} stopped by the watchdog, which the sweep counts as failed), "
              f"{c['failed']} failed without a result (the process failed or was stopped: logs/&lt;id&gt;.log says "
              f"why), {c['not_run']} not run yet, {c['stale']} stale (results that no longer stand: results.csv's "
              "column <code>stale</code>).</p>")
    pngs = [n for n in os.listdir(sweep_dir) if n.lower().endswith(".png")
            and os.path.isfile(os.path.join(sweep_dir, n))]
    methods = {}
    for r in results:
        methods.setdefault(r["method"], r["run_id"])
    described = []
    for method, run_id in methods.items():
        config_path = os.path.join(sweep_dir, "configs", f"{run_id}.json")
        config = read_json(config_path) if os.path.exists(config_path) else {}
        described.append([method, (config.get("description") if isinstance(config, dict) else "") or "–"])
    body = (f'<section id="counts"><h2>Runs</h2>{counts}</section>'
            f'<section id="summary"><h2>Summary</h2><p>The numbers of summary.csv, to {SWEEP_DIGITS} significant '
            "digits (hover a cell for summary.csv's ten); lengths in mm, times in s. "
            '<a href="summary.csv">summary.csv</a>, <a href="summary.md">summary.md</a>, '
            '<a href="results.csv">results.csv</a>.</p>'
            f'<div class="wide">{summary_tables(data["summary"])}</div>{breakdown_table(data["breakdown"])}</section>'
            + figures_section(sweep_dir, pngs)
            + '<section id="methods"><h2>Methods</h2>' + table(["method", "description (its first run's)"],
                                                                 described, "methods-table") + "</section>"
            + f'<section id="runs"><h2>Every run</h2><div class="wide">'
            f'{runs_table(sweep_dir, results, data["grid_columns"])}</div></section>')
    name = os.path.basename(os.path.normpath(os.path.abspath(sweep_dir)))
    return page(f"Sweep {name}", f"dsnake sweep report of <code>{esc(os.path.abspath(sweep_dir))}</code>", body)


# ---------------------------------------------------------------------------------------------
# Writing, the command line


def write_atomically(path, text):
    """Writes `text` to a temporary file beside `path`, then renames it over `path`."""
    fd, tmp = tempfile.mkstemp(prefix=".report.html.", suffix=".tmp", dir=os.path.dirname(path) or ".")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes it 0600; a report is as readable as the other outputs
        os.replace(tmp, path)
    except BaseException:
        try:
            os.remove(tmp)
        except OSError:
            pass
        raise


def draw_success_rates(sweep_dir):
    """success_rates.png (scripts/figures/success_rates.py) when the sweep's breakdown.csv has
    rows: the success rate per method against each corruption's magnitude. A figure that cannot
    be drawn is a note on stderr; the report embeds the PNGs that exist."""
    try:
        if not read_csv_records(os.path.join(sweep_dir, "breakdown.csv"))[1]:
            return
    except InputError:
        return
    try:
        import success_rates  # scripts/figures, on the path above; imports matplotlib
        success_rates.main([sweep_dir, "--quiet"])
    except (Exception, SystemExit) as e:  # noqa: BLE001 - a figure that fails must not lose the report
        print(f"make_report.py: note: {os.path.join(sweep_dir, 'success_rates.png')} not drawn: {e}", file=sys.stderr)


def make_report(folder, viewer=None, figures=True):
    """Writes folder/report.html for a run or a sweep folder and returns its path. InputError for
    bad input (nothing written), OSError when it cannot be written."""
    if os.path.isfile(os.path.join(folder, "results.csv")):
        if figures:
            draw_success_rates(folder)
        text = sweep_report(folder)
    elif os.path.isfile(os.path.join(folder, "result.json")):
        bundle = find_viewer(viewer)
        if bundle[0] is None:
            print(f"make_report.py: note: {os.path.join(folder, 'report.html')} has no interactive view: {bundle[1]}",
                  file=sys.stderr)
        text = run_report(folder, bundle, figures)
    elif not os.path.isdir(folder):
        raise InputError(f"{folder}: not a folder")
    else:
        raise InputError(f"{folder}: neither a run folder (result.json) nor a sweep folder (results.csv)")
    path = os.path.join(folder, "report.html")
    write_atomically(path, text)
    return path


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folder", metavar="DIR",
                    help="a dsnake run's output folder (result.json) or a sweep's (results.csv)")
    ap.add_argument("--viewer", metavar="BUNDLE", help="the viewer bundle dsnake_viewer.js (default: "
                    "$DSNAKE_VIEWER_JS, else build/release/viewer/dsnake_viewer.js)")
    ap.add_argument("--no-figures", action="store_true", help="do not draw the run's figures first "
                    "(scripts/figures/run_figures.py); embed the PNGs that exist")
    args = ap.parse_args(argv)
    try:
        make_report(args.folder, args.viewer, not args.no_figures)
    except InputError as e:
        print(f"make_report.py: {e}", file=sys.stderr)
        return 2
    except OSError as e:
        print(f"make_report.py: {os.path.join(args.folder, 'report.html')}: cannot be written: "
              f"{e.strerror or e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
