"""The Mohr–Coulomb interface law at contact points: closed forms and tangent."""
import math

import numpy as np
import pytest

from soilbin.errors import InputError
from soilbin.models.mohr_coulomb_interface import MohrCoulombInterface
from soilbin.params import from_table
from conftest import make_problem

LAW = MohrCoulombInterface(k_n=1e5, k_s=4e4, c_a=3.0, delta=25.0)
NORMAL = np.array([0.0, 0.0, -1.0])


def update(jump, slip=None, law=LAW, normal=NORMAL):
    jump = np.atleast_2d(jump).astype(float)
    n = np.tile(normal, (len(jump), 1))
    state = {"slip": np.zeros_like(jump) if slip is None else np.atleast_2d(slip)}
    return law.traction_update(jump, n, state)


def test_stick_stiffness():
    t, tangent, state = update([1e-5, 2e-5, -1e-4])       # pressed 1e-4 into the tool
    assert t[0] == pytest.approx([0.4, 0.8, -10.0])       # k_s jump_t, k_n g along n
    assert np.allclose(tangent[0], np.diag([4e4, 4e4, 1e5]))
    assert np.allclose(state["slip"], 0.0)


def test_slip_at_adhesion_plus_friction():
    t, _, state = update([0.01, 0.0, -1e-4])
    sigma_n = 1e5 * 1e-4
    assert t[0, 0] == pytest.approx(3.0 + sigma_n * math.tan(math.radians(25.0)), rel=1e-14)
    assert state["slip"][0, 0] == pytest.approx(0.01 - t[0, 0] / 4e4)
    # unloading the shear from the slipped state is elastic again
    t2, _, _ = update([0.01 - 1e-5, 0.0, -1e-4], slip=state["slip"])
    assert t2[0, 0] == pytest.approx(t[0, 0] - 4e4 * 1e-5)


def test_separation_carries_nothing_and_forgets_slip():
    t, tangent, state = update([0.3, -0.1, 2e-3])           # pulled away from the tool
    assert np.all(t == 0.0) and np.all(tangent == 0.0)
    assert state["slip"][0] == pytest.approx([0.3, -0.1, 0.0])


@pytest.mark.parametrize("jump, slip", [
    ([1e-5, 2e-5, -1e-4], [0.0, 0.0, 0.0]),          # stick
    ([0.01, 0.004, -1e-4], [0.0, 0.0, 0.0]),         # slip
    ([0.02, -0.01, -3e-4], [0.005, 0.001, 0.0]),     # slip with history
    ([0.01, 0.0, 1e-4], [0.0, 0.0, 0.0]),            # separation
])
def test_tangent_matches_central_differences(jump, slip):
    normal = np.array([0.6, 0.0, -0.8])               # an inclined (raked) face
    jump, slip = np.asarray(jump), np.asarray(slip)
    slip = slip - slip.dot(normal) * normal
    _, tangent, _ = update(jump, slip, normal=normal)
    h, fd = 1e-9, np.zeros((3, 3))
    for j in range(3):
        e = np.zeros(3)
        e[j] = h
        fd[:, j] = (update(jump + e, slip, normal=normal)[0][0]
                    - update(jump - e, slip, normal=normal)[0][0]) / (2 * h)
    assert np.allclose(tangent[0], fd, rtol=1e-6, atol=1e-6 * 1e5)


def test_parameters_are_checked():
    with pytest.raises(InputError, match="delta"):
        from_table(MohrCoulombInterface, {"k_n": 1.0, "k_s": 1.0, "delta": 95.0}, "tool.interface")
    with pytest.raises(InputError, match="k_n"):
        MohrCoulombInterface(k_n=0.0, k_s=1.0)


# ---- the interface in the finite element model: a stiff block on a rigid plate (the tool) ----

