"""Frame indifference with rollers, plane strain and gravity: the scene turned by a rotation
gives the same curve, the same dofs (components along the scene's axes) and the rotated stress."""
import numpy as np
import pytest

from conftest import make_problem
from soilbin.errors import InputError
from soilbin.solver.stepping import run_load_steps
from soilbin.tensors import from_mandel, rotation_matrix

#: A Drucker-Prager block on rollers under its own weight, pressed by a rough platen.
ROLLERS_AND_GRAVITY = """
title = "block on rollers under its own weight, pressed by a rough platen"
units = "lb, ft"
[mesh]
builder = "box"
lx = 2.0
ly = 1.0
lz = 1.0
nx = 2
ny = 1
nz = 2
[regions]
soil = "soil"
[materials.soil]
model = "drucker_prager"
E = 500000.0
nu = 0.3
c = 500.0
phi = 30.0
matching = "compression_cone"
[geostatic]
unit_weight = 120.0
K0 = 0.5
surface = 1.0
[[supports]]
boundary = "base"
fix = ["z"]
[[supports]]
boundary = "xmin"
fix = ["x"]
[[supports]]
boundary = "xmax"
fix = ["x"]
[[supports]]
boundary = "ymin"
fix = ["y"]
[[supports]]
boundary = "top"
fix = ["x", "y"]
[loading]
control = "displacement"
boundary = "top"
direction = "-z"
magnitude = 0.01
steps = 4
"""

ROTATION = [31.0, -47.0, 76.0]


def solved(scene, rotation, *overrides):
    problem = make_problem(scene, f"analysis.frame_rotation={rotation}", *overrides)
    rows = []
    run_load_steps(problem, problem.scene.loading.steps, 0, rows.append)
    return problem, rows


@pytest.mark.parametrize("large", [False, True])
def test_rollers_and_gravity_in_a_rotated_frame(tmp_path, large):
    scene = tmp_path / "rollers.toml"
    scene.write_text(ROLLERS_AND_GRAVITY)
    option = f"analysis.large_deformation={str(large).lower()}"
    (plain, a), (turned, b) = (solved(scene, r, option) for r in ([0.0, 0.0, 0.0], ROTATION))
    assert len(a) == len(b) == 4
    for x, y in zip(a, b):
        assert y.displacement == pytest.approx(x.displacement, rel=1e-8)
        assert y.force == pytest.approx(x.force, rel=1e-8)
    # the dofs are components along the scene's axes: the same numbers
    w0, w1 = plain.w.x.array, turned.w.x.array
    assert np.abs(w1 - w0).max() <= 1e-8 * np.abs(w0).max()
    Q = rotation_matrix(ROTATION)
    s0 = from_mandel(plain.points.committed["soil"]["stress"])
    s1 = from_mandel(turned.points.committed["soil"]["stress"])
    assert np.abs(s1 - Q @ s0 @ Q.T).max() <= 1e-8 * np.abs(s0).max()
    assert (plain.points.committed["soil"]["yield_state"] > 0).any()   # plastic
    assert a[0].force > 0.0


@pytest.mark.parametrize("rotation", [ROTATION, [0.0, 47.0, 0.0]])
def test_a_pressure_in_large_deformation_in_a_rotated_frame(rotation):
    """The large-deformation column under its pressure, turned: the same settlement. (With
    the traction's direction as UFL literals FFCx 0.5 could not compile its form where the
    turned direction has a zero component: the second rotation.)"""
    settlements = [solved("column-elastic-large", turn, "loading.steps=2")[1][-1].displacement
                   for turn in ([0.0, 0.0, 0.0], rotation)]
    assert settlements[1] == pytest.approx(settlements[0], rel=1e-10)


def test_plane_strain_footing_in_a_rotated_frame():
    """The strip footing on its slab (rollers, plane strain, hex8-bbar) turned: the same first
    steps."""
    overrides = ("loading.steps=40", "mesh.edge_size=0.2", "mesh.far_size=2.0", "mesh.dimension=3",
                 "analysis.element=hex8-bbar")
    curves = []
    for rotation in ([0.0, 0.0, 0.0], ROTATION):
        problem = make_problem("strip-footing-von-mises", f"analysis.frame_rotation={rotation}",
                               *overrides)
        rows = []
        for factor in (0.025, 0.05):
            problem.set_load_factor(factor)
            problem.solve()
            problem.commit()
            rows.append(problem.observe())
        curves.append(rows)
    for x, y in zip(*curves):
        assert y.displacement == pytest.approx(x.displacement, rel=1e-8)
        assert y.force == pytest.approx(x.force, rel=1e-8)


def test_a_tool_scene_cannot_be_rotated():
    with pytest.raises(InputError, match="frame_rotation: a scene with a tool"):
        make_problem("tine-2in-90deg", "analysis.frame_rotation=[0.0, 10.0, 0.0]")
