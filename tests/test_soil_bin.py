"""The tine in the soil bin: interface against bonded, the gap behind the tool, equilibrium."""
import csv

import numpy as np
import pytest
from mpi4py import MPI
from dolfinx import fem

from conftest import jacobian_error, make_problem
from soilbin.models.base import APEX, CAP, CAP_CORNER, ELASTIC, FAILURE
from soilbin.forms.virtual_work import internal_force
from soilbin.solver.stepping import run_load_steps

COARSE = ("mesh.element_size=1.5", "mesh.growth=1.6", "mesh.ahead=10.0", "mesh.behind=10.0",
          "mesh.bin_width=10.0", "loading.magnitude=0.04", "loading.steps=2")


def solve(*overrides, steps=2):
    problem = make_problem("tine-2in-90deg", *COARSE, *overrides)
    result = run_load_steps(problem, steps, 4, lambda r: None)
    assert result.complete
    return problem, result.steps[-1]


def support_reaction(problem, boundaries, axis):
    """Internal force of the soil on the supported dofs along an axis (their reaction)."""
    disc, tagged = problem.disc, problem.tagged
    probe = fem.Function(disc.space)
    for name in boundaries:
        facets = tagged.facet_tags.find(tagged.boundaries[name])
        probe.x.array[fem.locate_dofs_topological(disc.displacement_space.sub(axis), 2, facets)] = 1.0
    form = fem.form(internal_force(disc, problem.points.stress, problem.w, probe))
    return problem.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)


def test_gap_opens_behind_the_pushed_tool_and_draft_is_the_supports_reaction():
    problem, last = solve()
    contact, tagged = problem.tool.interface, problem.tagged
    gap = contact.gap()
    face_of_point = np.repeat([tagged.boundaries[f] for f in problem.scene.tool.faces],
                              contact.points_per_face)
    behind = face_of_point == tagged.boundaries["tool_back"]
    front = face_of_point == tagged.boundaries["tool_front"]
    assert gap[behind].max() > 0.5 * 0.04          # the soil behind came free of the tool
    assert gap[front].max() == 0.0                  # the front stays pressed
    assert last.force > 0.0
    # the bin holds the soil back with the draft force: the supports' internal force
    # sums to minus the draft (the tool pushes the soil along +x)
    reaction = support_reaction(problem, ["base", "back_end", "front_end"], 0)
    assert -reaction == pytest.approx(last.force, rel=1e-6)


@pytest.mark.slow
def test_bonded_tool_is_stiffer_than_the_interface():
    _, with_interface = solve()
    _, bonded = solve("tool.bonded=true")
    assert bonded.force > with_interface.force


@pytest.mark.slow
def test_force_controlled_tool_reaches_the_draft_of_the_displacement_controlled_run():
    """Force control: the tool's travel is an unknown; the draft equals the applied force
    and the tool stops where the displacement-controlled run needed that draft."""
    _, pushed = solve(steps=8)
    problem, pulled = solve("loading.control=force", f"loading.magnitude={pushed.force}", steps=8)
    assert pulled.force == pytest.approx(pushed.force, rel=1e-6)
    assert problem.tool.draft() == pytest.approx(pushed.force, rel=1e-6)
    assert pulled.displacement == pytest.approx(pushed.displacement, rel=0.01)
    assert max(pulled.residuals[1:]) < pulled.residuals[0]   # Newton with the border converges


@pytest.mark.slow
def test_embedded_half_model_reports_the_whole_tool():
    """Across the symmetry plane the mesh of a 2-in embedded tool is that of a 1-in tool
    against the glass wall: the whole embedded tool carries exactly twice the draft."""
    _, wall = solve("mesh.tool_width=1")
    _, embedded = solve("mesh.tool_width=2", "mesh.configuration=embedded")
    assert embedded.force == pytest.approx(2.0 * wall.force, rel=1e-10)
    assert embedded.columns["lift"] == pytest.approx(2.0 * wall.columns["lift"], rel=1e-10)


