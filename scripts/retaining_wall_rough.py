"""VII.3, the rough wall: the rough and smooth wall studies, their tables in docs/verification.md.

Runs `soilbin study` on studies/retaining-wall-rough.toml and
studies/retaining-wall-smooth.toml (resumable; into --out/rough and
--out/smooth), then prints and writes between the retaining-wall-rough
markers of docs/verification.md (--page): per φ and δ, Kp on the default 1-in mesh and
on 0.5 in against Lancellotta's lower bound, with Coulomb's wedge, the wall
friction V over P tan δ and the CPU time; δ = 0 against the smooth wall; and
Kp with the penalty springs halved and doubled. Kp = P/(γH²/2), P the
horizontal (normal) force on the wall, V the vertical one (geomechanics
signs: the passive pressure positive, V the soil's upward drag on the wall).
"""
import math
from dataclasses import dataclass

from soilbin.app.study import load_study
from soilbin.closed_form.earth_pressure import coulomb_passive, lancellotta_passive
from doc_tables import ROOT, write_between_markers
from study_tables import arguments, finished, run_study

ROUGH, SMOOTH = (ROOT / "studies" / f"retaining-wall-{kind}.toml" for kind in ("rough", "smooth"))
MESHES = {1: "1 in", 2: "0.5 in"}   # mesh.refine -> element size


@dataclass(frozen=True)
class Run:
    scene: object
    summary: dict

    @property
    def kp(self):
        return self.summary["passive_coefficient"]

    def friction_ratio(self):
        """V / (P tan δ): 1 where the whole wall slips."""
        tan = math.tan(math.radians(self.scene.tool.interface.delta))
        return self.summary["wall_shear_coefficient"] / (self.kp * tan)


def results(study_path, folder):
    """{(φ, δ or None, k_n or None, refine): Run} of the finished cases (δ and k_n None for
    the smooth wall)."""
    study = load_study(study_path)
    table = {}
    for case, summary, _ in finished(study, folder):
        scene, tool = case.scene, case.scene.tool
        key = (scene.materials["sand"].phi, tool and tool.interface.delta,
               tool and tool.interface.k_n, scene.mesh.refine)
        table[key] = Run(scene, summary)
    return study, table


def fraction(phi, delta):
    """δ as a fraction of φ, e.g. 'φ/3 = 11.67°'."""
    for label, value in (("0", 0.0), ("φ/3", 1 / 3), ("φ/2", 1 / 2), ("2φ/3", 2 / 3)):
        if math.isclose(delta, value * phi, abs_tol=1e-9):
            return label if value == 0.0 else f"{label} = {delta:.4g}°"
    return f"{delta:.4g}°"


def error(kp, reference, digits=1):
    """The relative difference in percent, with a true minus sign."""
    return f"{100.0 * (kp / reference - 1.0):+.{digits}f}%".replace("-", "−")


def main_table(rough, k_default):
    dofs = {r: next(run.summary["n_dofs"] for (_, _, _, refine), run in rough.items()
                    if refine == r) for r in MESHES}
    lines = ["| φ (K0) | δ | lower bound (Lancellotta) | Coulomb | "
             + " | ".join(f"Kp, {MESHES[r]} ({dofs[r]} dofs) | vs lower bound" for r in MESHES)
             + " | V/(P tan δ), 1 / 0.5 in | CPU (s), 1 / 0.5 in |",
             "| --- " * (6 + 2 * len(MESHES)) + "|"]
    cases = sorted({(phi, delta) for phi, delta, k, _ in rough if k == k_default})
    for phi, delta in cases:
        runs = [rough.get((phi, delta, k_default, r)) for r in MESHES]
        K0 = next(run.scene.geostatic.K0 for run in runs if run)
        reference = lancellotta_passive(phi, delta)
        cells = [f"{phi:g}° ({K0:g})", fraction(phi, delta), f"{reference:.3f}",
                 f"{coulomb_passive(phi, delta):.3f}"]
        for run in runs:
            cells += [f"{run.kp:.3f}", error(run.kp, reference)] if run else ["–", "–"]
        cells.append(" / ".join(f"{run.friction_ratio():.3f}" if run and delta > 0.0 else "–"
                                for run in runs))
        cells.append(" / ".join(f"{run.summary['cpu_s']:.1f}" if run else "–" for run in runs))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def smooth_table(rough, smooth, k_default):
    lines = ["| φ | mesh | smooth wall | rough wall, δ = 0 | difference |",
             "| --- | --- | --- | --- | --- |"]
    for phi, _, _, refine in sorted(smooth):
        flat, rough_0 = smooth[phi, None, None, refine], rough.get((phi, 0.0, k_default, refine))
        if rough_0:
            a, b = flat.kp, rough_0.kp
            lines.append(f"| {phi:g}° | {MESHES[refine]} | {a:.4f} | {b:.4f} | {error(b, a, 2)} |")
    return "\n".join(lines)


def stiffness_table(rough, k_default):
    stiffnesses = sorted({k for _, _, k, _ in rough})
    lines = ["| φ, δ, mesh | " + " | ".join(f"k_n = k_s = {k:g} pci" for k in stiffnesses) + " |",
             "| --- " * (1 + len(stiffnesses)) + "|"]
    varied = sorted({(phi, delta) for phi, delta, k, _ in rough if k != k_default})
    for phi, delta in varied:
        for refine in MESHES:
            runs = [rough.get((phi, delta, k, refine)) for k in stiffnesses]
            lines.append(f"| {phi:g}°, {fraction(phi, delta)}, {MESHES[refine]} | "
                         + " | ".join(f"{run.kp:.5f}" if run else "–" for run in runs)
                         + " |")
    return "\n".join(lines)


def main():
    args = arguments(__doc__, "retaining-wall-rough", "verification.md")
    run_study(ROUGH, args, args.out / "rough")
    run_study(SMOOTH, args, args.out / "smooth")
    rough_study, rough = results(ROUGH, args.out / "rough")
    _, smooth = results(SMOOTH, args.out / "smooth")
    k_default = rough_study.cases[0].scene.tool.interface.k_n
    text = "\n\n".join([main_table(rough, k_default), smooth_table(rough, smooth, k_default),
                        stiffness_table(rough, k_default)]) + "\n"
    print(text)
    write_between_markers(args.page, "retaining-wall-rough", text)


if __name__ == "__main__":
    main()
