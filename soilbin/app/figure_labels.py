"""The words and units of what the figures draw: every axis is a quantity in words with its
unit from the scene's ``units`` (records.units): "draft [lb]", "tool travel [in]",
"pressure [psi]"; a study's swept values in words ("rake angle 45°")."""
from ..records.scene import TOOL, Control, Direction, Headline


#: curve.csv columns: (words, dimension). The displacement's and the force's words are the
#: loading's (:func:`loading_words`).
COLUMNS = {
    "step": ("step", None),
    "load_factor": ("load factor", None),
    "displacement": (None, "length"),
    "force": (None, "force"),
    "pressure": ("pressure", "stress"),
    "lift": ("lift", "force"),
    "front_volumetric_strain": ("volumetric strain in front of the tool", None),
    "heave": ("heave (the rise of the soil's highest point)", "length"),
    "mesh_quality": ("least scaled Jacobian of the mesh", None),
    "soil_contact_force": ("force of the soil pressing on itself", "force"),
    "newton_iterations": ("Newton iterations", None),
    "cuts": ("step cuts", None),
    "wall_s": ("wall time", "time"),
}

#: curve.csv columns that are zero in the initial state, where a curve of them starts.
FROM_REST = ("load_factor", "displacement", "force", "pressure")

#: summary.json keys other than the headline results: (words, dimension).
SUMMARY = {
    "n_cells": ("cells", None), "n_dofs": ("degrees of freedom", None),
    "n_ranks": ("MPI ranks", None), "n_steps": ("converged steps", None),
    "load_factor": ("load factor reached", None), "newton_iterations": ("Newton iterations", None),
    "failed_newton_iterations": ("Newton iterations of cut attempts", None),
    "cuts": ("step cuts", None), "setup_s": ("set-up time", "time"),
    "wall_s": ("wall time", "time"), "cpu_s": ("CPU time", "time"),
}

#: A headline result: (words before the curve column's, the column it is read off).
HEADLINES = {
    Headline.FINAL_DISPLACEMENT: ("", "displacement"), Headline.FINAL_FORCE: ("", "force"),
    Headline.PEAK_FORCE: ("peak ", "force"), Headline.FINAL_PRESSURE: ("", "pressure"),
    Headline.PEAK_PRESSURE: ("peak ", "pressure"),
    Headline.COLLAPSE_PRESSURE: ("collapse ", "pressure"), Headline.FINAL_LIFT: ("", "lift"),
    Headline.STEADY_FORCE: ("steady ", "force"),   # steady_spread: a ratio; steady_slope:
                                                   # force per length, its key's words
}

#: Scene keys by their last part (a study's swept keys): (words, dimension).
KEYS = {
    "tool_width": ("tool width", "length"), "tool_depth": ("tool depth", "length"),
    "tool_thickness": ("tool thickness", "length"), "rake_angle": ("rake angle", "angle"),
    "element_size": ("element size", "length"), "refine": ("mesh refinement", None),
    "configuration": ("configuration", None), "bonded": ("bonded", None),
    "large_deformation": ("large deformation", None), "soil": ("soil model", None),
    "E": ("E", "stress"), "nu": ("ν", None), "c": ("c", "stress"), "phi": ("φ", "angle"),
    "psi": ("ψ", "angle"), "delta": ("δ", "angle"), "c_a": ("c_a", "stress"),
    "K0": ("K0", None), "dilatancy": ("dilatancy", None),
}


def unit(dimension, units):
    """The unit of a dimension (length, force, stress, angle, time or None) in ``units``."""
    return {"length": units.length, "force": units.curve_force, "stress": units.stress,
            "angle": "°", "time": "s", None: ""}[dimension]


def labelled(words, dimension, units):
    """'words [unit]', or the words alone for a number without unit."""
    shown = unit(dimension, units)
    return f"{words} [{shown}]" if shown else words


def loading_words(scene):
    """(displacement words, force words) of the loading: a tool moved across the ground has a
    travel and a draft, a boundary pressed down a settlement."""
    loading = scene.loading
    if loading.boundary == TOOL:
        across = loading.direction.axis != 2
        return ("tool travel", "draft") if across else ("tool displacement", "force on the tool")
    moved = "settlement" if loading.direction is Direction.MZ else f"{loading.boundary} displacement"
    return moved, f"force on the {loading.boundary}"


def column_words(column, scene):
    """(words, dimension) of a curve.csv column in ``scene``."""
    words, dimension = COLUMNS[column]
    if column in ("displacement", "force"):
        words = loading_words(scene)[column == "force"]
    return words, dimension


def column_label(column, scene):
    """A curve.csv column as an axis reads: 'draft [lb]', 'settlement [in]'."""
    return labelled(*column_words(column, scene), scene.unit_system)


def summary_label(key, scene):
    """A summary.json key as an axis reads: a headline result as the curve's quantity it is
    read off ('draft [lb]', 'collapse pressure [psi]'; divided by a scale, its key's words)."""
    if key in scene.headline:
        result = scene.headline[key]
        if result.divide_by != 1.0 or result.of not in HEADLINES:   # a ratio
            return key.replace("_", " ")
        before, column = HEADLINES[result.of]
        words, dimension = column_words(column, scene)
        return labelled(before + words, dimension, scene.unit_system)
    return labelled(*SUMMARY.get(key, (key.replace("_", " "), None)), scene.unit_system)


def key_words(key, scene):
    """(words, unit) of a dotted scene key: ('rake', '°'); loading.magnitude is the loading's
    displacement, draft or pressure; a key not known here its last part's words."""
    if key == "loading.magnitude":
        column = {Control.DISPLACEMENT: "displacement", Control.INDIRECT: "displacement",
                  Control.FORCE: "force" if scene.loading.boundary == TOOL else "pressure"}
        words, dimension = column_words(column[scene.loading.control], scene)
    else:
        last = key.rsplit(".", 1)[-1]
        words, dimension = KEYS.get(last, (last.replace("_", " "), None))
    return words, unit(dimension, scene.unit_system)


def key_label(key, scene):
    """A swept key as an axis reads: 'rake [°]', 'tool width [in]'."""
    words, shown = key_words(key, scene)
    return f"{words} [{shown}]" if shown else words


def key_value(key, value, scene):
    """A swept key's value in words: 'rake 45°', 'tool width 2 in', 'bonded = true'."""
    from .study import label
    words, shown = key_words(key, scene)
    if not shown:
        return f"{words} = {label(value)}"
    return f"{words} {label(value)}{'' if shown == '°' else ' '}{shown}"
