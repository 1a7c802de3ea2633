#!/usr/bin/python3
"""Prints the anatomy development set's table (Markdown), one block per case, from
out/real/anatomy/ (experiments/real/anatomy/run_all.sh writes it):

  rows     start (the registrations' placed template: output.start_metrics of the recipe run),
           start without atlas (the template as given: the recipe without atlas has no image init),
           recipe without atlas (recipe_noref), recipe with atlas (recipe: template.reference_image),
           fixed point (start: the truth's own surface; then the run), fixed point without atlas (the
           same start, the recipe without atlas: fixed_point_noref), elastix (affine + B-spline,
           experiments/real/elastix.sh), SyN (dipy, experiments/real/syn.py), each measured on the
           surface of its warped mask (2000 vertices, the cerebellum 3000) and on the template's own
           vertices carried by its transform ("template carried": the mesh dsnake returns, at the
           template's resolution)
  columns  Dice, mean surface distance (mm), HD95 (mm), self-intersections, correspondence error
           mean / max (mm; the warp cases: the template's vertices against phi(p); for the peers,
           the vertices carried by the inverse of their transform), wall time (s) and peak memory
           (MB) under /usr/bin/time: a dsnake run; elastix's registration plus transformix's mask
           warp; SyN's registration (affine, SyN, mask warp, vertices) in its child process.
The fixed points have no correspondence (their template is the truth's surface, not the template).

  table.py [OUT] [--compact]   (default out/real/anatomy; --compact: one row per case, Dice / msd
                               per method, then the warp cases' correspondence errors and the wall times)
"""
import csv
import json
import os
import sys

ARGS = [a for a in sys.argv[1:] if a != "--compact"]
COMPACT = "--compact" in sys.argv[1:]
OUT = ARGS[0] if ARGS else "out/real/anatomy"
CASES = [f"{s}_{v}" for v in ("mirror", "cross", "warp") for s in ("amygdala", "pallidum", "cerebellum")]
METHODS = [("recipe_noref", "recipe without atlas"), ("recipe", "recipe with atlas"), ("fixed_point", "fixed point"),
           ("fixed_point_noref", "fixed point without atlas"), ("true_correspondence", "template at phi(p)")]
FIXED_POINTS = ("fixed_point", "fixed_point_noref")


def f(x, p=3):
    return "-" if x is None else f"{x:.{p}f}"


def row(name, m, wall=None, mb=None, corr=True):
    if m is None:
        return f"| {name} | missing | | | | | | |"
    ce = f"{f(m.get('correspondence_error_mean'))} / {f(m.get('correspondence_error_max'))}" if corr and m.get(
        "correspondence_error_mean") is not None else "-"
    return (f"| {name} | {f(m.get('dice'))} | {f(m.get('mean_surface_distance'), 2)} | {f(m.get('hausdorff95'), 2)} | "
            f"{m.get('self_intersections', '-')} | {ce} | {f(wall, 1)} | {f(mb, 0)} |")


def dsnake_runs(case):
    runs = {}
    path = f"{OUT}/{case}/results.csv"
    if not os.path.exists(path):
        return runs
    for r in csv.DictReader(open(path)):
        d = f"{OUT}/{case}/runs/{r['run_id']}"
        if os.path.exists(f"{d}/result.json"):
            res = json.load(open(f"{d}/result.json"))
            t = f"{OUT}/{case}/time/{r['run_id']}.txt"
            wall, kb = open(t).read().split()[-2:] if os.path.exists(t) else (None, None)
            runs[r["method"]] = (res, float(wall) if wall else None, int(kb) / 1024 if kb else None)
    return runs


def peer(case, name):
    path = f"{OUT}/{case}/{name}/summary.json"
    if not os.path.exists(path):
        return None, None, None
    s = json.load(open(path))
    m = dict(s["metrics"], correspondence_error_mean=s.get("correspondence_error_mean"),
             correspondence_error_max=s.get("correspondence_error_max"))
    if name == "elastix":
        return m, s["elastix_wall_s"] + s["transformix_wall_s"], max(s["elastix_peak_mb"], s["transformix_peak_mb"])
    return m, s["syn_wall_s"], s["syn_peak_mb"]


