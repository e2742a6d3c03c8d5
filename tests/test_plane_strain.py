"""Plane strain on a two-dimensional mesh (mesh.dimension = 2): the same discrete problem as
the one-hex-layer slab whose y displacement is held, with a third of the unknowns."""
import csv

import meshio
import numpy as np
import pytest

from soilbin.closed_form.verification import prandtl_limit_pressure
from soilbin.errors import InputError
from soilbin.records.scene import load_scene
from conftest import SCENES, soilbin_cli

FOOTING = SCENES / "strip-footing-von-mises.toml"
SLAB = ("mesh.dimension=3", "analysis.element=hex8-bbar")
PLANE = ("mesh.dimension=2", "analysis.element=quad4-bbar")


def pressures(out):
    with open(out / "curve.csv") as f:
        return np.array([float(row["pressure"]) for row in csv.DictReader(f)])


@pytest.mark.parametrize("extra", [pytest.param((), marks=pytest.mark.slow),
                                   ("analysis.large_deformation=true", "mesh.corner_size=0.05",
                                    "loading.magnitude=0.02", "loading.steps=4")],
                         ids=["small strain", "large deformation"])
def test_the_plane_mesh_solves_the_slab_s_problem(solve, extra):
    """Every step's footing pressure and Newton count equal the slab's (to round-off): the
    slab's nodes move alike in y, so its 2 x 2 x 2 points pair with the quad's 2 x 2."""
    slab, slab_out = solve("strip-footing-von-mises", *SLAB, *extra)
    plane, plane_out = solve("strip-footing-von-mises", *PLANE, *extra)
    assert plane["status"] == slab["status"] == "complete"
    assert plane["n_cells"] == slab["n_cells"]
    # the slab: 3 components at twice the nodes; both: a dilatation and a pressure per cell
    nodes = (plane["n_dofs"] - 2 * plane["n_cells"]) / 2
    assert slab["n_dofs"] - 2 * slab["n_cells"] == 6 * nodes
    assert plane["newton_iterations"] == slab["newton_iterations"]
    np.testing.assert_allclose(pressures(plane_out), pressures(slab_out), rtol=1e-9)


def test_the_rough_wall_s_tool_acts_on_the_plane_mesh_as_on_the_slab(solve):
    """The wall a rigid tool behind the Mohr–Coulomb interface (2-in cells): Kp and the wall's
    shear on the plane mesh equal the slab's, whose far boundary holds its hourglass family."""
    runs = [solve("retaining-wall-passive-rough", "mesh.element_size=2", "output.fields=[]",
                  *dimension)[0]
            for dimension in (("mesh.dimension=3", "analysis.element=hex8-reduced"), ())]
    for key in ("passive_coefficient", "wall_shear_coefficient"):
        assert runs[1][key] == pytest.approx(runs[0][key], rel=1e-9)
    assert runs[1]["newton_iterations"] == runs[0]["newton_iterations"]


def test_quadratic_quadrilaterals_reach_prandtl_within_half_a_percent(solve):
    """quad9-bbar (Q2/P1) on the default 2D mesh: +0.31% (docs/performance.md, *Run time
    against error*)."""
    summary, _ = solve("strip-footing-von-mises", "mesh.dimension=2", "analysis.element=quad9-bbar")
    error = summary["limit_pressure"] / prandtl_limit_pressure(17.5) - 1.0
    assert 0.0 < error < 0.005


def test_amg_on_the_plane_mesh_gives_the_direct_solver_s_curve(solve):
    """GAMG with the three rigid-body modes of the plane (condensed quad4-bbar) against LDLT."""
    extra = ("loading.magnitude=0.02", "loading.steps=2")
    direct, direct_out = solve("strip-footing-von-mises", *PLANE, *extra)
    amg, amg_out = solve("strip-footing-von-mises", *PLANE, *extra, "solver.linear=amg")
    assert amg["linear_solver"].startswith("GMRES")
    np.testing.assert_allclose(pressures(amg_out), pressures(direct_out), rtol=1e-6)


def test_fields_of_a_plane_run_are_in_the_scene_s_three_axes(tmp_path):
    """fields.xdmf: quadrilaterals in the x-z plane (y = 0), displacement with a zero y
    component, the 3 x 3 stress."""
    out = tmp_path / "plane"
    done = soilbin_cli("run", FOOTING, "--out", out, "--set", "loading.steps=2",
                       "--set", "loading.magnitude=0.01", "--set", "output.fields=['displacement', 'stress']")
    assert done.returncode == 0, done.stderr
    reader = meshio.xdmf.TimeSeriesReader(str(out / "fields.xdmf"))
    points, cells = reader.read_points_cells()
    assert [c.type for c in cells] == ["quad"]
    assert np.all(points[:, 1] == 0.0) and points[:, 2].min() == pytest.approx(-10.0)
    _, point_data, cell_data = reader.read_data(reader.num_steps - 1)
    u = point_data["displacement"]
    assert u.shape == (len(points), 3) and np.all(u[:, 1] == 0.0)
    assert u[:, 2].min() == pytest.approx(-0.01)   # the footing, pushed down
    stress = cell_data["stress"][0].reshape(-1, 3, 3)
    assert np.all(stress[:, 0, 1] == 0.0) and np.all(stress[:, 1, 2] == 0.0)
    assert np.all(stress[:, 1, 1] != 0.0)          # plane strain: σ_yy carries load


@pytest.mark.parametrize("override, message", [
    ("analysis.element=hex8-bbar", "is not an element of a 2D mesh (mesh.dimension = 2): "
                                   "use 'quad4-bbar'"),
    ("analysis.element=tet10-bbar", "use 'tri6-bbar'"),
    ("analysis.plane_strain=false", "analysis.plane_strain: mesh.dimension = 2"),
    ("analysis.frame_rotation=[0, 0, 30]", "cannot be turned out of its plane"),
    ("loading.direction=-y", "has no y direction"),
    ("supports=[{boundary = 'base', fix = ['x', 'y', 'z']}]", "supports[0].fix: y is not a "
                                                              "displacement"),
])
def test_what_a_plane_mesh_cannot_do_is_refused_by_key(override, message):
    with pytest.raises(InputError) as err:
        load_scene(FOOTING, ["mesh.dimension=2", override])
    assert message in str(err.value)


def test_a_quadrilateral_element_on_the_slab_is_refused():
    with pytest.raises(InputError) as err:
        load_scene(FOOTING, ["mesh.dimension=3", "analysis.element=quad9-bbar"])
    assert "use 'hex27-bbar'" in str(err.value)
    with pytest.raises(InputError) as err:
        load_scene(FOOTING, ["mesh.dimension=3", "analysis.element=tri6"])
    assert "use 'tet10'" in str(err.value)


@pytest.mark.slow
def test_two_ranks_give_the_serial_plane_footing(tmp_path):
    """mpirun -n 2 on the 2D footing: the serial limit pressure to 1e-9."""
    runs = {}
    for ranks in (None, 2):
        out = tmp_path / f"ranks{ranks}"
        done = soilbin_cli("run", FOOTING, "--out", out, mpi_ranks=ranks)
        assert done.returncode == 0, done.stderr
        runs[ranks] = pressures(out)
    np.testing.assert_allclose(runs[2], runs[None], rtol=1e-9)
