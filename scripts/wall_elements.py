"""VII.3's smooth wall on every two-dimensional element: which lock under dilatant flow.

Runs `soilbin study` on studies/wall-elements.toml (resumable; into --out) and writes
between the wall-elements markers of docs/theory.md (--page): per element, Kp on cells
of 2, 1 and 0.5 in against Rankine's, with Newton iterations and CPU time per mesh.
Kp = P/(γH²/2), P the wall's normal force per unit length (geomechanics signs).
"""
from soilbin.app.study import load_study
from soilbin.closed_form.earth_pressure import rankine_passive
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, finished, run_study

STUDY = ROOT / "studies" / "wall-elements.toml"


def percent(value, reference):
    """The relative difference in percent, with a true minus sign."""
    return f"{100.0 * (value / reference - 1.0):+.1f}%".replace("-", "−")


def table(study, folder):
    runs = {(case.scene.analysis.element.value, case.scene.mesh.element_size): summary
            for case, summary, _ in finished(study, folder)}
    elements = list(dict.fromkeys(element for element, _ in runs))
    sizes = sorted({size for _, size in runs}, reverse=True)
    phi = study.cases[0].scene.materials["sand"].phi
    rankine = rankine_passive(phi)
    lines = [f"| element | " + " | ".join(f"Kp, {size:g}-in cells | vs Rankine" for size in sizes)
             + " | Newton, " + " / ".join(f"{size:g}" for size in sizes)
             + " | CPU (s), " + " / ".join(f"{size:g}" for size in sizes) + " |",
             "| --- " * (3 + 2 * len(sizes)) + "|"]
    for element in elements:
        cells = [f"`{element}`"]
        row = [runs.get((element, size)) for size in sizes]
        for summary in row:
            kp = summary and summary.get("passive_coefficient")
            cells += [f"{kp:.3f}", percent(kp, rankine)] if kp else ["–", "–"]
        cells.append(" / ".join(str(s["newton_iterations"]) if s else "–" for s in row))
        cells.append(" / ".join(f"{s['cpu_s']:.1f}" if s else "–" for s in row))
        lines.append("| " + " | ".join(cells) + " |")
    lines.append(f"\nRankine's Kp at φ = {phi:g}°: {rankine:.3f}.")
    return "\n".join(lines) + "\n"


def main():
    args = arguments(__doc__, "wall-elements", "theory.md")
    run_study(STUDY, args)
    text = table(load_study(STUDY), args.out)
    print(text)
    write_between_markers(args.page, "wall-elements", text)


if __name__ == "__main__":
    main()
