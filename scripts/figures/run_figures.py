#!/usr/bin/python3
"""The per-run figures of a `dsnake run` output folder, drawn with matplotlib:

    energy.png       the weighted energy terms and their total per iteration (energy_trace.csv)
    convergence.png  the largest vertex move per iteration, and the vertex count when remeshing
                     changes it
    render.png       3D runs only (final.vtk holds triangles): the final mesh seen from three
                     sides, coloured by each vertex's error (mm) where the ground truth gives its
                     true position, else by how far it moved from its template position (mm)

    /usr/bin/python3 scripts/figures/run_figures.py RUN_DIR [RUN_DIR ...] [--verbose]

Each figure is written into its run folder atomically (a temporary file in the same folder,
then renamed). Bad or missing input (energy_trace.csv, result.json, final.vtk) gives one line on
stderr naming the file and exit code 2, and no figure of that folder is written; a figure that
cannot be written (a full disk, a read-only folder) gives one such line and exit code 1, and no
temporary file is left. Nothing is printed on success unless --verbose.

Every PNG carries text metadata: `Title` (the figure's title, "<run name> — energy") and
`dsnake:axes`, a JSON list with one object per axes as drawn: role ("plot", "render" or
"colorbar"), title, xlabel, ylabel, xscale, yscale, legend (the legend's entries), lines (the
labels of the data lines), phase_boundaries (x of the phase-boundary lines), annotations (the
phase labels), xlim, ylim and bbox_px (the axes' box in pixels, [left, top, right, bottom] from
the image's top-left corner). render.png also has `dsnake:colour`: the scalar it is coloured by,
its unit, range, how many vertices carry it and the views.

The mesh is projected orthographically in world coordinates (LPS mm: +x toward the patient's
left, +y posterior, +z superior) and rasterised by matplotlib (depth-sorted Gouraud triangles),
so no display or OpenGL context is needed: Debian's VTK 9.1 can render only through an X server.
"""
import argparse
import json
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from common import InputError, read_csv_records, read_polydata  # noqa: E402

FIXED_COLUMNS = ("iteration", "phase", "phase_iteration", "vertices", "max_displacement")
DPI = 150
FONT = {"font.size": 9, "axes.titlesize": 10, "axes.labelsize": 9, "legend.fontsize": 8,
        "xtick.labelsize": 8, "ytick.labelsize": 8, "figure.titlesize": 11}
# Distinct colour, line style and marker per curve, so that curves that coincide stay apart.
COLOURS = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442")
LINESTYLES = ("-", "--", "-.", ":")
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
NO_TARGET_GREY = (0.72, 0.72, 0.72)
# The weighted terms w_e E_e of the paper's eq. (1) (E = E_int + kappa E_ext + eta E_def, §1) do
# not share a unit: the physical internal energy is in mm^3 (2D) or mm^4 (3D) per unit gamma (its
# umbrella form in mm^2), the ASAP-MLS energy (§4) in mm^2, an external potential in the field's
# own units, and the weights are pure numbers (docs/methods.md, docs/experiment-file.md).
ENERGY_UNIT = "weight × term, units differ by term"


class OutputError(Exception):
    """A figure that could not be written (a full disk, a read-only folder); names the file."""


# ---------------------------------------------------------------------------------------------
# Reading the run folder


def read_result(run_dir):
    """The run's name and its phases' names from result.json."""
    path = os.path.join(run_dir, "result.json")
    try:
        with open(path) as f:
            result = json.load(f)
    except OSError as e:
        raise InputError(f"{path}: {e.strerror}") from None
    except ValueError as e:
        raise InputError(f"{path}: not JSON ({e})") from None
    if not isinstance(result, dict) or not isinstance(result.get("name"), str) or not result["name"]:
        raise InputError(f"{path}: no \"name\"")
    phases = result.get("phases") if isinstance(result.get("phases"), list) else []
    names = [p.get("name", "") if isinstance(p, dict) else "" for p in phases]
    return result["name"], names


def _number(text, path, row, column):
    if text.strip() == "":  # a missing value (dsnake writes an empty field)
        return float("nan")
    try:
        return float(text)
    except (TypeError, ValueError):
        raise InputError(f"{path}: row {row}, column {column}: not a number: {text!r}") from None


