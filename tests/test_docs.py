"""The user guide's scene table, model list and builder list are those of the code, its
default of `make run` is the Makefile's, the performance page's benchmark block is what the
benchmark writes from its rows, and the scripts' tables are what they say."""
import re
from types import SimpleNamespace

import numpy as np

from soilbin.meshes import BUILDERS
from soilbin.models import MODELS
from conftest import ROOT, SCENES

GUIDE = (ROOT / "docs" / "user-guide.md").read_text()


def section_names(heading, row):
    """The backticked first-column names of the lines matching ``row`` after ``heading``,
    up to the next heading."""
    text = GUIDE.split(heading, 1)[1].split("\n#", 1)[0]
    return [m.group(1) for m in re.finditer(row, text, flags=re.MULTILINE)]


def test_the_scene_table_has_one_row_per_scene():
    names = section_names("| scene | problem | headline |", r"^\| `([\w-]+)` \|")
    assert sorted(names) == sorted(p.stem for p in SCENES.glob("*.toml"))


def test_the_default_of_make_run_is_the_makefiles():
    default = re.search(r"^SCENE\s*\?=\s*scenes/([\w-]+)\.toml", (ROOT / "Makefile").read_text(),
                        flags=re.MULTILINE).group(1)
    rows = [line for line in GUIDE.splitlines() if "default of `make run`" in line]
    assert len(rows) == 1 and rows[0].startswith(f"| `{default}` |")


def test_the_model_list_is_the_registry():
    assert section_names("### Models", r"^- `(\w+)`:") == list(MODELS)


def test_the_builder_list_is_the_catalogue():
    assert section_names("### Mesh builders", r"^- `(\w+)`:") == list(BUILDERS)


def test_the_benchmark_block_is_rebuilt_from_its_own_rows(monkeypatch):
    """`scripts/benchmark.py --update` keeps the page's rows of the cases it does not run: the
    block read back and written again from them is the block (on any machine: it names the
    one its rows were measured on), every row a case's, and a measured case's row is the one
    written from its results."""
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    import benchmark
    page = ROOT / "docs" / "performance.md"
    block = page.read_text().split("<!-- benchmark:start -->\n")[1].split("<!-- benchmark:end -->")[0]
    names = {name for quick in (False, True) for name, _, _ in benchmark.cases(quick)}
    rows, again, machine = benchmark.page_rows(page, names)
    first = [line for line in block.split(benchmark.COST_TITLE)[0].splitlines()
             if line.startswith("| ")]
    assert len(rows) == len(first) - 2   # the heading and the rule
    assert benchmark.markdown(list(rows.values()), "OMP_NUM_THREADS=1 python "
                              "scripts/benchmark.py", again, machine) == block
    name = next(iter(rows))
    measured = dict(case=name, element="hex8", solver="LU", dofs=10, steps=2, iterations=7,
                    failed=1, solve_s=0.5, setup_s=1.25, memory_MB=200.4, kind="error %",
                    value=0.0123, complete=True, until_collapse=False, krylov=0,
                    factorisation_s=0.008, assembly_s=0.004, constitutive_s=0.002,
                    linear_solve_s=0.001)
    assert benchmark.table_rows(measured) == (
        f"| {name} | hex8 | LU | 10 | 2 | 7 (1) | 0.50 | 1.75 | 200 | +0.0123 |",
        f"| {name} | 10 | 1.0 | 0.5 | 0.2 | 0.1 | - |")


def test_the_tetrahedral_blade_is_compared_at_the_travel_of_the_finest_quadratic_bricks(
        monkeypatch):
    """scripts/tine_cad_blade.py reads each curve's draft at the travel where the finest
    quadratic bricks carry 36, 72 and 108 lb: on straight curves, a blade 5% softer reads 5%
    less draft there; a curve that ends before that travel reads none."""
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    import tine_cad_blade

    def case(label, size, stiffness, end):
        rows = [{"displacement": u, "force": stiffness * u} for u in (0.0, end)]
        return label, (size, 1.5), dict(n_cells=1, n_dofs=3, newton_iterations=4, n_steps=2,
                                 cpu_s=1.0), rows
    quadratic = tine_cad_blade.STUDIES["tine-blade-hex27"]
    text = tine_cad_blade.tables([case("hex8", 0.5, 110.0, 0.9), case("tet", 1.0, 95.0, 1.2),
                                  case(quadratic, 1.0, 100.0, 1.08)])
    comparison = text.split("\n\n")[1].splitlines()
    assert comparison[0].startswith("| blade, element | element size at the blade [in] / growth"
                                    " | draft at 0.36 in [lb], against 36 lb | draft at 0.72 in")
    assert comparison[2] == "| hex8 | 0.5 / 1.5 | 39.6 (+10.0%) | 79.2 (+10.0%) | – |"
    assert comparison[3] == "| tet | 1 / 1.5 | 34.2 (-5.0%) | 68.4 (-5.0%) | 102.6 (-5.0%) |"
    assert comparison[4] == (f"| {quadratic} | 1 / 1.5 | 36 (the reference) | "
                             "72 (the reference) | 108 (the reference) |")


