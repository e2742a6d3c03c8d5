"""The key reference: the line ``<!-- scene-keys -->`` of keys.md becomes a section per
table a scene may hold, each key with its default, accepted range and meaning, read from
the same records as ``soilbin keys`` (:func:`soilbin.app.keys.reference`); the line
``<!-- study-keys -->`` becomes those of a study file's tables, one heading level down."""
import math
from itertools import groupby

from sphinx.errors import ExtensionError

from soilbin.app.keys import REQUIRED, reference, study_reference
from soilbin.records.toml_out import _scalar as toml_value

PAGE = "keys"
#: marker line -> (the tables it becomes, the level of their headings)
MARKERS = {"<!-- scene-keys -->": (reference, 2), "<!-- study-keys -->": (study_reference, 3)}
#: Escaped in table text so that Markdown and MyST's math read it literally.
SPECIAL = "\\`*_[]<>$|"
#: Table titles shown in a heading by what they name in a scene.
TITLES = {"top level": "Top-level keys", "mesh": "mesh: one builder's keys", "materials": "materials.NAME: one model's keys",
          "supports": "[[supports]]", "tractions": "[[tractions]]", "headline": "headline.NAME", "run": "[run]", "table": "[table]",
          "figures": "[[figures]]"}


def _text(text):
    return "".join("\\" + c if c in SPECIAL else c for c in str(text))


def _default(value):
    """A default as TOML; 'required' for a key that must be given, and the meaning's word for
    a default that the model or builder works out (None)."""
    if value == REQUIRED:
        return REQUIRED
    if value is None:
        return "see meaning"
    if isinstance(value, float) and math.isnan(value):
        return "`nan`"
    return f"`{toml_value(value)}`"


def _table(rows):
    lines = ["| key | default | accepted | meaning |", "| --- | --- | --- | --- |"]
    lines += [f"| `{key}` | {_default(default)} | {_text(accepted)} | {_text(doc)} |"
              for key, default, accepted, doc in rows]
    return lines


def markdown(tables, level):
    """The sections of ``tables`` (as :func:`soilbin.app.keys.reference`), headed at
    ``level``, as MyST Markdown."""
    lines = []
    for table, entries in groupby(tables, key=lambda entry: entry[0]):
        lines += ["", f"{'#' * level} {_text(TITLES.get(table, table))}", ""]
        for _, kind, summary, rows in entries:
            if kind:
                lines += [f"{'#' * (level + 1)} {_text(kind)}", ""]
            if summary:
                lines += [_text(summary), ""]
            lines += _table(rows) + [""]
    return "\n".join(lines)


def write_reference(app):
    """The sections of every marker, made before any page is read: autodoc, reading the
    API page, adds annotations from the source to classes, as text that get_type_hints
    cannot evaluate."""
    app.env.scene_keys = {marker: markdown(tables(), level)
                          for marker, (tables, level) in MARKERS.items()}


def insert_reference(app, docname, source):
    if docname != PAGE:
        return
    for marker, text in app.env.scene_keys.items():
        if marker not in source[0]:
            raise ExtensionError(f"{PAGE}.md: no {marker} line for the key reference")
        source[0] = source[0].replace(marker, text)


def read_again(app, env, added, changed, removed):
    """The page is made from the code: read it at every build."""
    return [PAGE]


def setup(app):
    app.connect("builder-inited", write_reference)
    app.connect("source-read", insert_reference)
    app.connect("env-get-outdated", read_again)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
