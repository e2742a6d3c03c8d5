"""The user guide's scene table, model list and builder list are those of the code, and its
default of `make run` is the Makefile's."""
import re

from soilbin.meshes import BUILDERS
from soilbin.models import MODELS
from conftest import ROOT, SCENES

GUIDE = (ROOT / "docs" / "user-guide.md").read_text()


def section_names(heading, row):
    """The backticked first-column names of the lines matching ``row`` after ``heading``,
    up to the next heading."""
    text = GUIDE.split(heading, 1)[1].split("\n#", 1)[0]
    return [m.group(1) for m in re.finditer(row, text, flags=re.MULTILINE)]


def test_the_scene_table_has_one_row_per_scene():
    names = section_names("| scene | problem | headline |", r"^\| `([\w-]+)` \|")
    assert sorted(names) == sorted(p.stem for p in SCENES.glob("*.toml"))


def test_the_default_of_make_run_is_the_makefiles():
    default = re.search(r"^SCENE\s*\?=\s*scenes/([\w-]+)\.toml", (ROOT / "Makefile").read_text(),
                        flags=re.MULTILINE).group(1)
    rows = [line for line in GUIDE.splitlines() if "default of `make run`" in line]
    assert len(rows) == 1 and rows[0].startswith(f"| `{default}` |")


def test_the_model_list_is_the_registry():
    assert section_names("### Models", r"^- `(\w+)`:") == list(MODELS)


def test_the_builder_list_is_the_catalogue():
    assert section_names("### Mesh builders", r"^- `(\w+)`:") == list(BUILDERS)