def read_trace(run_dir):
    """energy_trace.csv as {"columns": {name: numpy array}, "terms": [term names]}; nan where a
    term has no value; None when it has no iteration (a header only)."""
    import numpy as np
    path = os.path.join(run_dir, "energy_trace.csv")
    header, data = read_csv_records(path)
    missing = [c for c in FIXED_COLUMNS + ("total",) if c not in header]
    if missing:
        raise InputError(f"{path}: no column {missing[0]!r}")
    if not data:  # a run stopped before its first iteration: no curve to draw
        return None
    values = []
    for i, r in data:
        if len(r) != len(header):
            raise InputError(f"{path}: row {i}: {len(r)} fields, the header has {len(header)}")
        values.append([_number(t, path, i, c) for t, c in zip(r, header)])
    table = np.array(values, dtype=float)
    for c in FIXED_COLUMNS:
        if not np.all(np.isfinite(table[:, header.index(c)])):
            raise InputError(f"{path}: column {c!r} has a value that is not a finite number")
    columns = {c: table[:, k] for k, c in enumerate(header)}
    terms = [c for c in header if c not in FIXED_COLUMNS and c != "total"]
    return {"columns": columns, "terms": terms}


def read_mesh(run_dir):
    """final.vtk's points (n, 3), triangles (m, 3) and point arrays, or None when the run is 2D
    (its final.vtk holds lines) or has no final.vtk."""
    path = os.path.join(run_dir, "final.vtk")
    if not os.path.exists(path):
        return None
    mesh = read_polydata(path)
    if "triangles" not in mesh:
        return None
    if "displacement" not in mesh["arrays"]:
        raise InputError(f"{path}: no point array 'displacement'")
    return mesh


# ---------------------------------------------------------------------------------------------
# Drawing helpers shared by the figures


def _new_figure(width, height, layout="constrained"):
    from matplotlib.figure import Figure
    return Figure(figsize=(width, height), dpi=DPI, layout=layout)


def _phase_starts(trace):
    """(x of the boundary before the phase's first iteration, phase index) for every phase."""
    it, phase = trace["columns"]["iteration"], trace["columns"]["phase"]
    starts = [(it[0] - 0.5, int(phase[0]))]
    for k in range(1, len(it)):
        if phase[k] != phase[k - 1]:
            starts.append((it[k] - 0.5, int(phase[k])))
    return starts


def _draw_phases(axes_list, starts, phase_names):
    """Thin vertical lines between phases in every panel (§6: a fit phase, then refinement
    phases), and each phase's index and name centred above its span in the first panel (or the
    index and name, the index alone, or nothing, where the span is too narrow for the text)."""
    from matplotlib.transforms import blended_transform_factory
    first = axes_list[0]
    lo, hi = first.get_xlim()
    width_in = first.get_position().width * first.figure.get_figwidth()
    char = 0.075 / max(width_in, 1e-6)  # a 7.5 pt character's share of the axes' width
    ends = [x for x, _ in starts[1:]] + [hi]
    place = blended_transform_factory(first.transData, first.transAxes)
    for k, ((x, phase), end) in enumerate(zip(starts, ends)):
        if k > 0:
            for ax in axes_list:
                ax.axvline(x, color="0.45", linewidth=0.7, linestyle=(0, (4, 2)), gid="phase-boundary",
                           label="_phase boundary")
        name = phase_names[phase] if 0 <= phase < len(phase_names) and phase_names[phase] else ""
        share = (min(end, hi) - max(x, lo)) / (hi - lo)
        texts = (f"phase {phase}: {name}", f"{phase}: {name}", f"{phase}") if name else (f"phase {phase}", f"{phase}")
        for text in texts:
            if (len(text) + 1) * char <= share:
                first.text((max(x, lo) + min(end, hi)) / 2, 1.01, text, transform=place, ha="center",
                           va="bottom", fontsize=7.5, color="0.3", gid="phase-label")
                break
    first.set_xlim(lo, hi)


SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _plain_log_formatter():
    """Log tick labels as plain text (10⁻³, 2, 50): matplotlib's default ones are mathtext,
    whose parser costs more than drawing the whole figure."""
    from matplotlib.ticker import LogFormatter

    class PlainLogFormatter(LogFormatter):
        def __call__(self, x, pos=None):
            text = super().__call__(x, pos)
            return "−" + text if text and x < 0 else text

        def _num_to_string(self, x, vmin, vmax):
            exponent = math.log10(x)
            wide = vmin > 0 and vmax / vmin >= 100  # narrower: plain numbers, as the minor labels
            if wide and abs(exponent - round(exponent)) < 1e-9:
                return "10" + str(round(exponent)).translate(SUPERSCRIPT)
            return f"{x:g}"

    return PlainLogFormatter


def _set_yscale(ax, scale, **kwargs):
    ax.set_yscale(scale, **kwargs)
    if scale in ("log", "symlog"):
        formatter = _plain_log_formatter()
        ax.yaxis.set_major_formatter(formatter(labelOnlyBase=False))
        ax.yaxis.set_minor_formatter(formatter(labelOnlyBase=False, minor_thresholds=(2, 0.5)))


def _scale_for(ax, values, name, unit):
    """Log y when every finite value is positive; symmetric log when values span many decades
    through zero; linear otherwise. Returns the y label: name, the scale, then (unit)."""
    import numpy as np
    finite = values[np.isfinite(values)]
    if finite.size and np.all(finite > 0):
        _set_yscale(ax, "log")
        return f"{name}, log scale\n({unit})"
    nonzero = np.abs(finite[finite != 0])
    if nonzero.size and nonzero.max() > 1e3 * nonzero.min():
        _set_yscale(ax, "symlog", linthresh=float(np.percentile(nonzero, 5)))
        return f"{name}, symmetric log scale\n({unit})"
    # Whole numbers on the ticks: no offset or exponent above the axes, where the phase labels are.
    ax.ticklabel_format(axis="y", style="plain", useOffset=False)
    return f"{name}\n({unit})"


