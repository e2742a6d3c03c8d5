"""The soil against itself (problem.soil_contact): two blocks of one mesh pressed together
through the contact of their facing faces carry the closed-form force, and the contact's
Jacobian is the derivative of its residual."""
import csv

import gmsh
import numpy as np
import pytest
from scipy.sparse import coo_matrix

from soilbin.errors import InputError
from soilbin.records.scene import load_scene
from conftest import last_json, soilbin_cli

E, LENGTH, GAP, STANDOFF, K_N = 1000.0, 1.0, 0.05, 0.01, 2.0e4

SCENE = f"""
title = "two blocks pressed together through their faces' contact"
units = "N, m (stresses in Pa)"

[mesh]
builder = "gmsh"
file = "blocks.msh"

[regions]
soil = "soil"

[materials.soil]
model = "elastic"
E = {E}
nu = 0.0

[[supports]]
boundary = "a_end"
fix = ["x"]

[[supports]]
boundary = "ymin"
fix = ["y"]

[[supports]]
boundary = "zmin"
fix = ["z"]

[loading]
control = "displacement"
boundary = "b_end"
direction = "-x"
magnitude = 0.1
steps = 10

[analysis]
element = "hex8"

[soil_contact]
faces = ["a_face", "b_face"]
k_n = {K_N}
standoff = {STANDOFF}
"""