BLOCK_ON_PLATE = """
title = "block on a rigid plate"
units = "any"
[mesh]
builder = "box"
lx = 2.0
nx = 2
nz = 2
[regions]
soil = "soil"
[materials.soil]
model = "elastic"
E = 1.0e7        # stiff: the interface alone governs
nu = 0.3
[tool]
faces = ["base"]
[tool.interface]
k_n = 1.0e6
k_s = 1.0e5
c_a = 2.0
delta = 20.0
[loading]
control = "displacement"
boundary = "tool"
direction = "+x"
magnitude = 0.01
steps = 10
"""

HELD_AT_WALL = """
[[supports]]
boundary = "xmin"
fix = ["x"]
[[supports]]
boundary = "ymin"
fix = ["y"]
[[tractions]]
boundary = "top"
direction = "-z"
magnitude = 50.0
"""

HELD_AT_TOP = """
[[supports]]
boundary = "top"
fix = ["x", "y", "z"]
"""


def block_scene(tmp_path, supports):
    path = tmp_path / "block.toml"
    path.write_text(BLOCK_ON_PLATE + supports)
    return path


#: The patch tests on the box's quadrilateral faces and on its triangles (each brick in six
#: tetrahedra).
ELEMENTS = pytest.mark.parametrize("element", ["hex8", "tet10-bbar"])


def test_every_node_of_a_six_node_triangle_is_a_contact_point(tmp_path):
    """A corner's φ of a six-node triangle integrates to zero over it: the contact areas are
    the lumped ones instead, a corner A/19 and a mid-edge node 16 A/57 of each triangle, so
    that every node of the tool's face (none free to pass into the tool) is a contact point,
    and they sum to the face's area."""
    problem = make_problem(block_scene(tmp_path, HELD_AT_WALL), "analysis.element=tet10-bbar")
    interface = problem.tool.interface
    x = interface.scalar_space.tabulate_dof_coordinates()
    owned = interface.scalar_space.dofmap.index_map.size_local
    on_base = np.flatnonzero(np.isclose(x[:owned, 2], 0.0))
    assert np.array_equal(np.sort(interface.nodes), on_base) and len(on_base) == 15
    assert (interface.areas > 0.0).all() and interface.areas.sum() == pytest.approx(2.0, rel=1e-12)
    at = x[interface.nodes, :2]
    corner = np.isclose(at, np.round(at)).all(axis=1)    # the squares' corners
    assert corner.sum() == 6
    # each of the four triangles (0.5 each) gives each of its three corners A/19
    assert interface.areas[corner].sum() == pytest.approx(3 * 2.0 / 19.0, rel=1e-12)


@ELEMENTS
def test_sliding_block_carries_adhesion_plus_friction(tmp_path, solve_file, element):
    """Shear force at slip = c_a A + N tan(delta), with N = p A (A = 2, p = 50)."""
    summary, rows, problem = solve_file(block_scene(tmp_path, HELD_AT_WALL),
                                        f"analysis.element={element}")
    slip_force = 2.0 * 2.0 + 50.0 * 2.0 * math.tan(math.radians(20.0))
    assert rows[-1]["force"] == pytest.approx(slip_force, rel=1e-9)


@ELEMENTS
def test_block_pulled_off_the_tool_separates(tmp_path, solve_file, element):
    summary, rows, problem = solve_file(block_scene(tmp_path, HELD_AT_TOP), "loading.direction=-z",
                                        f"analysis.element={element}")
    assert all(row["force"] == 0.0 for row in rows)
    assert np.allclose(problem.tool.interface.gap(), 0.01)


@pytest.mark.parametrize("held, direction, stiffness", [(HELD_AT_WALL, "+x", 1.0e5),
                                                      (HELD_AT_TOP, "+z", 1.0e6)])
@ELEMENTS
def test_stick_stiffness_is_the_penalty(tmp_path, solve_file, held, direction, stiffness, element):
    """The plate moved by U along or against a stiff block that sticks: F = k A U."""
    summary, rows, _ = solve_file(block_scene(tmp_path, held), f"loading.direction={direction}",
                                  f"analysis.element={element}",
                                  "loading.magnitude=1e-6", "tool.interface.c_a=1e9",
                                  "materials.soil.E=1e10")
    assert rows[-1]["force"] == pytest.approx(stiffness * 2.0 * 1e-6, rel=2e-3)
