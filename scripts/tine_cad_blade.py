"""The blade from a STEP file on tetrahedra against the built-in blade on bricks, both
under force control to 108 lb: studies/tine-cad-blade.toml (tet10-bbar, seven meshes) and
studies/tine-blade-hex27.toml (hex27-bbar, four), beside `make run`'s trilinear bricks; the
tine-cad-blade tables of docs/chapter8.md.

Runs both studies (resumable; --out DIR holds them and `make run`'s scene, run there if
it has no curve), then writes between the tine-cad-blade markers of docs/chapter8.md
(--page): per case its cells, unknowns, Newton iterations and steps, CPU time and the
travel at 36, 72 and 108 lb of draft; below it each case's draft at the travel that the
finest quadratic bricks reach at those loads, against those loads: where the curve is
flat (108 lb) the travel magnifies a difference of the drafts many times, so the drafts
are compared at equal travel. Loads in lb, travel in in.
"""
import csv
import json
import subprocess

from soilbin.app.study import load_study
from soilbin.records.scene import load_scene
from doc_tables import ROOT, write_between_markers
from study_tables import SOILBIN, arguments, at, finished, run_study, travel_at

#: Each study with the blade and element of its cases; the finest case of the last one, the
#: quadratic bricks, is the reference of the drafts at equal travel.
STUDIES = {"tine-cad-blade": "from STEP, `tet10-bbar`",
           "tine-blade-hex27": "built in, `hex27-bbar`"}
TRILINEAR = "tine-2in-108lb"
LOADS = (36.0, 72.0, 108.0)
SIZE, GROWTH = "mesh.element_size", "mesh.growth"


def shown(value, form=".4g"):
    return "–" if value is None else f"{value:{form}}"


def trilinear(folder):
    """(blade and element, (element size, growth), summary, rows) of `make run`'s scene
    (hex8-bbar), run into ``folder`` if it holds no finished run."""
    if not (folder / "summary.json").is_file():
        subprocess.run([SOILBIN, "run", TRILINEAR, "--out", folder], cwd=ROOT, check=True)
    with open(folder / "curve.csv") as f:
        rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    mesh = load_scene(ROOT / "scenes" / f"{TRILINEAR}.toml").mesh
    return ("built in, `hex8-bbar`", (mesh.element_size, mesh.growth),
            json.loads((folder / "summary.json").read_text()), rows)


def cases(args):
    """(blade and element, (element size, growth), summary, rows) of every finished case,
    the trilinear bricks first, then each study's coarse to fine."""
    found = [trilinear(args.out / TRILINEAR)]
    for name, label in STUDIES.items():
        study = load_study(ROOT / "studies" / f"{name}.toml")
        own = load_scene(study.scene_path).mesh
        done = [(label, (case.values[SIZE], case.values.get(GROWTH, own.growth)), summary, rows)
                for case, summary, rows in finished(study, args.out / name)]
        found += sorted(done, key=lambda c: (-c[1][0], -c[1][1]))
    return found


def mesh_name(mesh):
    size, growth = mesh
    return f"{size:g} / {growth:g}"


def tables(found):
    lines = ["| blade, element | element size at the blade [in] / growth | cells | unknowns | "
             "Newton (steps) | CPU [s] | travel at 36 / 72 / 108 lb [in] |",
             "| --- | --- | --- | --- | --- | --- | --- |"]
    for label, mesh, summary, rows in found:
        travels = " / ".join(shown(travel_at(rows, load)) for load in LOADS)
        lines.append(f"| {label} | {mesh_name(mesh)} | {summary['n_cells']} | "
                     f"{summary['n_dofs']} | {summary['newton_iterations']} "
                     f"({summary['n_steps']}) | {summary['cpu_s']:.0f} | {travels} |")
    if found[-1][0] != STUDIES["tine-blade-hex27"]:   # no quadratic brick finished yet
        return "\n".join(lines) + "\n"
    reference = found[-1][3]
    travels = [travel_at(reference, load) for load in LOADS]
    lines += ["", f"| blade, element | element size at the blade [in] / growth | "
              + " | ".join(f"draft at {shown(t)} in [lb], against {load:g} lb"
                           for t, load in zip(travels, LOADS)) + " |",
              "| --- | --- | --- | --- | --- |"]
    for label, mesh, _, rows in found:
        if rows is reference:
            cells = [f"{load:g} (the reference)" for load in LOADS]
        else:
            drafts = [None if t is None else at(rows, "force", t) for t in travels]
            cells = ["–" if d is None else f"{d:.1f} ({100 * (d / load - 1):+.1f}%)"
                     for d, load in zip(drafts, LOADS)]
        lines.append(f"| {label} | {mesh_name(mesh)} | " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def main():
    args = arguments(__doc__, "tine-cad-blade", "chapter8.md")
    for name in STUDIES:
        run_study(ROOT / "studies" / f"{name}.toml", args, out=args.out / name)
    text = tables(cases(args))
    print(text)
    write_between_markers(args.page, "tine-cad-blade", text)


if __name__ == "__main__":
    main()
