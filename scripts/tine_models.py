"""The 2-in tine in each soil model: studies/tine-models.toml, its tables in docs/chapter8.md.

Runs `soilbin study studies/tine-models.toml` (resumable), then reads each
case's summary.json and curve.csv, prints and writes between the tine-models
and tine-dilatancy markers of docs/chapter8.md (--page), per case: the load steps
(cuts), the Newton iterations (per converged step, the first step's, and
those of attempts that were cut), the draft at 0.1, 0.25 and 0.5 in of travel
and the wall time: the three VII.5 soil models as the scene has them
(Drucker–Prager: c = 0, psi = phi) in tine-models, the Drucker–Prager cases
and the caps with less dilatancy in tine-dilatancy. Draws tine-models.png
and the study's own tine-dilatancy.png in the study folder and copies both
into docs/figures (--figures DIR).
Loads in lb, travel in in.
"""
import shutil

import numpy as np

from soilbin.app.study import Figure, Outcome, draw_figures, load_study
from soilbin.app.study_figures import curves_png
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, finished, run_study

STUDY = ROOT / "studies" / "tine-models.toml"
TRAVELS = (0.1, 0.25, 0.5)
SOILS = {"modified_cap": "modified cap, A = C = 5.6",
         "dimaggio_sandler": "DiMaggio–Sandler, A = C = 5.6",
         "drucker_prager": "Drucker–Prager, c = 0, ψ = φ"}
DP = "materials.drucker_prager."
CAP_DILATANCY = {soil: f"materials.{soil}.dilatancy" for soil in SOILS if soil != "drucker_prager"}


def outcomes(study, folder):
    """(Outcome, curve rows) of every finished case, in the study's order."""
    for case, summary, rows in finished(study, folder):
        yield Outcome(case, summary["status"], summary, ran=False), rows


def draft_at(rows, travel):
    """The draft at this travel, linear between converged steps; '–' if not reached."""
    travels = [0.0] + [r["displacement"] for r in rows]
    if travels[-1] < travel * (1.0 - 1e-9):
        return "–"
    return f"{np.interp(travel, travels, [0.0] + [r['force'] for r in rows]):.3g}"


def row(name, outcome, rows):
    summary = outcome.summary
    steps, newton, cuts = summary["n_steps"], summary["newton_iterations"], summary["cuts"]
    per_step = f"{newton / steps:.1f}; first step {int(rows[0]['newton_iterations'])}" if rows else "–"
    if cuts:
        steps = f"{steps} ({cuts} cuts)"
    if summary["status"] != "complete" and rows:
        steps = f"{steps}, stopped at {rows[-1]['displacement']:.3g} in"
    return (f"| {name} | {steps} | {newton} ({per_step}) | {summary['failed_newton_iterations']} | "
            + " / ".join(draft_at(rows, t) for t in TRAVELS) + f" | {summary['wall_s']:.0f} |")


HEADER = ("| {} | steps | Newton iterations (per step) | in cut attempts | draft at 0.1 / 0.25 / "
          "0.5 in [lb] | wall (s) |\n| --- | --- | --- | --- | --- | --- |")


def soil_model(outcome):
    """Whether the case is one of the soil models as the scene has them."""
    values = outcome.case.values
    soil = values["regions.soil"]
    if soil == "drucker_prager":
        return (values[DP + "c"], values[DP + "psi"]) == (0.0, 33.0)
    return CAP_DILATANCY[soil] not in values


def models_table(results):
    lines = [HEADER.format("soil")]
    for outcome, rows in results:
        if soil_model(outcome):
            lines.append(row(SOILS[outcome.case.values["regions.soil"]], outcome, rows))
    return "\n".join(lines)


def dilatancy_table(results):
    lines = [HEADER.format("model")]
    for outcome, rows in results:
        values = outcome.case.values
        soil = values["regions.soil"]
        if soil == "drucker_prager":
            psi = values[DP + "psi"]
            dilation = "ψ = φ = 33°" if psi == 33.0 else f"ψ = {psi:g}°"
            lines.append(row(f"Drucker–Prager, c = {values[DP + 'c']:g} psi, {dilation}",
                             outcome, rows))
        elif not soil_model(outcome):
            eta = values[CAP_DILATANCY[soil]]
            lines.append(row(f"{SOILS[soil]}, η_d = {eta:g}", outcome, rows))
    return "\n".join(lines)


def main():
    args = arguments(__doc__, "tine-models", "chapter8.md")
    run_study(STUDY, args)
    study = load_study(STUDY)
    results = list(outcomes(study, args.out))
    draw_figures(study, [outcome for outcome, _ in results], args.out)
    models = [outcome for outcome, _ in results if soil_model(outcome)]
    curves_png(Figure(name="tine-models", title="2-in vertical tine in the VII.5 soil models"),
               models, study, args.out)
    tables = {"tine-models": models_table(results), "tine-dilatancy": dilatancy_table(results)}
    for name, text in tables.items():
        print(text + "\n")
        shutil.copy(args.out / f"{name}.png", args.figures / f"{name}.png")
        write_between_markers(args.page, name, text + "\n")


if __name__ == "__main__":
    main()
