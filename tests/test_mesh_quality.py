"""The mesh's quality (least scaled Jacobian over the cells' corners) against closed forms."""
import math

import numpy as np
import pytest
from dolfinx import mesh as dmesh
from mpi4py import MPI

from soilbin.problem.mesh_quality import MeshQuality


def box(dim):
    if dim == 3:
        return dmesh.create_box(MPI.COMM_WORLD, [[0, 0, 0], [1, 2, 3]], [2, 3, 4],
                                dmesh.CellType.hexahedron)
    return dmesh.create_rectangle(MPI.COMM_WORLD, [[0, 0], [1, 2]], [2, 3],
                                  dmesh.CellType.quadrilateral)


@pytest.mark.parametrize("dim", [2, 3])
def test_right_angled_cells_are_one_and_a_shear_gives_the_sine_of_the_angle(dim):
    mesh = box(dim)
    quality = MeshQuality(mesh)
    assert quality.minimum() == pytest.approx(1.0, abs=1e-14)
    x = mesh.geometry.x
    x[:, 0] += 0.75 * x[:, dim - 1]   # simple shear, gamma = 0.75
    assert np.allclose(quality.cells(), 1 / math.sqrt(1 + 0.75**2), rtol=1e-12)
    x[:, :dim] *= 3.0                 # a uniform stretch keeps the angles
    assert quality.minimum() == pytest.approx(1 / math.sqrt(1 + 0.75**2), rel=1e-12)


def test_a_regular_simplex_is_one_and_the_split_cube_its_closed_form():
    """Verdict's normalisation: the equilateral triangle and the regular tetrahedron have
    1; the right triangles of a split square 1/√2 · 2/√3 (the corner between the
    hypotenuse and a leg: sin 45° over sin 60°); a cube split into six tetrahedra (each
    with edges 1, √2, √3 from a corner) √2 / √6 = 1/√3; a shear of either folds nothing."""
    triangle = dmesh.create_mesh(MPI.COMM_WORLD, np.array([[0, 1, 2]], dtype=np.int64),
                                 np.array([[0.0, 0.0], [1.0, 0.0], [0.5, np.sqrt(3) / 2]]),
                                 ufl_mesh(2))
    assert MeshQuality(triangle).minimum() == pytest.approx(1.0, rel=1e-12)
    regular = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], dtype=float)
    tetrahedron = dmesh.create_mesh(MPI.COMM_WORLD, np.array([[0, 1, 2, 3]], dtype=np.int64),
                                    regular, ufl_mesh(3))
    assert MeshQuality(tetrahedron).minimum() == pytest.approx(1.0, rel=1e-12)
    square = dmesh.create_rectangle(MPI.COMM_WORLD, [[0, 0], [1, 1]], [2, 2],
                                    dmesh.CellType.triangle)
    assert MeshQuality(square).minimum() == pytest.approx(math.sqrt(0.5) * 2 / math.sqrt(3),
                                                          rel=1e-12)
    cube = dmesh.create_unit_cube(MPI.COMM_WORLD, 2, 2, 2, dmesh.CellType.tetrahedron)
    quality = MeshQuality(cube)
    assert np.allclose(quality.cells(), 1 / math.sqrt(3), rtol=1e-12)
    cube.geometry.x[:, 0] += 0.2 * cube.geometry.x[:, 2]
    assert 0.0 < quality.minimum() < 1 / math.sqrt(3)


def ufl_mesh(dim):
    import ufl
    cell = "tetrahedron" if dim == 3 else "triangle"
    return ufl.Mesh(ufl.VectorElement("Lagrange", cell, 1, dim=dim))


def test_a_folded_cell_is_negative_and_a_mirrored_mesh_keeps_its_quality():
    mesh = box(3)
    quality = MeshQuality(mesh)
    x = mesh.geometry.x
    corner = np.flatnonzero(np.all(np.isclose(x, [0.5, 2 / 3, 0.75]), axis=1))
    x[corner, 2] += 2.0               # pushed through the cells above it
    assert quality.minimum() < 0.0
    mirrored = box(3)
    mirrored.geometry.x[:, 0] *= -1.0   # every cell numbered the other way round
    assert MeshQuality(mirrored).minimum() == pytest.approx(1.0, abs=1e-14)


def test_a_run_whose_cells_fold_says_so(tmp_path):
    """The rigid rough footing in large deformation on its scene's mesh: the cells at the
    footing's edge fold over between 0.0131 and 0.015 in of settlement (the last step
    here), while Newton goes on converging to 0.036 in."""
    from conftest import last_json, soilbin_cli
    done = soilbin_cli("run", "strip-footing-von-mises", "--json", "--out", tmp_path,
                       "--set", "analysis.large_deformation=true", "--set", "output.fields=[]",
                       "--set", "loading.magnitude=0.015", "--set", "loading.steps=6")
    assert done.returncode == 0, done.stderr
    summary = last_json(done.stdout)
    assert summary["n_steps"] == 8 and summary["folded_at_step"] == 8
    assert summary["mesh_quality"] < 0.0
    assert "step 8: a cell of the mesh has folded over" in done.stderr