def carried(case, name):
    """The template's own vertices carried by a peer's transform (its correspondence run): the same
    mesh, at the template's resolution, as dsnake's result."""
    path = f"{OUT}/{case}/{name}/correspondence/result.json"
    if os.path.exists(path):
        return json.load(open(path))["metrics"]
    summary = f"{OUT}/{case}/{name}/summary.json"
    if os.path.exists(summary) and json.load(open(summary)).get("carried_template_refused"):
        return {"refused": True}  # the transform folded the template onto itself
    return None


def compact():
    cols = ["start", "recipe with atlas", "elastix", "SyN", "fixed point", "start without atlas", "recipe without atlas",
            "fixed point without atlas"]
    table = {}
    for case in CASES:
        runs = dsnake_runs(case)
        rec = runs.get("recipe", (None, None, None))
        noref = runs.get("recipe_noref", (None, None, None))
        fp = runs.get("fixed_point", (None, None, None))
        fpn = runs.get("fixed_point_noref", (None, None, None))
        table[case] = {
            "start": (rec[0].get("start", {}).get("metrics") if rec[0] else None, None, None),
            "start without atlas": (noref[0].get("start", {}).get("metrics") if noref[0] else None, None, None),
            "recipe without atlas": (noref[0]["metrics"] if noref[0] else None,) + noref[1:],
            "fixed point without atlas": (fpn[0]["metrics"] if fpn[0] else None,) + fpn[1:],
            "recipe with atlas": (rec[0]["metrics"] if rec[0] else None,) + rec[1:],
            "fixed point": (fp[0]["metrics"] if fp[0] else None,) + fp[1:],
            "elastix": peer(case, "elastix"), "SyN": peer(case, "syn")}
        table[case]["fixed point start"] = fp[0].get("start", {}).get("metrics") if fp[0] else None
        table[case]["fixed point without atlas start"] = fpn[0].get("start", {}).get("metrics") if fpn[0] else None
    print("Dice / mean surface distance (mm); start: the template after the image init (the recipe with atlas); start "
          "without atlas: the template as given; fixed points: from the truth's own surface (its start Dice in brackets)\n")
    print("| case | " + " | ".join(cols) + " |")
    print("| --- |" + " --- |" * len(cols))
    for case, t in table.items():
        cells = []
        for c in cols:
            m = t[c][0]
            cell = "-" if m is None else f"{f(m.get('dice'))} / {f(m.get('mean_surface_distance'), 2)}"
            if c.startswith("fixed point") and t[c + " start"]:
                cell += f" ({f(t[c + ' start'].get('dice'))})"
            cells.append(cell)
        print(f"| {case} | " + " | ".join(cells) + " |")
    print("\nWarp cases: correspondence error mean / max (mm), the template's vertices against phi(p); "
          "last column: the Dice of the template with every vertex at phi(p) (the truth at the template's resolution)\n")
    cc = ["start", "recipe without atlas", "recipe with atlas", "elastix", "SyN"]
    print("| case | " + " | ".join(cc) + " | Dice at phi(p) |")
    print("| --- |" + " --- |" * (len(cc) + 1))
    for case, t in table.items():
        if not case.endswith("_warp"):
            continue
        truth = dsnake_runs(case).get("true_correspondence", (None,))[0]
        cells = []
        for c in cc:
            m = t[c][0]
            cells.append("-" if m is None or m.get("correspondence_error_mean") is None else
                         f"{f(m['correspondence_error_mean'], 2)} / {f(m['correspondence_error_max'], 2)}")
        cells.append(f(truth["metrics"].get("dice")) if truth else "-")
        print(f"| {case} | " + " | ".join(cells) + " |")
    print("\nAt the template's resolution: Dice / mean surface distance (mm) of the template's own vertices "
          "(dsnake's result; the peers' transforms carrying them), beside the peers' masks' surfaces (2000, "
          "cerebellum 3000 vertices)\n")
    pc = ["recipe with atlas", "elastix, template carried", "SyN, template carried", "elastix, mask", "SyN, mask"]
    print("| case | " + " | ".join(pc) + " |")
    print("| --- |" + " --- |" * len(pc))
    for case, t in table.items():
        ms = [t["recipe with atlas"][0], carried(case, "elastix"), carried(case, "syn"), t["elastix"][0], t["SyN"][0]]
        print(f"| {case} | " + " | ".join("-" if m is None else "self-intersecting" if m.get("refused") else
                                          f"{f(m.get('dice'))} / {f(m.get('mean_surface_distance'), 2)}" for m in ms) + " |")
    tc = ["recipe with atlas", "elastix", "SyN", "fixed point", "recipe without atlas", "fixed point without atlas"]
    print("\nWall time (s) / peak memory (MB), one thread each\n")
    print("| case | " + " | ".join(tc) + " |")
    print("| --- |" + " --- |" * len(tc))
    for case, t in table.items():
        print(f"| {case} | " + " | ".join(f"{f(t[c][1], 1)} / {f(t[c][2], 0)}" for c in tc) + " |")