def two_blocks(path, n=3):
    """Blocks [0, L] and [L + GAP, 2 L + GAP] (x) by [0, 1]^2 of n^3 hexahedra each, one mesh:
    volume "soil"; surfaces a_end (x = 0), a_face, b_face (the facing ones), b_end, ymin, zmin
    and "free" (the rest)."""
    gmsh.initialize(readConfigFiles=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        occ = gmsh.model.occ
        boxes = [occ.addBox(x, 0.0, 0.0, LENGTH, 1.0, 1.0) for x in (0.0, LENGTH + GAP)]
        occ.synchronize()
        for _, curve in gmsh.model.getEntities(1):
            gmsh.model.mesh.setTransfiniteCurve(curve, n + 1)
        for _, surface in gmsh.model.getEntities(2):
            gmsh.model.mesh.setTransfiniteSurface(surface)
            gmsh.model.mesh.setRecombine(2, surface)
        for box in boxes:
            gmsh.model.mesh.setTransfiniteVolume(box)
        gmsh.model.addPhysicalGroup(3, boxes, 1)
        gmsh.model.setPhysicalName(3, 1, "soil")
        eps, far = 1e-6, 10.0
        named = {"a_end": 0.0, "a_face": LENGTH, "b_face": LENGTH + GAP,
                 "b_end": 2 * LENGTH + GAP}
        groups = {name: [t for _, t in gmsh.model.getEntitiesInBoundingBox(
            x - eps, -far, -far, x + eps, far, far, 2)] for name, x in named.items()}
        groups["ymin"] = [t for _, t in gmsh.model.getEntitiesInBoundingBox(
            -far, -eps, -far, far, eps, far, 2)]
        groups["zmin"] = [t for _, t in gmsh.model.getEntitiesInBoundingBox(
            -far, -far, -eps, far, far, eps, 2)]
        used = {t for faces in groups.values() for t in faces}
        groups["free"] = [t for _, t in gmsh.model.getEntities(2) if t not in used]
        for tag, (name, faces) in enumerate(groups.items(), start=2):
            gmsh.model.addPhysicalGroup(2, faces, tag)
            gmsh.model.setPhysicalName(2, tag, name)
        gmsh.model.mesh.generate(3)
        gmsh.write(str(path))
    finally:
        gmsh.finalize()


@pytest.fixture()
def blocks_scene(tmp_path):
    two_blocks(tmp_path / "blocks.msh")
    path = tmp_path / "blocks.toml"
    path.write_text(SCENE)
    return path


def closed_form_force(d):
    """Two bars of length L in series with the contact's two passes, 2 k_n per area, engaged
    from a gap of GAP - STANDOFF (unit cross-section)."""
    return max(d - (GAP - STANDOFF), 0.0) / (1.0 / (2.0 * K_N) + 2.0 * LENGTH / E)


def closed_form_curve(folder):
    """The run's curve.csv rows, each checked against :func:`closed_form_force`."""
    with open(folder / "curve.csv") as f:
        rows = [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    assert len(rows) == 10
    for row in rows:
        expected = closed_form_force(row["displacement"])
        assert row["force"] == pytest.approx(expected, rel=1e-9, abs=1e-9 * closed_form_force(0.1))
    return rows


def test_blocks_pressed_together_carry_the_closed_form_force(tmp_path, blocks_scene):
    from soilbin.app.run import run_scene
    summary = run_scene(load_scene(blocks_scene), tmp_path / "run")
    assert summary["status"] == "complete"
    rows = closed_form_curve(tmp_path / "run")
    assert [row["force"] > 1.0 for row in rows] == [False] * 4 + [True] * 6   # d > 0.04
    for row in rows:   # the pairs' forces, both passes, carry all the load
        assert row["soil_contact_force"] == pytest.approx(row["force"], rel=1e-9, abs=1e-9)


def test_a_run_stopped_without_soil_contact_resumes_with_it(tmp_path, blocks_scene):
    """[soil_contact] keeps no state: a run may take it up on --resume (one stopped where its
    soil folded onto itself goes on with it); the blocks, stopped after 2 steps without it,
    carry the closed-form force from then on."""
    from soilbin.app.run import run_scene
    from test_checkpoint import stop_after
    without = blocks_scene.with_name("without.toml")
    without.write_text(SCENE[:SCENE.index("[soil_contact]")])
    run_scene(load_scene(without), tmp_path / "stopped", progress=stop_after(2))
    summary = run_scene(load_scene(blocks_scene), tmp_path / "resumed",
                        resume=tmp_path / "stopped")
    assert summary["status"] == "complete" and summary["resumed_after_step"] == 2
    with open(tmp_path / "resumed" / "curve.csv") as f:
        rows = list(csv.DictReader(f))
    assert float(rows[-1]["force"]) == pytest.approx(closed_form_force(0.1), rel=1e-9)
    assert [row["soil_contact_force"] == "" for row in rows] == [True] * 2 + [False] * 8


@pytest.mark.slow
def test_blocks_pressed_together_under_two_ranks(tmp_path, blocks_scene):
    """The blocks' faces on two ranks: a pair's point and triangle on different ranks (the
    residual and Jacobian entries of another rank's rows), the same force."""
    done = soilbin_cli("run", blocks_scene, "--json", "--out", tmp_path / "n2", mpi_ranks=2)
    assert done.returncode == 0, done.stderr
    assert last_json(done.stdout)["n_ranks"] == 2
    closed_form_curve(tmp_path / "n2")


def test_the_contact_jacobian_is_the_derivative_of_its_residual(blocks_scene):
    """Finite differences of the contact's residual along a random direction, at a state
    where half the nodes press (the residual is piecewise linear: exact away from g = 0)."""
    from mpi4py import MPI
    from soilbin.meshes import scene_mesh
    from soilbin.problem import SoilProblem
    scene = load_scene(blocks_scene)
    problem = SoilProblem(scene, scene_mesh(scene, MPI.COMM_WORLD))
    contact, w = problem.soil_contact, problem.w
    # B's face tilted through A's: pressing where x is large, open elsewhere
    x = problem.mesh.geometry.x
    nodal = contact._dofs
    on_b = np.flatnonzero(np.isclose(x[:, 0], LENGTH + GAP) | (x[:, 0] > LENGTH + GAP))
    w.x.array[nodal[on_b, 0]] = -GAP * (0.5 + x[on_b, 1])
    n = len(w.x.array)

    def residual():
        contact.update()
        b = w.vector.duplicate()
        b.set(0.0)
        contact.add_residual(b)
        return b.getArray().copy()

    base = residual()
    assert 0 < contact.touching() < len(contact._force)
    rows, columns = contact.coupling_entries()
    jacobian = coo_matrix((contact.coupling_values(), (rows, columns)), shape=(n, n)).tocsr()
    direction = np.random.default_rng(0).standard_normal(n) * 1e-7
    w.x.array[:] += direction
    assert residual() - base == pytest.approx(jacobian @ direction, rel=1e-6, abs=1e-12)


def test_a_crease_pairs_with_a_face_that_one_of_its_sides_faces(blocks_scene):
    """B turned 30 degrees about y and laid 0.15 over the crease of A's front (a_face, +x)
    and top ("free", +z), its bottom (zmin, normal (sin 30, 0, -cos 30)) facing A's top
    (150 degrees apart) but not A's front (60): every point of the crease pairs with it (the
    mean of the crease's two normals is 105 degrees from it, short of FACING's 120), and no
    point of A's front below the crease does."""
    from mpi4py import MPI
    from soilbin.meshes import scene_mesh
    from soilbin.problem import SoilProblem
    blocks_scene.write_text(SCENE.replace('"a_face", "b_face"', '"a_face", "free", "zmin"'))
    scene = load_scene(blocks_scene)
    problem = SoilProblem(scene, scene_mesh(scene, MPI.COMM_WORLD))
    contact, w = problem.soil_contact, problem.w
    x = problem.mesh.geometry.x
    on_b = np.flatnonzero(x[:, 0] > LENGTH + GAP / 2)
    angle, lift = np.radians(30.0), 0.15
    turn = np.array([[np.cos(angle), 0.0, -np.sin(angle)], [0.0, 1.0, 0.0],
                     [np.sin(angle), 0.0, np.cos(angle)]])
    normal = turn @ [0.0, 0.0, -1.0]
    # B's bottom centre onto the plane 0.15 above the crease (L, 0.5, L), 0.3 of B along +x
    centre = np.array([LENGTH, 0.5, LENGTH]) - lift * normal + 0.3 * (turn @ [1.0, 0.0, 0.0])
    moved = centre + (x[on_b] - [1.5 * LENGTH + GAP, 0.5, 0.0]) @ turn.T
    for axis in range(3):
        w.x.array[contact._dofs[on_b, axis]] = moved[:, axis] - x[on_b, axis]
    contact.pair()
    at = contact._x_mesh
    crease = np.isclose(at[:, 0], LENGTH) & np.isclose(at[:, 2], LENGTH)
    front = np.isclose(at[:, 0], LENGTH) & (at[:, 2] < LENGTH - 1e-9)
    paired = {tuple(pair) for pair in contact._pair_nodes[:, :2].tolist()}
    crease_points = [tuple(p) for p in contact._points.tolist() if crease[p].all()]
    assert len(crease_points) == 7   # 4 nodes, 3 edge middles
    assert all(p in paired for p in crease_points)
    assert not any(front[list(p)].any() for p in paired)
    assert np.allclose(contact._normal[[tuple(p) in crease_points
                                        for p in contact._pair_nodes[:, :2].tolist()]], normal)


def test_faces_too_far_apart_to_pair_leave_the_run_as_without(tmp_path, blocks_scene):
    """The blocks' far ends named: no pair on any step, and the blocks pass through each
    other with no force, as without [soil_contact]."""
    from soilbin.app.run import run_scene
    blocks_scene.write_text(SCENE.replace('"a_face", "b_face"', '"a_end", "b_end"'))
    summary = run_scene(load_scene(blocks_scene), tmp_path / "run")
    assert summary["status"] == "complete"
    with open(tmp_path / "run" / "curve.csv") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 10
    assert all(float(row["soil_contact_force"]) == 0.0 for row in rows)
    assert all(abs(float(row["force"])) < 1e-9 for row in rows)


def test_soil_contact_faces_must_be_boundaries_of_the_mesh(blocks_scene):
    blocks_scene.write_text(SCENE.replace('"a_face", "b_face"', '"a_face", "b_side"'))
    with pytest.raises(InputError, match=r"soil_contact.faces\[1\] = 'b_side': .* no such "
                                         "boundary"):
        load_scene(blocks_scene)
