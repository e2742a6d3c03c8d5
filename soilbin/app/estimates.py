"""The McKyes & Ali draft of the tool in the soil bin (summary.json and curve.png): the
scene's [tool.estimate] strength or the soil material's own, on the flat blade of the
built-in tool or of a tool file's width across the travel."""
import dataclasses

import numpy as np
from mpi4py import MPI

from ..closed_form import MODEL, NoWedge, narrow_tine_draft, passive_wedge_strength
from ..meshes.cad_tool import Configuration


@dataclasses.dataclass(frozen=True)
class Blade:
    """The flat blade McKyes & Ali is applied to: its whole width across the travel, the
    depth of its lowest point, its rake [degrees], the side crescents of soil failing beside
    it (one against the bin's glass wall, two with soil on both sides); ``shape`` names a
    tool file's blade."""
    width: float
    depth: float
    rake: float
    crescents: int
    shape: str = ""


def blade_of(scene, problem=None):
    """The :class:`Blade` of a tool in the soil bin under gravity, else None: the built-in
    blade's, or (collective, with the ``problem``) a tool file's taken as the flat blade of
    its width (its faces' extent in y, both halves when embedded)."""
    if scene.tool is None or scene.geostatic is None:
        return None
    mesh = scene.mesh
    if scene.mesh_builder == "soil_bin":
        return Blade(mesh.tool_width, mesh.tool_depth, mesh.rake_angle,
                     2 if mesh.tool_share < 1.0 else 1)
    if scene.mesh_builder != "soil_bin_cad" or problem is None:
        return None
    y = np.concatenate(list(problem.tool.face_points.values()))[:, 1]
    comm = problem.comm
    span = (comm.allreduce(y.max(initial=-np.inf), op=MPI.MAX)
            - comm.allreduce(y.min(initial=np.inf), op=MPI.MIN))
    width = span / mesh.tool_share
    side_wall = Configuration(mesh.configuration) is Configuration.SIDE_WALL
    return Blade(width, mesh.tool_depth, mesh.rake_angle, 1 if side_wall else 2,
                 shape=f", as a flat blade {width:.3g} {scene.unit_system.length} wide")


def draft_estimate(scene, blade=None):
    """The McKyes & Ali draft that applies to the whole tool (``blade``, default
    :func:`blade_of` the scene), or None: with the soil's c, phi of the scene's
    [tool.estimate] if it gives them, else the material's (:func:`material_draft_estimate`)."""
    blade = blade or blade_of(scene)
    if blade is None or scene.tool.estimate is None:
        return material_draft_estimate(scene, blade)
    chosen = scene.tool.estimate
    return _mckyes_ali(scene, blade, (chosen.phi, chosen.c, chosen.source))


def material_draft_estimate(scene, blade=None):
    """The McKyes & Ali draft with the soil material's own c, phi or, for a cap model, its
    failure surface's at the passive wedge's stress level (closed_form.equivalent_strength);
    None where the soil has neither."""
    blade = blade or blade_of(scene)
    if blade is None:
        return None
    soil = scene.materials[scene.regions["soil"]]
    if hasattr(soil, "failure"):
        strength = passive_wedge_strength(soil.failure, scene.geostatic.unit_weight, blade.depth)
        return _mckyes_ali(scene, blade, (strength.phi, strength.c,
                                          f"failure surface linearised at I1 = {strength.I1:.3g} "
                                          f"{scene.unit_system.stress}"))
    if hasattr(soil, "phi") and hasattr(soil, "c"):
        return _mckyes_ali(scene, blade, (soil.phi, soil.c, f"material {scene.regions['soil']}"))
    return None


def _mckyes_ali(scene, blade, strength):
    """McKyes & Ali on ``blade`` with ``strength`` (phi, c, where they come from): one side
    crescent against the bin's glass wall, two with soil on both sides. A bonded tool is fully
    rough: delta = phi, c_a = c."""
    phi, c, source = strength
    interface = scene.tool.interface
    delta, c_a = (phi, c) if scene.tool.bonded else (interface.delta, interface.c_a)
    try:
        estimate = narrow_tine_draft(width=blade.width, depth=blade.depth, rake=blade.rake,
                                     phi=phi, delta=delta, gamma=scene.geostatic.unit_weight,
                                     c=c, c_a=c_a, crescents=blade.crescents, strength=source)
    except NoWedge as err:
        raise NoWedge(f"no {MODEL} estimate: {err} (phi = {phi:.3g} from the {source}, "
                      f"delta = {delta:.3g})") from None
    return dataclasses.replace(estimate, model=estimate.model + blade.shape)


def draft_estimates(scene, blade=None):
    """The draft that applies, then the material's if the scene chose another strength (left
    out if its wedge cannot form); a NoWedge of the first is raised."""
    first = draft_estimate(scene, blade)
    if first is None or scene.tool.estimate is None:
        return [first] if first is not None else []
    try:
        other = material_draft_estimate(scene, blade)
    except NoWedge:
        other = None
    return [first] if other is None else [first, other]
