"""Gravity and K0 initial stress: in equilibrium before the first load step."""
import numpy as np
import pytest

from conftest import make_problem

LAYER = """
title = "a soil layer under its own weight"
units = "lb, in"
[mesh]
builder = "box"
lx = 20.0
ly = 10.0
lz = 10.0
nx = 4
ny = 2
nz = 4
[regions]
soil = "soil"
[materials.soil]
model = "drucker_prager"
E = 7000.0
nu = 0.3
c = 0.0
phi = 35.0
matching = "compression_cone"
[geostatic]
unit_weight = 0.064
K0 = 0.43
surface = 10.0
[[supports]]
boundary = "base"
fix = ["x", "y", "z"]
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
boundary = "ymax"
fix = ["y"]
[loading]
control = "force"
boundary = "top"
direction = "-z"
magnitude = 1.0
steps = 1
"""


@pytest.mark.parametrize("element", ["hex8", "hex8-bbar"])
def test_initial_stress_is_in_equilibrium(tmp_path, element):
    scene = tmp_path / "layer.toml"
    scene.write_text(LAYER)
    problem = make_problem(scene, f"analysis.element={element}")
    sigma = problem.points.committed["soil"]["stress"]
    z = problem.points.evaluate(problem.points.expression(
        __import__("ufl").SpatialCoordinate(problem.disc.mesh)))[:, 2]
    assert sigma[:, 2] == pytest.approx(0.064 * (z - 10.0), rel=1e-12)       # σ_v = γ (z - z_s)
    assert sigma[:, 0] == pytest.approx(0.43 * sigma[:, 2], rel=1e-12)      # σ_h = K0 σ_v
    problem.set_load_factor(0.0)
    problem.solve()
    u = problem.w.x.array if element == "hex8" else problem.w.sub(0).collapse().x.array
    settlement_scale = 0.064 * 10.0**2 / 7000.0     # γ H² / E
    assert np.abs(u).max() < 1e-10 * settlement_scale