@pytest.mark.slow
def test_force_controlled_run_lands_on_the_stated_loads_and_draws_the_sections(tmp_path):
    from soilbin.app.run import run_scene
    from soilbin.records.scene import load_scene
    from conftest import SCENES

    overrides = [o for o in COARSE if not o.startswith(("loading.magnitude", "loading.steps"))]
    # the strict residual floor: the scene's 1e-6 of the force scale leaves 2e-9 of the load
    scene = load_scene(SCENES / "tine-2in-90deg.toml",
                       overrides + ["solver.atol=1e-10", "loading.control=force",
                                    "loading.magnitude=50",
                                    "loading.steps=2", "output.at=[20.0, 50.0]"])
    summary = run_scene(scene, tmp_path)
    assert summary["status"] == "complete"
    with open(tmp_path / "curve.csv") as f:
        rows = [(float(row["load_factor"]), float(row["force"])) for row in csv.DictReader(f)]
    assert [f for _, f in rows] == pytest.approx([50.0 * factor for factor, _ in rows], rel=1e-9)
    assert 20.0 in [round(f, 9) for _, f in rows] and rows[-1][1] == pytest.approx(50.0)
    assert (tmp_path / "sections-20.png").is_file() and (tmp_path / "sections-50.png").is_file()


def test_the_tine_is_factorised_by_ldlt_where_its_jacobian_is_symmetric():
    """Small strain: LDLᵀ for every iterate of the bonded tool in associated Drucker–Prager
    soil, LU for the iterates where a point slips on the Mohr–Coulomb interface (and for
    the cap soils, whose tangent is unsymmetric); the curves are LU's."""
    soil = "regions.soil=drucker_prager"
    for bonded, symmetric_everywhere in (("true", True), ("false", False)):
        _, reference = solve(f"tool.bonded={bonded}", soil, "solver.linear=lu")
        auto, last = solve(f"tool.bonded={bonded}", soil)
        linear = auto.newton.linear
        lu_iterates = linear.stats["unsymmetric_solves"]
        assert (lu_iterates == 0) == symmetric_everywhere
        every = linear.stats["factorisations"]
        assert linear.description == (
            "MUMPS LDLT" if symmetric_everywhere else
            "MUMPS LU (the Jacobian is unsymmetric)" if lu_iterates == every else
            f"MUMPS LDLT, LU for {lu_iterates} of {every} iterates (unsymmetric)")
        assert last.force == pytest.approx(reference.force, rel=1e-6)


@pytest.mark.parametrize("amplitude", [1e-2, 1e-4])
def test_the_tines_newton_matrix_is_the_derivative_of_its_residual(amplitude):
    """The assembled Newton matrix of the tine (hex8-bbar, the modified cap on its failure
    surface, apex, cap and cap corner, and elastic at the smaller amplitude; Mohr–Coulomb
    contact points separated, slipping and sticking) against central differences of the
    residual at a random state (docs/performance.md, *The large tine*: the stall of the fine
    mesh is not an inconsistent tangent). Measured: 1e-11 and 3e-10."""
    problem = make_problem("tine-2in-90deg", *COARSE)
    error, trial = jacobian_error(problem, amplitude=amplitude)
    assert error < 1e-8
    modes = set(np.unique(trial["soil"]["yield_state"]).astype(int))
    assert {FAILURE, APEX, CAP, CAP_CORNER} <= modes and (ELASTIC in modes) == (amplitude < 1e-3)
    interface = problem.tool.interface
    traction, _, trial = interface.law.traction_update(interface.jump(), interface.normals,
                                                       interface.committed)
    separated = ~traction.any(axis=1)
    slipping = ~separated & (trial["slip"] != interface.committed["slip"]).any(axis=1)
    assert separated.any() and slipping.any() and (~separated & ~slipping).any()
