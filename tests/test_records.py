"""The records layer: scenes, parameters, the builder catalogue and the model registry,
read without FEniCSx; builder declarations; the bin's extents; K0 after Jaky."""
import math
import re
import subprocess
import sys

import pytest

from soilbin.errors import InputError
from soilbin.meshes import BUILDERS, SoilBinParams
from soilbin.meshes.cad_tool import TOOL_FACES as CAD_FACES
from soilbin.meshes.soil_bin import TOOL_FACES
from soilbin.params import from_table
from soilbin.records.scene import load_scene
from conftest import ROOT, SCENES

TINE = SCENES / "tine-2in-90deg.toml"
HEAVY = ("dolfinx", "gmsh", "petsc4py", "ufl", "basix", "mpi4py")


def test_the_records_layer_loads_no_fenicsx_gmsh_or_mpi():
    code = ("import sys\n"
            "import soilbin.records.scene, soilbin.params, soilbin.meshes, soilbin.models, soilbin.elements\n"
            "import soilbin.material_point.driver, soilbin.app.cli\n"
            "from soilbin.records.scene import load_scene\n"
            f"load_scene({str(TINE)!r}, ['geostatic.K0=jaky', 'regions.soil=drucker_prager'])"
            ".resolved()\n"
            "print(' '.join(sorted({m.split('.')[0] for m in sys.modules})))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                          check=True)
    loaded = set(done.stdout.split())
    assert "soilbin" in loaded
    assert not loaded & set(HEAVY)


def test_every_builder_declares_its_contact_groups_among_its_boundaries():
    assert {name: b.contact for name, b in BUILDERS.items()} == {
        "box": (), "strip_footing": (), "soil_bin": TOOL_FACES, "soil_bin_cad": CAD_FACES,
        "retaining_wall": (), "gmsh": ()}
    for name, builder in BUILDERS.items():
        assert builder.name == name and builder.summary
        assert builder.regions or name == "gmsh"   # a file's groups are the file's
        assert set(builder.contact) <= set(builder.boundaries)


def scene_without(tmp_path, line, text=None):
    """The tine scene with ``line`` removed (or replaced by ``text``), in tmp_path."""
    source = TINE.read_text()
    assert line in source
    path = tmp_path / "scene.toml"
    path.write_text(source.replace(line, text or ""))
    return path


def test_tool_faces_default_to_the_builders_contact_groups(tmp_path):
    listed = load_scene(TINE)
    default = load_scene(scene_without(tmp_path, 'faces = ["tool_front", "tool_back", "tool_side", "tool_bottom"]'))
    assert default.tool.faces == listed.tool.faces == TOOL_FACES
    assert default.resolved() == listed.resolved()


def test_a_tool_on_a_builder_without_contact_groups_must_name_its_faces(tmp_path):
    path = tmp_path / "box-tool.toml"
    path.write_text((SCENES / "block-drucker-prager.toml").read_text() + "\n[tool]\nbonded = true\n")
    with pytest.raises(InputError, match=r"tool\.faces: required: mesh builder 'box' declares no "
                                         r"contact groups; its boundaries: xmin"):
        load_scene(path)


def test_the_bin_reaches_9_tool_widths_ahead_and_behind():
    two_inch = SoilBinParams()
    assert (two_inch.ahead, two_inch.behind, two_inch.length) == (18.0, 18.0, 36.5)
    four_inch = load_scene(TINE, ["mesh.tool_width=4"]).mesh
    assert (four_inch.ahead, four_inch.behind) == (36.0, 36.0)
    assert "ahead = 36.0" in load_scene(TINE, ["mesh.tool_width=4"]).resolved()
    given = from_table(SoilBinParams, {"tool_width": 4.0, "ahead": 10.0}, "mesh")
    assert (given.ahead, given.behind) == (10.0, 36.0)


def test_the_2in_tine_mesh_is_unchanged():
    """Cells and extents of the default tine scene before the bin scaled with the tool."""
    mesh = load_scene(TINE).mesh
    assert mesh.cells == 3131
    assert (mesh.length, mesh.bin_width, mesh.bin_depth) == (36.5, 18.0, 12.0)


@pytest.mark.parametrize("overrides, phi", [([], 33.0), (["materials.drucker_prager.phi=25"], 25.0)])
def test_jaky_K0_follows_the_friction_angle_and_is_written_as_a_number(overrides, phi):
    scene = load_scene(TINE, ["geostatic.K0=jaky", "regions.soil=drucker_prager", *overrides])
    K0 = 1.0 - math.sin(math.radians(phi))
    assert scene.geostatic.K0 == K0
    assert f"K0 = {K0!r}" in scene.resolved()


@pytest.mark.parametrize("model", ["cam_clay", "modified_cam_clay"])
def test_jaky_K0_of_the_critical_state_friction_angle(model):
    scene = load_scene(SCENES / "container-footing.toml", ["geostatic.K0=jaky", f"regions.soil={model}"])
    assert scene.geostatic.K0 == pytest.approx(1.0 - math.sin(math.radians(scene.materials[model].phi)))


@pytest.mark.parametrize("overrides, message", [
    (["regions.soil=modified_cap"],
     "geostatic.K0 = 'jaky': materials.modified_cap (ModifiedCap) has no friction angle phi; "
     "give K0 as a number in [0, 10]"),
    (["regions.soil=dimaggio_sandler"],
     "geostatic.K0 = 'jaky': materials.dimaggio_sandler (DiMaggioSandler) has no friction angle"),
    (["geostatic.K0=rankine"], "geostatic.K0: expected a number or 'jaky', got 'rankine'"),
])
def test_jaky_K0_without_a_friction_angle_is_refused(overrides, message):
    with pytest.raises(InputError, match=re.escape(f"container-footing.toml: {message}")):
        load_scene(SCENES / "container-footing.toml", ["geostatic.K0=jaky", *overrides])


@pytest.mark.parametrize("scene, headline, driven", [
    ("retaining-wall-passive", "final_lift", "a loaded boundary"),
    ("retaining-wall-passive-rough", "final_pressure", "a tool"),
    ("retaining-wall-passive-rough", "collapse_pressure", "a tool")])
def test_a_headline_is_read_off_what_the_scene_drives(scene, headline, driven):
    """A loaded boundary has a pressure and no lift, a tool a lift and no pressure."""
    with pytest.raises(InputError, match=f"headline.x: {headline} is not read off {driven}"):
        load_scene(SCENES / f"{scene}.toml", [f"headline.x={headline}"])


def test_the_first_step_cannot_start_below_the_smallest_increment():
    with pytest.raises(InputError, match=re.escape(
            "loading.first_cuts: 4 is more than max_cuts (3), the smallest increment allowed")):
        load_scene(SCENES / "strip-footing-von-mises.toml",
                   ["loading.first_cuts=4", "loading.max_cuts=3"])