def _style(k, n_points, n_curves):
    """Colour, line style and marker of curve k; markers staggered so coinciding curves show."""
    step = max(1, n_points // 12)
    return dict(color=COLOURS[k % len(COLOURS)], linestyle=LINESTYLES[k % len(LINESTYLES)],
                marker=MARKERS[k % len(MARKERS)], markersize=4, linewidth=1.3,
                markevery=(min(n_points - 1, (k * step) // max(1, n_curves)), step) if n_points > 1 else None)


def _dots(x):
    """A dot per iteration on a short trace, where a value between two missing ones would
    otherwise draw nothing."""
    return {"marker": ".", "markersize": 5} if len(x) <= 60 else {}


def _iteration_axis(ax):
    from matplotlib.ticker import MaxNLocator
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.grid(alpha=0.3, linewidth=0.5)


# ---------------------------------------------------------------------------------------------
# The figures


def _term_label(term, y):
    import numpy as np
    missing = int(np.count_nonzero(~np.isfinite(y)))
    if missing == len(y):
        return f"{term} (no value)"
    if missing:
        return f"{term} (no value in {missing} of {len(y)} iterations)"
    return term


def draw_energy(trace, name, phase_names):
    """energy.png: the weighted terms (top) and their total (bottom) per iteration."""
    import numpy as np
    cols, terms = trace["columns"], trace["terms"]
    x = cols["iteration"]
    fig = _new_figure(7.5, 6.0)
    top, bottom = fig.subplots(2, 1, sharex=True, gridspec_kw={"height_ratios": (3, 2)})
    plotted = []
    for k, term in enumerate(terms):
        y = np.where(np.isfinite(cols[term]), cols[term], np.nan)
        label = _term_label(term, y)
        style = _style(k, len(x), len(terms))
        if np.isfinite(y).any():
            top.plot(x, y, label=label, **style)
            plotted.append(y)
        else:  # a legend entry only: the term has no value to draw
            top.plot([], [], label=label, **{**style, "markevery": None})
    values = np.concatenate(plotted) if plotted else np.array([])
    top.set_ylabel(_scale_for(top, values, "weighted energy terms", ENERGY_UNIT))
    if terms:
        top.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    total = np.where(np.isfinite(cols["total"]), cols["total"], np.nan)
    bottom.plot(x, total, color="0.1", linewidth=1.5, label=_term_label("total", total), **_dots(x))
    bottom.set_ylabel(_scale_for(bottom, total, "total energy", "units differ by term"))
    for ax in (top, bottom):  # each panel labelled in full, so that it reads on its own
        ax.tick_params(labelbottom=True)
        ax.set_xlabel("iteration (over all phases)")
        _iteration_axis(ax)
        ax.set_xlim(x[0] - 0.5, x[-1] + 0.5)
    _draw_phases([top, bottom], _phase_starts(trace), phase_names)
    title = f"{name} — energy"
    fig.suptitle(title)
    return fig, title


def draw_convergence(trace, name, phase_names):
    """convergence.png: the largest vertex move per iteration (log y), and the vertex count in a
    second panel when remeshing changes it."""
    import numpy as np
    cols = trace["columns"]
    x, move, vertices = cols["iteration"], cols["max_displacement"], cols["vertices"]
    remeshed = bool(np.any(vertices != vertices[0]))
    fig = _new_figure(7.5, 5.6 if remeshed else 3.8)
    axes = fig.subplots(2 if remeshed else 1, 1, sharex=True, squeeze=False,
                        gridspec_kw={"height_ratios": (3, 2)} if remeshed else None)[:, 0]
    shown = np.where(move > 0, move, np.nan)
    zeros = int(np.count_nonzero(move <= 0))
    label = "largest vertex move" + (f" ({zeros} iteration{'s' * (zeros > 1)} without a move not shown)" if zeros else "")
    axes[0].plot(x, shown, color=COLOURS[0], linewidth=1.3, label=label, **_dots(x))
    _set_yscale(axes[0], "log")
    axes[0].set_ylabel("largest vertex move, log scale\n(mm)")
    if zeros:
        axes[0].legend(loc="upper right")
    if remeshed:
        axes[1].step(x, vertices, where="mid", color=COLOURS[1], linewidth=1.3, label="vertices")
        axes[1].set_ylabel("vertices (count)")
        axes[1].ticklabel_format(axis="y", style="plain", useOffset=False)
    for ax in axes:
        ax.tick_params(labelbottom=True)
        ax.set_xlabel("iteration (over all phases)")
        _iteration_axis(ax)
        ax.set_xlim(x[0] - 0.5, x[-1] + 0.5)
    _draw_phases(list(axes), _phase_starts(trace), phase_names)
    title = f"{name} — convergence"
    fig.suptitle(title)
    return fig, title


# ---------------------------------------------------------------------------------------------
# The 3D rendering

# Orthographic views in the world LPS frame: (title, screen x axis, screen y axis, axis toward the
# viewer), each axis (coordinate index, sign). Anterior and inferior follow the radiological
# convention of slices.png (the patient's left on the right; inferior: anterior up).
VIEWS = (
    ("from anterior", (0, 1), (2, 1), (1, -1)),
    ("from the patient's left", (1, 1), (2, 1), (0, 1)),
    ("from inferior", (0, 1), (1, -1), (2, -1)),
)
AXIS_NAMES = ("x, toward the patient's left (mm)", "y, toward posterior (mm)", "z, toward superior (mm)")


def _shading(mesh, toward):
    """Outward face normals, the visible faces and a headlight intensity per vertex."""
    import numpy as np
    p, t = mesh["points"], mesh["triangles"]
    a, b, c = p[t[:, 0]], p[t[:, 1]], p[t[:, 2]]
    normals = np.cross(b - a, c - a)
    if np.einsum("ij,ij->", a, np.cross(b, c)) < 0:  # inward-wound mesh: flip to outward
        normals = -normals
    vertex_normals = np.zeros_like(p)
    for k in range(3):
        np.add.at(vertex_normals, t[:, k], normals)
    length = np.linalg.norm(vertex_normals, axis=1)
    vertex_normals /= np.where(length > 0, length, 1.0)[:, None]
    intensity = 0.35 + 0.65 * np.abs(vertex_normals @ toward)
    return normals @ toward > 0, intensity


def _surface_triangles(mesh, rgb, valued, view):
    """Screen triangles (m, 3, 2), their corner colours (m, 3, 4), far to near. A face whose
    corners all carry a value (or none does) is one Gouraud triangle; a face with some is split
    into its corners' thirds, each flat in its corner's colour, so that a vertex's value is never
    blurred into the grey of its neighbours that have none."""
    import numpy as np
    (sx, _), (sy, _), (sz, oz) = view[1], view[2], view[3]
    toward = np.zeros(3)
    toward[sz] = oz
    visible, light = _shading(mesh, toward)
    p, t = mesh["points"], mesh["triangles"][visible]
    screen = p[:, [sx, sy]]
    depth = (p[:, sz] * oz)[t].mean(axis=1)
    count = valued[t].sum(axis=1)
    whole = (count == 0) | (count == 3)
    lit = rgb * light[:, None]
    tris = [screen[t[whole]]]
    cols = [lit[t[whole]]]
    depths = [depth[whole]]
    tm = t[~whole]
    g = screen[tm].mean(axis=1)
    gl = light[tm].mean(axis=1)
    for i in range(3):
        vi, vj, vk = tm[:, i], tm[:, (i + 1) % 3], tm[:, (i + 2) % 3]
        mij, mik = (screen[vi] + screen[vj]) / 2, (screen[vi] + screen[vk]) / 2
        lij, lik = (light[vi] + light[vj]) / 2, (light[vi] + light[vk]) / 2
        base = rgb[vi]
        tris += [np.stack([screen[vi], mij, g], axis=1), np.stack([screen[vi], g, mik], axis=1)]
        cols += [base[:, None, :] * np.stack([light[vi], lij, gl], axis=1)[:, :, None],
                 base[:, None, :] * np.stack([light[vi], gl, lik], axis=1)[:, :, None]]
        depths += [depth[~whole]] * 2
    tris, cols, depths = np.concatenate(tris), np.concatenate(cols), np.concatenate(depths)
    order = np.argsort(depths, kind="stable")
    rgba = np.concatenate([np.clip(cols[order], 0, 1), np.ones(cols[order].shape[:2] + (1,))], axis=2)
    return tris[order], rgba


def _gouraud_artist(triangles, colours):
    """An artist that draws screen triangles with per-corner colours in the given order."""
    from matplotlib.artist import Artist

    class GouraudSurface(Artist):
        def draw(self, renderer):
            if not self.get_visible() or len(triangles) == 0:
                return
            gc = renderer.new_gc()
            gc.set_clip_rectangle(self.axes.bbox)
            renderer.draw_gouraud_triangles(gc, triangles, colours, self.axes.transData.frozen())
            gc.restore()

    return GouraudSurface()


def colouring(mesh):
    """What render.png is coloured by: (array name, per-vertex values with nan where a vertex has
    none, colour bar label). The error is the registration's own measure (the paper's §8): a
    template vertex's distance to its counterpart. Vertices that refinement inserted have none
    (they follow only the internal and external forces, §6) and stay grey."""
    import numpy as np
    arrays = mesh["arrays"]
    has_target = arrays.get("has_target")
    if has_target is not None and np.any(has_target > 0.5) and "error" in arrays:
        values = np.where(has_target > 0.5, arrays["error"], np.nan)
        label = "error (mm): distance to its true position; grey where the ground truth gives none"
        return "error", values, label
    label = "displacement (mm): distance from its template position"
    return "displacement", arrays["displacement"].astype(float), label


# The render's fixed layout, in inches: about each panel room for its title, tick labels and axis
# labels; above all, the figure's title; below all, the colour bar and its label. (A fixed layout
# costs nothing, where matplotlib's constrained layout measures every label twice.)
PANEL_LEFT, PANEL_RIGHT, PANEL_TOP, PANEL_BOTTOM = 0.8, 0.2, 0.3, 0.55
TITLE_BAND, BAR_BAND = 0.45, 0.8
MAX_WIDTH, MAX_HEIGHT = 11.0, 9.0


def _row_layout(extents):
    """Three panels side by side, vertically centred: (width, height, boxes) in inches."""
    cw, ch = PANEL_LEFT + PANEL_RIGHT, PANEL_TOP + PANEL_BOTTOM
    tall = max(h for _, h in extents)
    scale = min((MAX_WIDTH - 3 * cw) / sum(w for w, _ in extents), (MAX_HEIGHT - TITLE_BAND - BAR_BAND - ch) / tall)
    boxes, x = [], 0.0
    for w, h in extents:
        boxes.append((x + PANEL_LEFT, BAR_BAND + PANEL_BOTTOM + scale * (tall - h) / 2, scale * w, scale * h))
        x += cw + scale * w
    return x, TITLE_BAND + BAR_BAND + ch + scale * tall, boxes


def _stack_layout(extents):
    """Anterior above lateral, the inferior view beside them: (width, height, boxes) in inches."""
    (w0, h0), (w1, h1), (w2, h2) = extents
    cw, ch = PANEL_LEFT + PANEL_RIGHT, PANEL_TOP + PANEL_BOTTOM
    room = MAX_HEIGHT - TITLE_BAND - BAR_BAND
    scale = min((MAX_WIDTH - 2 * cw) / (max(w0, w1) + w2), (room - 2 * ch) / (h0 + h1), (room - ch) / h2)
    left_column, right_column = 2 * ch + scale * (h0 + h1), ch + scale * h2
    area = max(left_column, right_column)
    top = BAR_BAND + area - (area - left_column) / 2 - PANEL_TOP  # the left column, centred
    column = scale * max(w0, w1)
    a = (PANEL_LEFT + (column - scale * w0) / 2, top - scale * h0, scale * w0, scale * h0)
    top -= scale * h0 + ch
    b = (PANEL_LEFT + (column - scale * w1) / 2, top - scale * h1, scale * w1, scale * h1)
    c = (cw + column + PANEL_LEFT, BAR_BAND + PANEL_BOTTOM + (area - right_column) / 2, scale * w2, scale * h2)
    return 2 * cw + column + scale * w2, TITLE_BAND + BAR_BAND + area, [a, b, c]


def _render_layout(extents):
    """The figure size and each view's axes rectangle (figure fractions) for the views' (width,
    height) in mm, every panel at the same scale: three in a row, or anterior and lateral stacked
    beside the inferior view, whichever leaves less of the panels' bounding box empty (a round
    shape goes in a row, a flat one, such as the lung phantom, stacks)."""
    (w0, h0), (w1, h1), (w2, h2) = extents
    area = w0 * h0 + w1 * h1 + w2 * h2
    in_row = area / ((w0 + w1 + w2) * max(h0, h1, h2))
    stacked = area / ((max(w0, w1) + w2) * max(h0 + h1, h2))
    width, height, boxes = _row_layout(extents) if in_row >= stacked else _stack_layout(extents)
    return (width, height), [(x / width, y / height, w / width, h / height) for x, y, w, h in boxes]


def draw_render(mesh, name):
    """render.png: the final mesh from three sides, coloured by error or displacement."""
    import numpy as np
    from matplotlib import colormaps
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize
    scalar, values, label = colouring(mesh)
    valued = np.isfinite(values)
    top = float(values[valued].max()) if valued.any() else 0.0
    norm, cmap = Normalize(0.0, top if top > 0 else 1.0), colormaps["viridis"]
    rgb = np.tile(np.array(NO_TARGET_GREY), (len(values), 1))
    rgb[valued] = cmap(norm(values[valued]))[:, :3]
    p = mesh["points"]
    pad = 0.04 * float(np.ptp(p, axis=0).max() or 1.0)
    lo, hi = p.min(axis=0) - pad, p.max(axis=0) + pad
    size, boxes = _render_layout([((hi - lo)[v[1][0]], (hi - lo)[v[2][0]]) for v in VIEWS])
    fig = _new_figure(*size, layout=None)
    for box, view in zip(boxes, VIEWS):
        ax = fig.add_axes(box, label="render")
        ax.add_artist(_gouraud_artist(*_surface_triangles(mesh, rgb, valued, view)))
        (sx, ox), (sy, oy) = view[1], view[2]
        ax.set_xlim(*((lo[sx], hi[sx])[::ox]))
        ax.set_ylim(*((lo[sy], hi[sy])[::oy]))
        ax.set_aspect("equal", adjustable="box")
        ax.set_title(view[0])
        ax.set_xlabel(AXIS_NAMES[sx])
        ax.set_ylabel(AXIS_NAMES[sy])
    left, right = min(b[0] for b in boxes), max(b[0] + b[2] for b in boxes)
    bar_axes = fig.add_axes((left, 0.45 / size[1], right - left, 0.14 / size[1]), label="colorbar")
    fig.colorbar(ScalarMappable(norm, cmap), cax=bar_axes, orientation="horizontal").set_label(label)
    title = f"{name} — final mesh"
    fig.suptitle(title, y=1 - 0.12 / size[1], va="top")
    info = {"scalar": scalar, "unit": "mm", "min": float(values[valued].min()) if valued.any() else None,
            "max": top if valued.any() else None, "vertices": int(valued.sum()), "of": int(len(values)),
            "views": [v[0] for v in VIEWS]}
    return fig, title, info


# ---------------------------------------------------------------------------------------------
# Metadata, writing, the command line


def axes_metadata(fig):
    """What each axes of the drawn figure shows, read back from matplotlib (after a draw, so that
    it is what the PNG holds)."""
    height = fig.bbox.height
    described = []
    for ax in fig.axes:
        legend = ax.get_legend()
        box = ax.get_window_extent()
        described.append({
            "role": ax.get_label() if ax.get_label() in ("render", "colorbar") else "plot",
            "title": ax.get_title(),
            "xlabel": ax.get_xlabel(),
            "ylabel": ax.get_ylabel(),
            "xscale": ax.get_xscale(),
            "yscale": ax.get_yscale(),
            "legend": [t.get_text() for t in legend.get_texts()] if legend else [],
            "lines": [line.get_label() for line in ax.get_lines() if not line.get_label().startswith("_")],
            "phase_boundaries": [float(line.get_xdata()[0]) for line in ax.get_lines()
                                 if line.get_gid() == "phase-boundary"],
            "annotations": [t.get_text() for t in ax.texts if t.get_gid() == "phase-label"],
            "xlim": [float(v) for v in ax.get_xlim()],
            "ylim": [float(v) for v in ax.get_ylim()],
            "bbox_px": [round(box.x0), round(height - box.y1), round(box.x1), round(height - box.y0)],
        })
    return described


def save_figure(fig, path, title, extra=None):
    """Draws fig once and writes it, with its metadata, to path through a temporary file in the
    same folder. The metadata is read from the drawn figure, so it describes the final layout."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image, PngImagePlugin
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    info = PngImagePlugin.PngInfo()
    metadata = {"Title": title, "Software": f"matplotlib {matplotlib.__version__}",
                "dsnake:axes": json.dumps(axes_metadata(fig), ensure_ascii=False), **(extra or {})}
    for key, value in metadata.items():
        info.add_itxt(key, value)
    # Opaque RGB and a moderate deflate level: as small a file as the default, in half the time.
    rgba = Image.frombuffer("RGBA", canvas.get_width_height(), canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
    image = rgba.convert("RGB")
    folder, base = os.path.split(path)
    tmp = os.path.join(folder, f".{base}.{os.getpid()}.tmp.png")
    try:
        image.save(tmp, format="png", pnginfo=info, dpi=(DPI, DPI), compress_level=3)
        os.replace(tmp, path)
    except OSError as e:
        raise OutputError(f"{path}: {e.strerror or e}") from None
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


def draw_run_figures(run_dir):
    """Writes energy.png, convergence.png and, for a 3D run, render.png into run_dir; returns
    their paths. Every input is read and checked before any figure is written: InputError (its
    message names the file) leaves the folder as it was."""
    import matplotlib
    name, phase_names = read_result(run_dir)
    trace = read_trace(run_dir)
    mesh = read_mesh(run_dir)
    written = []
    with matplotlib.rc_context(FONT):  # our font sizes, without changing the caller's settings
        if trace is not None:
            fig, title = draw_energy(trace, name, phase_names)
            written.append(save_figure(fig, os.path.join(run_dir, "energy.png"), title))
            fig, title = draw_convergence(trace, name, phase_names)
            written.append(save_figure(fig, os.path.join(run_dir, "convergence.png"), title))
        if mesh is not None:
            fig, title, info = draw_render(mesh, name)
            written.append(save_figure(fig, os.path.join(run_dir, "render.png"), title,
                                       {"dsnake:colour": json.dumps(info)}))
    return written


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", metavar="RUN_DIR", help="a folder written by dsnake run")
    ap.add_argument("--verbose", action="store_true", help="print each figure written")
    args = ap.parse_args(argv)
    status = 0
    for run_dir in args.runs:
        try:
            for path in draw_run_figures(run_dir):
                if args.verbose:
                    print(path)
        except InputError as e:
            print(f"run_figures.py: {e}", file=sys.stderr)
            status = 2
        except OutputError as e:
            print(f"run_figures.py: {e}", file=sys.stderr)
            status = max(status, 1)
    return status


if __name__ == "__main__":
    sys.exit(main())