def main():
    if COMPACT:
        compact()
        return
    print(f"Anatomy development set ({OUT}); times: one process, THREADS threads each, two streams side by side.\n")
    for case in CASES:
        if not os.path.isdir(f"{OUT}/{case}"):
            continue
        print(f"**{case}**\n")
        print("| method | Dice | msd mm | HD95 mm | SI | corr. err. mean / max mm | wall s | peak MB |")
        print("| --- | --- | --- | --- | --- | --- | --- | --- |")
        runs = dsnake_runs(case)
        start = runs.get("recipe", runs.get("recipe_noref", (None,)))[0]
        print(row("start", start.get("start", {}).get("metrics") if start else None))
        if "recipe_noref" in runs:
            print(row("start without atlas", runs["recipe_noref"][0].get("start", {}).get("metrics")))
        for key, name in METHODS:
            if key == "true_correspondence" and not case.endswith("_warp"):
                continue
            if key not in runs:
                print(row(name, None))
                continue
            res, wall, mb = runs[key]
            if key in FIXED_POINTS:
                sm = res.get("start", {}).get("metrics", {})
                name = f"{name} (from Dice {f(sm.get('dice'))})"
            print(row(name, res["metrics"], wall, mb, corr=key not in FIXED_POINTS))
        e = f"{OUT}/{case}/elastix/summary.json"
        if os.path.exists(e):
            s = json.load(open(e))
            m = dict(s["metrics"], correspondence_error_mean=s.get("correspondence_error_mean"),
                     correspondence_error_max=s.get("correspondence_error_max"))
            print(row("elastix", m, s["elastix_wall_s"] + s["transformix_wall_s"],
                      max(s["elastix_peak_mb"], s["transformix_peak_mb"])))
            if carried(case, "elastix"):
                print(row("elastix, template carried", carried(case, "elastix")))
        else:
            print(row("elastix", None))
        sy = f"{OUT}/{case}/syn/summary.json"
        if os.path.exists(sy):
            s = json.load(open(sy))
            m = dict(s["metrics"], correspondence_error_mean=s.get("correspondence_error_mean"),
                     correspondence_error_max=s.get("correspondence_error_max"))
            print(row("SyN", m, s["syn_wall_s"], s["syn_peak_mb"]))
            if carried(case, "syn") and carried(case, "syn").get("refused"):
                print("| SyN, template carried | self-intersecting | | | | | | |")
            elif carried(case, "syn"):
                print(row("SyN, template carried", carried(case, "syn")))
        else:
            print(row("SyN", None))
        print()


if __name__ == "__main__":
    main()
