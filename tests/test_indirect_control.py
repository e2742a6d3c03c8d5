"""Indirect displacement control (``loading.control = "indirect_displacement"``): a uniform
traction whose magnitude is the Newton system's extra unknown, with the equation that the
loaded boundary's mean displacement is the load factor's (``problem.loads.BoundaryLoad``)."""
import math

import pytest

from conftest import SCENES, make_problem
from soilbin.errors import InputError
from soilbin.records.scene import load_scene

INDIRECT = ("loading.control=indirect_displacement", "loading.until_collapse=false")


def test_the_strip_load_is_followed_to_its_limit_without_a_cut_step(solve_file):
    """VII.4 by mean settlement: every step converges at its nominal size, lands on its
    settlement, and the pressure levels off at (2 + pi) c (+0.47% measured; force control
    brackets the collapse from below by step cutting, 90.31 psi)."""
    result, rows, _ = solve_file(SCENES / "strip-load-von-mises.toml", *INDIRECT,
                                 "loading.magnitude=0.1")
    assert result.complete and len(rows) == 10
    assert all(r.cuts == 0 and r.failed_iterations == 0 for r in result.steps)
    for row in rows:
        assert row["displacement"] == pytest.approx(0.1 * row["load_factor"], rel=1e-9)
    pressures = [r.columns["pressure"] for r in result.steps]
    assert pressures == sorted(pressures)
    assert pressures[-1] == pytest.approx((2 + math.pi) * 17.5, rel=0.01)
    assert pressures[-1] - pressures[-2] < 1e-4 * pressures[-1]   # on the plateau


def test_the_pressure_found_gives_the_settlement_under_force_control(solve_file):
    """One plastic step (0.01 in, about 77% of the limit): the traction that indirect control
    solves for, applied under force control, settles the strip by the same 0.01 in."""
    indirect, _, _ = solve_file(SCENES / "strip-load-von-mises.toml", *INDIRECT,
                                "loading.magnitude=0.01", "loading.steps=1")
    pressure = indirect.steps[-1].columns["pressure"]
    assert pressure > math.pi * 17.5   # past first yield
    force, rows, _ = solve_file(SCENES / "strip-load-von-mises.toml",
                                "loading.until_collapse=false", f"loading.magnitude={pressure!r}",
                                "loading.steps=1")
    assert rows[-1]["displacement"] == pytest.approx(0.01, rel=1e-7)


@pytest.mark.parametrize("overrides, message", [
    (("loading.control=indirect_displacement",),
     "loading.until_collapse = true: only under force control"),
    (INDIRECT + ("solver.line_search=cp",), "solver.line_search = 'cp' needs an energy"),
])
def test_what_indirect_control_refuses(overrides, message):
    with pytest.raises(InputError, match=message):
        load_scene(SCENES / "strip-load-von-mises.toml", overrides)


def test_a_tool_is_not_driven_by_indirect_control():
    with pytest.raises(InputError, match="drives a traction on a boundary, not the tool"):
        load_scene(SCENES / "tine-2in-90deg.toml", ["loading.control=indirect_displacement"])


def test_a_held_boundary_is_refused_with_its_name(tmp_path):
    """A support holding the loaded boundary along the load leaves the traction nothing to
    move: a one-line input error, not a division by zero."""
    scene = tmp_path / "held.toml"
    scene.write_text((SCENES / "strip-load-von-mises.toml").read_text()
                     + '\n[[supports]]\nboundary = "footing"\nfix = ["z"]\n')
    with pytest.raises(InputError, match="a traction on 'footing' does not move it"):
        make_problem(scene, *INDIRECT, "mesh.edge_size=0.1")
