"""A scene on top of another (``base``): tables merged key by key, other values replaced,
paths of the base's mesh kept relative to the base, errors naming the file and the key."""
from pathlib import Path

import pytest

from soilbin.errors import InputError
from soilbin.records.scene import load_scene
from conftest import SCENES


def write(folder, name, text):
    path = folder / name
    path.write_text(text)
    return path


def test_the_default_scene_is_the_tine_scene_embedded_under_force_control():
    base, top = load_scene(SCENES / "tine-2in-90deg.toml"), load_scene(SCENES / "tine-2in-108lb.toml")
    assert top.mesh.configuration.value == "embedded" and base.mesh.configuration.value == "side_wall"
    assert top.loading.control.value == "force" and top.loading.magnitude == 108.0
    # everything the top scene does not name is the base's
    assert top.materials == base.materials and top.tool == base.tool and top.solver == base.solver
    assert top.mesh.tool_width == base.mesh.tool_width and top.supports == base.supports
    assert top.title != base.title


def test_tables_merge_and_arrays_are_replaced_whole(tmp_path):
    path = write(tmp_path, "top.toml", f'base = "{SCENES / "tine-2in-90deg.toml"}"\n'
                 "[materials.modified_cap]\nE = 6000.0\n"
                 '[[supports]]\nboundary = "base"\nfix = ["x", "y", "z"]\n'
                 '[[supports]]\nboundary = "symmetry"\nfix = ["y"]\n'
                 '[[supports]]\nboundary = "side"\nfix = ["y"]\n'
                 '[[supports]]\nboundary = "front_end"\nfix = ["x"]\n')
    scene = load_scene(path)
    cap = scene.materials["modified_cap"]
    assert cap.E == 6000.0 and cap.nu == 0.35          # one key set, the rest the base's
    assert [s.boundary for s in scene.supports] == ["base", "symmetry", "side", "front_end"]


def test_a_base_by_name_and_overrides_on_top(tmp_path):
    path = write(tmp_path, "wide.toml", 'base = "tine-2in-108lb"\n[mesh]\ntool_width = 3.0\n')
    scene = load_scene(path, ["mesh.rake_angle=60"])
    assert (scene.mesh.tool_width, scene.mesh.rake_angle) == (3.0, 60.0)
    assert scene.mesh.configuration.value == "embedded"      # from the base's base chain
    assert scene.loading.magnitude == 108.0


def test_the_base_mesh_file_stays_relative_to_the_base(tmp_path):
    path = write(tmp_path, "soft.toml", f'base = "{SCENES / "block-gmsh-file.toml"}"\n'
                 "[materials.soil]\nE = 250000.0\n")
    scene = load_scene(path)
    assert Path(scene.mesh.file) == (SCENES / "meshes" / "block.msh").resolve()


@pytest.mark.parametrize("base, words", [
    ('"nowhere"', "no such scene"),
    ("3", "the name of a scene"),
    ('"loop.toml"', "name each other as base"),
])
def test_a_bad_base_is_named(tmp_path, base, words):
    path = write(tmp_path, "loop.toml", f"base = {base}\n")
    with pytest.raises(InputError, match=words) as err:
        load_scene(path)
    assert str(err.value).startswith(str(path)) and "base" in str(err.value)
