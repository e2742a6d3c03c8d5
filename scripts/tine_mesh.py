"""The 2-in tine's draft against the mesh: studies/tine-mesh.toml (the built-in blade on
hexahedra) or, with --study tine-cad-mesh, studies/tine-cad-mesh.toml (the blade from a
STEP file on tetrahedra); their tables in docs/chapter8.md.

Runs `soilbin study studies/STUDY.toml` (resumable), then reads each case's
summary.json and curve.csv and writes between the STUDY markers of
docs/chapter8.md (--page), per mesh: cells, unknowns, Newton iterations and
steps to 0.5 in, the draft and the lift at 0.1 and 0.5 in of travel, each draft
against the finest mesh's, and the CPU time; below it the fit D = D_inf + C h^p
through the three finest levels of one growth. Copies the study's STUDY.png
into docs/figures (--figures DIR). Loads in lb, travel in in.
"""
import shutil

from scipy.optimize import brentq

from soilbin.app.study import Outcome, draw_figures, load_study
from soilbin.records.scene import load_scene
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, at, finished, run_study

STUDIES = ("tine-mesh", "tine-cad-mesh")
TRAVELS = (0.1, 0.5)
SIZE, GROWTH = "mesh.element_size", "mesh.growth"


def shown(value, form=".4g"):
    return "–" if value is None else f"{value:{form}}"


def against(value, reference):
    return "–" if value is None or reference is None else f"{100 * (value / reference - 1):+.1f}%"


#: The orders a fit may find: below LOWEST_ORDER the three drafts do not converge at a rate
#: these elements have (the tetrahedra at 1.5, 1, 0.75 in gave p = 0.11, D_inf = 0.98 lb).
LOWEST_ORDER, HIGHEST_ORDER = 0.5, 10.0


def fit(levels):
    """(p, D_inf) of D = D_inf + C h^p through three (h, D), h falling; None if no p in
    (LOWEST_ORDER, HIGHEST_ORDER) fits."""
    (h1, d1), (h2, d2), (h3, d3) = levels
    ratio = (d1 - d2) / (d2 - d3)

    def gap(p):
        return (h1**p - h2**p) / (h2**p - h3**p) - ratio
    try:
        p = brentq(gap, LOWEST_ORDER, HIGHEST_ORDER)
    except ValueError:
        return None
    c = (d1 - d2) / (h1**p - h2**p)
    return p, d3 - c * h3**p


def table(results, scene_size, scene_growth):
    results = sorted(results, key=lambda r: (-r[0].values[SIZE], r[0].values[GROWTH]))
    finest = results[-1][2]
    reference = {t: at(finest, "force", t) for t in TRAVELS}
    lines = ["| element size [in] / growth | cells | unknowns | Newton (steps) to 0.5 in | "
             "draft at 0.1 in [lb] | vs finest | lift at 0.1 in [lb] | draft at 0.5 in [lb] | "
             "vs finest | lift at 0.5 in [lb] | CPU (s) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case, summary, rows in results:
        size, growth = case.values[SIZE], case.values[GROWTH]
        name = f"{size:g} / {growth:g}" + (" (the scene's)" if (size, growth) == (scene_size, scene_growth)
                                          else "")
        cells = []
        for travel in TRAVELS:
            draft = at(rows, "force", travel)
            cells += [shown(draft), "finest" if rows is finest else against(draft, reference[travel]),
                      shown(at(rows, "lift", travel), ".3g")]
        lines.append(f"| {name} | {summary['n_cells']} | {summary['n_dofs']} | "
                     f"{summary['newton_iterations']} ({summary['n_steps']}) | " + " | ".join(cells)
                     + f" | {summary['cpu_s']:.0f} |")
    return "\n".join(lines), results


def fit_line(results):
    """The fit through the three finest levels at the finest level's growth, at 0.1 in."""
    growth = results[-1][0].values[GROWTH]
    levels = [(case.values[SIZE], at(rows, "force", 0.1)) for case, _, rows in results
              if case.values[GROWTH] == growth][-3:]
    fitted = fit(levels) if len(levels) == 3 and None not in (d for _, d in levels) else None
    if fitted is None:
        return (f"No D = D∞ + C hᵖ with p ≥ {LOWEST_ORDER:g} fits the three finest levels at "
                "0.1 in.")
    p, limit = fitted
    return (f"D = D∞ + C hᵖ through the three finest levels at growth {growth:g} "
            f"(h = {', '.join(f'{h:g}' for h, _ in levels)} in) at 0.1 in: p = {p:.2f}, "
            f"D∞ = {limit:.2f} lb.")


def main():
    args = arguments(__doc__, "tine-mesh", "chapter8.md", STUDIES)
    path = ROOT / "studies" / f"{args.study}.toml"
    run_study(path, args)
    study = load_study(path)
    results = [r for r in finished(study, args.out) if r[1]["status"] == "complete"]
    if not results:
        raise SystemExit(f"{args.out}: no finished case")
    own = load_scene(study.scene_path).mesh
    text, ordered = table(results, own.element_size, own.growth)
    text += "\n\n" + fit_line(ordered) + "\n"
    print(text)
    draw_figures(study, [Outcome(case, summary["status"], summary, ran=False)
                         for case, summary, _ in results], args.out)
    shutil.copy(args.out / f"{args.study}.png", args.figures / f"{args.study}.png")
    write_between_markers(args.page, args.study, text)


if __name__ == "__main__":
    main()
