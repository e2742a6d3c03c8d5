"""soilbin study: a case's material read whole from a file (materials.NAME.from), such as the
material.toml that soilbin calibrate writes."""
import pytest

from soilbin.app.cli import main
from soilbin.app.study import load_study
from soilbin.models import MODELS
from soilbin.params import from_table
from conftest import ROOT

#: As soilbin calibrate writes it: one [materials.NAME] table, no psi (associated flow).
FITTED = {"E": 5000.0, "nu": 0.3, "c": 1.0, "phi": 30.0, "matching": "plane_strain"}
MATERIAL_TOML = """\
# fit.toml: fitted by soilbin calibrate
[materials]
[materials.fit]
model = "drucker_prager"
E = 5000.0
nu = 0.3
c = 1.0
phi = 30.0
matching = "plane_strain"
"""
#: The column with a non-associated Drucker-Prager soil: its psi must not survive a `from`.
SCENE = """\
base = "column-elastic"
[materials.soil]
model = "drucker_prager"
c = 2.0
phi = 25.0
matching = "compression_cone"
psi = 10.0
"""
STUDY = """\
title = "column with the fitted soil"
scene = "dp.toml"
[set]
mesh.nz = 2
materials.soil.E = 7000
[[case]]
label = "fitted"
materials.soil = { from = "material.toml" }
[[case]]
label = "scene's soil"
"""


@pytest.fixture
def folder(tmp_path):
    (tmp_path / "material.toml").write_text(MATERIAL_TOML)
    (tmp_path / "dp.toml").write_text(SCENE)
    return tmp_path


def study_file(folder, text):
    path = folder / "study.toml"
    path.write_text(text)
    return path


def test_a_case_runs_the_scene_with_exactly_the_files_material(folder):
    fitted, scenes = load_study(study_file(folder, STUDY)).cases
    assert fitted.scene.materials["soil"] == from_table(MODELS["drucker_prager"], FITTED, "fitted")
    assert fitted.scene.materials["soil"].psi == 30.0   # the file's phi (associated), not 10
    assert fitted.overrides == (
        'materials.soil={model = "drucker_prager", E = 5000.0, nu = 0.3, c = 1.0, phi = 30.0, '
        'matching = "plane_strain"}', "mesh.nz=2")                 # [set]'s E left out
    assert (fitted.name, fitted.label) == ("from=material.toml", "fitted")
    assert fitted.values == {"mesh.nz": 2, "materials.soil.from": "material.toml"}
    assert (scenes.scene.materials["soil"].E, scenes.scene.materials["soil"].psi) == (7000.0, 10.0)


def test_keys_beside_from_change_the_files_values(folder):
    study = load_study(study_file(folder, """\
title = "the fitted soil, stiffer and softer"
scene = "dp.toml"
[set]
materials.soil.from = "material.toml"
[product]
materials.soil.E = [2500.0, 10000.0]
[[case]]
materials.soil.phi = 35.0
[[case]]
materials.soil = { c = 2.5, from = "material.toml" }
"""))
    changed = [{"phi": 35.0, "E": 2500.0}, {"phi": 35.0, "E": 10000.0},
               {"c": 2.5, "E": 2500.0}, {"c": 2.5, "E": 10000.0}]
    for case, values in zip(study.cases, changed, strict=True):
        expected = from_table(MODELS["drucker_prager"], {**FITTED, **values}, "expected")
        assert case.scene.materials["soil"] == expected
    assert [case.name for case in study.cases] == [
        "phi=35.0,E=2500.0", "phi=35.0,E=10000.0",
        "E=2500.0,c=2.5,from=material.toml", "E=10000.0,c=2.5,from=material.toml"]


def test_a_product_of_files_sweeps_materials(folder):
    (folder / "stiff.toml").write_text(MATERIAL_TOML.replace("E = 5000.0", "E = 20000.0"))
    study = load_study(study_file(folder, """\
title = "the fitted soil and a stiffer one"
scene = "dp.toml"
[product]
materials.soil.from = ["material.toml", "stiff.toml"]
"""))
    assert [(case.name, case.scene.materials["soil"].E) for case in study.cases] == [
        ("from=material.toml", 5000.0), ("from=stiff.toml", 20000.0)]


def test_a_path_relative_to_the_study_file_and_a_named_material_of_a_scene(folder):
    (folder / "studies").mkdir()
    study = load_study(study_file(folder / "studies", f"""\
title = "column of the fitted soil or of the tine's modified cap"
scene = "../dp.toml"
[[case]]
materials.soil.from = "../material.toml"
[[case]]
materials.soil.from = "{ROOT / 'scenes' / 'tine-2in-108lb.toml'}:modified_cap"
"""))
    fitted, tine = study.cases
    assert fitted.scene.materials["soil"] == from_table(MODELS["drucker_prager"], FITTED, "fitted")
    cap = {"E": 4000.0, "nu": 0.35, "A": 5.6, "B": 0.11, "C": 5.6, "beta": 0.062, "R": 2.0,
           "W": 0.18, "D": 0.05}
    assert tine.scene.materials["soil"] == from_table(MODELS["modified_cap"], cap, "cap")
    assert fitted.name == "from=.._material.toml-" + fitted.name[-8:]


SEVERAL = MATERIAL_TOML + '[materials.other]\nmodel = "elastic"\nE = 1.0\nnu = 0.2\n'
ACCEPTED = '"FILE.toml" (a file holding one [materials.NAME] table'


@pytest.mark.parametrize("spec, content, expected", [
    ('"missing.toml"', None, "no such file {folder}/missing.toml; expected " + ACCEPTED),
    ('"m.toml"', 'title = "no materials"\n', "{folder}/m.toml has no [materials.NAME] table; "
                                            "expected " + ACCEPTED),
    ('"m.toml"', SEVERAL, '{folder}/m.toml holds 2 materials (fit, other): name one as '
                         '"m.toml:NAME"'),
    ('"m.toml:clay"', SEVERAL, "{folder}/m.toml has no material 'clay'; its materials: fit, "
                               "other"),
    ('"m.toml"', MATERIAL_TOML.replace('"drucker_prager"', '"mohr_coulomb"'),
     "{folder}/m.toml: materials.fit.model = 'mohr_coulomb' is not a model of soilbin; known: "
     "elastic, von_mises, drucker_prager"),
    ('"m.toml"', MATERIAL_TOML.replace("phi = 30.0", "phi = 95.0"),
     "{folder}/m.toml: materials.fit.phi = 95.0 is outside the accepted range"),
    ('"m.toml:"', SEVERAL, "expected " + ACCEPTED),
    ("3", None, "expected " + ACCEPTED),
])
def test_a_bad_from_is_one_line_naming_study_case_and_key(capsys, folder, spec, content,
                                                          expected):
    if content is not None:
        (folder / "m.toml").write_text(content)
    path = study_file(folder, STUDY.replace('{ from = "material.toml" }', f"{{ from = {spec} }}"))
    status = main(["study", str(path), "--dry-run"])
    err = capsys.readouterr().err
    assert status == 2
    assert f"{path}: case fitted: materials.soil.from = {spec.replace(chr(34), chr(39))}: " in err
    assert expected.format(folder=folder) in err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_a_from_must_name_a_material_of_the_scenes_regions(capsys, folder):
    path = study_file(folder, STUDY.replace("materials.soil =", "materials.clay ="))
    assert main(["study", str(path), "--dry-run"]) == 2
    err = capsys.readouterr().err
    assert (f"{path}: case fitted: materials.clay.from: no region of the scene has the material "
            "'clay'; its regions' materials: soil") in err
