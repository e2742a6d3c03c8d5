"""User meshes: builder = "gmsh" reads a .msh file; its named physical groups are the
scene's regions and boundaries, checked when the scene is read."""
import subprocess
import sys

import gmsh
import pytest

from soilbin.closed_form.verification import unconfined_strength
from soilbin.errors import InputError
from soilbin.records.scene import load_scene
from conftest import ROOT, SCENES

USER_SCENE = SCENES / "block-gmsh-file.toml"


@pytest.fixture(scope="module")
def user_mesh(tmp_path_factory):
    """The example mesh, written by scripts/make_user_mesh.py."""
    path = tmp_path_factory.mktemp("mesh") / "block.msh"
    subprocess.run([sys.executable, str(ROOT / "scripts" / "make_user_mesh.py"), str(path)],
                   check=True)
    return path


def scene_file(tmp_path, mesh, *replace):
    text = USER_SCENE.read_text().replace('file = "meshes/block.msh"', f'file = "{mesh}"')
    for old, new in replace:
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "user.toml"
    path.write_text(text)
    return path


def test_the_shipped_example_is_what_the_script_writes(user_mesh):
    assert (SCENES / "meshes" / "block.msh").read_bytes() == user_mesh.read_bytes()


def test_a_user_mesh_block_collapses_at_the_mohr_coulomb_stress(tmp_path, user_mesh):
    from soilbin.app.run import run_scene
    user_mesh_copy = tmp_path / user_mesh.name
    user_mesh_copy.write_bytes(user_mesh.read_bytes())
    scene = load_scene(scene_file(tmp_path, user_mesh.name))   # relative to the scene's folder
    assert scene.mesh.file == str(user_mesh_copy)
    summary = run_scene(scene, tmp_path / "run")
    assert summary["n_cells"] == 8
    assert summary["collapse_stress"] == pytest.approx(unconfined_strength(500.0, 30.0), rel=1e-6)
    assert f'file = "{user_mesh_copy}"' in (tmp_path / "run" / "scene.toml").read_text()


def test_a_group_the_file_lacks_is_named_with_the_file_and_its_groups(tmp_path, user_mesh):
    path = scene_file(tmp_path, user_mesh, ('boundary = "ymin"', 'boundary = "ymax"'))
    with pytest.raises(InputError) as err:
        load_scene(path)
    assert str(err.value) == (
        f"{path}: supports[2].boundary = 'ymax': mesh file {user_mesh} has no such boundary; "
        "its boundaries: base, top, xmin, ymin")
    path = scene_file(tmp_path, user_mesh, ('soil = "soil"', 'clay = "soil"'))
    with pytest.raises(InputError, match=f"regions.clay = 'clay': mesh file {user_mesh} has no "
                                         "such region; its regions: soil"):
        load_scene(path)


def test_an_unstructured_tetrahedral_block_collapses_at_the_mohr_coulomb_stress(tmp_path):
    """A user's tetrahedra (gmsh's Delaunay, no structure) serve the simplex elements: the
    block's stress is uniform, so tet10-bbar reaches the closed form as the hexahedra do."""
    from soilbin.app.run import run_scene
    subprocess.run([sys.executable, str(ROOT / "scripts" / "make_user_mesh.py"),
                    str(tmp_path / "tetrahedra.msh"), "--tetrahedra"], check=True)
    scene = load_scene(scene_file(tmp_path, tmp_path / "tetrahedra.msh",
                                  ("[regions]", '[analysis]\nelement = "tet10-bbar"\n\n[regions]'),
                                  ("steps = 20", "steps = 8")))
    summary = run_scene(scene, tmp_path / "run")
    assert summary["n_cells"] > 8
    assert summary["collapse_stress"] == pytest.approx(unconfined_strength(500.0, 30.0), rel=1e-6)


def test_files_that_cannot_serve_are_refused(tmp_path):
    from soilbin.app.run import run_scene
    missing = scene_file(tmp_path, tmp_path / "none.msh")
    with pytest.raises(InputError, match="none.msh': cannot read it"):
        load_scene(missing)
    gmsh.initialize(readConfigFiles=False)
    gmsh.option.setNumber("General.Terminal", 0)
    box = gmsh.model.occ.addBox(0, 0, 0, 1, 1, 1)
    gmsh.model.occ.synchronize()
    gmsh.model.mesh.generate(3)
    gmsh.write(str(tmp_path / "unnamed.msh"))
    for tag, (dim, name) in enumerate([(3, "soil"), (2, "base"), (2, "top"), (2, "xmin"),
                                       (2, "ymin")], start=1):
        gmsh.model.addPhysicalGroup(dim, [box] if dim == 3 else [1], tag)
        gmsh.model.setPhysicalName(dim, tag, name)
    gmsh.write(str(tmp_path / "tetrahedra.msh"))
    gmsh.finalize()
    with pytest.raises(InputError, match="the file names no physical groups"):
        load_scene(scene_file(tmp_path, tmp_path / "unnamed.msh"))
    scene = load_scene(scene_file(tmp_path, tmp_path / "tetrahedra.msh"))
    with pytest.raises(InputError, match=r"tetrahedra.msh' has 3D elements \[Tetrahedron 4\]; "
                                         r"analysis.element \(hex8, hex27\) needs 8-node "
                                         "hexahedra only"):
        run_scene(scene, tmp_path / "run")