def test_the_paths_of_one_mesh_are_summed_up_by_their_mean_and_range(monkeypatch):
    """scripts/long_travel.py: the cases that differ only in the threshold of a remesh are the
    paths of one mesh; at a travel, the mean and range over those that reached it, over the
    last half over those that reached the end; no summary where each mesh has one path."""
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    import long_travel
    scene = SimpleNamespace(analysis=SimpleNamespace(element=SimpleNamespace(value="tet10-bbar")),
                            mesh=SimpleNamespace(element_size=1.0),
                            loading=SimpleNamespace(magnitude=8.0))

    def path(size, quality, draft, end):
        rows = [{"displacement": u, "force": draft} for u in np.linspace(0.0, end, 33)]
        return (SimpleNamespace(values={"mesh.element_size": size,
                                        "remesh.min_quality": quality}),
                {"steady_draft": draft}, rows, [])
    results = [path(1.0, 0.04, 200.0, 8.0), path(1.0, 0.05, 220.0, 8.0),
               path(1.0, 0.045, 300.0, 5.0), path(0.5, 0.04, 180.0, 8.0)]
    lines = long_travel.over_paths(results, scene).splitlines()
    assert lines[2] == ("| `tet10-bbar` | 1 | 3 (2) | 240.0 (200.0–300.0, ±20.8%) | "
                        "240.0 (200.0–300.0, ±20.8%) | 210.0 (200.0–220.0, ±4.8%) | "
                        "210.0 (200.0–220.0, ±4.8%) |")
    assert lines[3] == "| `tet10-bbar` | 0.5 | 1 (1) | 180.0 | 180.0 | 180.0 | 180.0 |"
    assert long_travel.over_paths(results[3:], scene) == ""


def test_the_steady_draft_is_fitted_against_the_cells_size_over_every_path_to_the_end(
        monkeypatch):
    """scripts/long_travel.py: D = D_inf + C h by least squares over the paths that reached the
    end (200 + 40 h, each mesh's two paths 2 lb either side of it; a path that stopped short,
    far off the line, left out), and D_inf with h² (exact on 200 + 40 h²); nothing with one
    mesh."""
    monkeypatch.syspath_prepend(str(ROOT / "scripts"))
    import long_travel
    scene = SimpleNamespace(mesh=SimpleNamespace(element_size=1.0),
                            loading=SimpleNamespace(magnitude=8.0))

    def path(size, draft, end=8.0):
        rows = [{"displacement": u, "force": draft} for u in np.linspace(0.0, end, 33)]
        return SimpleNamespace(values={"mesh.element_size": size}), {}, rows, []
    results = [path(h, 200.0 + 40.0 * h + noise) for h in (1.5, 1.0, 0.5) for noise in (-2, 2)]
    line = long_travel.mesh_limit(results + [path(0.5, 400.0, end=5.0)], scene)
    assert line.startswith("D = D∞ + C h through the draft over the last half of the 6 paths "
                           "that reached 8 in on 3 meshes (h = 1.5, 1, 0.5 in), by least "
                           "squares: D∞ = 200.0 ± 2.6 lb (one standard error), C = 40.0 lb/in, "
                           "the paths about the line ±2.0 lb (rms). With √h or h² instead of h: "
                           "D∞ = ")
    exact = long_travel.mesh_limit([path(h, 200.0 + 40.0 * h**2) for h in (1.5, 1.0, 0.5, 0.25)],
                                   scene)
    assert exact.endswith("or 200.0 lb (±0.0 lb rms).")
    assert long_travel.mesh_limit(results[:2], scene) == ""
