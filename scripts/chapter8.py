"""Chapter VIII: run studies/chapter8.toml and write its tables into docs/chapter8.md.

Runs `soilbin study studies/chapter8.toml` (resumable), then reads each case's
summary.json and curve.csv, prints and writes between the chapter8 markers of
docs/chapter8.md (--page; `python scripts/chapter8.py --no-run` only rewrites
the tables, from the cases finished so far):
- per case: the travel at 36, 72 and 108 lb of draft, the lift at the last
  step, the McKyes & Ali estimate twice (with the c, phi of the modified
  cap's failure surface at the wedge's stress level, which `soilbin run`
  writes as draft_estimate_material, and with the scene's [tool.estimate],
  the soil's laboratory phi = 33 deg, c = 0 of section VII.5, which it writes
  as draft_estimate), Newton iterations and wall time;
- the volume-change table of chapter VIII: the incremental volumetric strain
  (x 10^3, negative in compression) of the soil element in front of the
  embedded 2-in vertical tool with the interface, per 12-lb load step, small
  against large deformation (read off the curve at 12, 24, ... lb, linear
  between converged steps where the adaptive steps did not land on one).
Loads and travel in lb and in; the dissertation's figures 8.2-8.9 are the
study's figure-8.*.png (drawn here too, of the cases finished so far),
figures 8.10-8.12 each case's sections-*.png; figures 8.2-8.9 are copied into
docs/figures (--figures DIR).
"""
import shutil

import numpy as np

from soilbin.app.estimates import draft_estimate, material_draft_estimate
from soilbin.app.study import Outcome, draw_figures, load_study
from soilbin.closed_form import NoWedge
from soilbin.records.scene import load_scene
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, finished, run_study

STUDY = ROOT / "studies" / "chapter8.toml"
LOADS = (36.0, 72.0, 108.0)
STEP_LOAD = 12.0   # lb, the study's load step
KEYS = ("mesh.configuration", "mesh.tool_width", "mesh.rake_angle", "tool.bonded",
        "analysis.large_deformation")


def cases(study, folder):
    """(overrides dict, summary, curve rows, scene run, case) of every finished case."""
    for case, summary, rows in finished(study, folder):
        values = dict(item.split("=", 1) for item in summary["overrides"])
        yield ({k: values[k].strip('"') for k in KEYS}, summary, rows,
               load_scene(folder / case.name / "scene.toml"), case)


def estimates(scene):
    """McKyes & Ali drafts: with the FE soil's c, phi (the cap's failure surface at the
    wedge), and with the scene's [tool.estimate] (the laboratory phi, c of section VII.5)."""
    return _draft(material_draft_estimate, scene), _draft(draft_estimate, scene)


def _draft(estimate, scene):
    try:
        return f"{estimate(scene).draft:.3g}"
    except NoWedge:
        return "no wedge"


def travel_at(rows, load):
    row = next((r for r in rows if abs(r["force"] - load) < 1e-6 * load), None)
    return f"{row['displacement']:.4g}" if row else "–"


def softening(rows):
    """Travel per pound of the last step over the secant travel per pound at the first
    STEP_LOAD (what the limit criterion compares with 100)."""
    first = next((r for r in rows if r["force"] >= STEP_LOAD * (1 - 1e-9)), None)
    if first is None or len(rows) < 2:
        return "–"
    last, before = rows[-1], rows[-2]
    per_lb = (last["displacement"] - before["displacement"]) / (last["force"] - before["force"])
    return f"{per_lb / (first['displacement'] / first['force']):.3g}"


def case_table(results):
    lines = ["| tool | interface | deformation | travel at 36 / 72 / 108 lb [in] | last load [lb] "
             "(travel per lb ÷ first 12 lb's) | lift at the last step [lb] | estimate: cap "
             "surface / lab φ [lb] | status | Newton (steps) | wall (s) |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for values, summary, rows, scene, _ in results:
        tool = (f"{values['mesh.tool_width']}-in, {values['mesh.rake_angle']}°, "
                f"{values['mesh.configuration'].replace('_', ' ')}")
        lines.append(" | ".join([
            f"| {tool}", "no" if values["tool.bonded"] == "true" else "yes",
            "large" if values["analysis.large_deformation"] == "true" else "small",
            " / ".join(travel_at(rows, load) for load in LOADS),
            f"{rows[-1]['force']:.4g} ({softening(rows)})" if rows else "–",
            f"{rows[-1]['lift']:.3g}" if rows else "–",
            " / ".join(estimates(scene)), summary["status"],
            f"{summary['newton_iterations']} ({summary['n_steps']})", f"{summary['wall_s']:.0f} |"]))
    return "\n".join(lines)


#: The case whose sections at 108 lb the page shows (figures 8.10-8.12: the 2-in tool against
#: the side wall with the interface), copied as sections-side-wall-108.png.
SECTIONS_CASE = {"mesh.configuration": "side_wall", "mesh.tool_width": "2", "mesh.rake_angle": "90",
                 "tool.bonded": "false", "analysis.large_deformation": "false"}


def volume_change_table(results):
    """Increments of the front element's volumetric strain per 12-lb step, x 10^3."""
    picked = {values["analysis.large_deformation"]: rows for values, _, rows, _, _ in results
              if values["mesh.configuration"] == "embedded" and values["mesh.tool_width"] == "2"
              and values["mesh.rake_angle"] == "90" and values["tool.bonded"] == "false"}
    loads = STEP_LOAD * np.arange(8)
    increments = {}
    for large, rows in picked.items():
        force = [0.0] + [r["force"] for r in rows]
        strain = [0.0] + [r["front_volumetric_strain"] for r in rows]
        reached = loads <= force[-1] * (1.0 + 1e-9)
        increments[large] = np.where(reached, np.interp(loads, force, strain), np.nan)
    lines = ["| load [lb] | small deformation | large deformation |", "| --- | --- | --- |"]
    for k in range(1, 8):
        cells = []
        for large in ("false", "true"):
            strain = increments.get(large)
            step = np.nan if strain is None else strain[k] - strain[k - 1]
            cells.append("–" if np.isnan(step) else f"{1e3 * step:.3g}")
        lines.append(f"| {loads[k]:g} | {cells[0]} | {cells[1]} |")
    return "\n".join(lines)


def main():
    args = arguments(__doc__, "chapter8", "chapter8.md")
    run_study(STUDY, args)
    study = load_study(STUDY)
    results = list(cases(study, args.out))
    # the figures of the finished cases (the study draws them itself once all are done)
    draw_figures(study, [Outcome(case, summary["status"], summary, ran=False)
                         for _, summary, _, _, case in results], args.out)
    text = (case_table(results) + "\n\nVolume change of the soil element in front of the embedded "
            "2-in vertical tool with the interface: incremental volumetric strain × 10³ per 12-lb "
            "step (negative in compression; dissertation: small −0.54, −1.53, −1.31, −1.19, −2.70, "
            "−3.03, −3.18; large −0.57, −1.47, −1.98, −2.88, −2.58, −4.87, −3.34):\n\n"
            + volume_change_table(results) + "\n")
    print(text)
    for figure in study.figures:
        shutil.copy(args.out / f"{figure.name}.png", args.figures / f"{figure.name}.png")
    sections = next((case for values, _, _, _, case in results if all(
        values[key] == value for key, value in SECTIONS_CASE.items())), None)
    if sections is not None and (args.out / sections.name / "sections-108.png").is_file():
        shutil.copy(args.out / sections.name / "sections-108.png",
                    args.figures / "sections-side-wall-108.png")
    write_between_markers(args.page, "chapter8", text)


if __name__ == "__main__":
    main()
