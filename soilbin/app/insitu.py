"""Is the initial stress of a scene admissible? Checked before the first step.

The in-situ stress is affine in z and every yield surface bounds a convex
elastic domain, so if the stress at the top and at the bottom of a region is
inside its material's surface, it is inside everywhere in the region. A zero
strain increment from a stress outside the surface returns a different
stress (the return mapping projects it), or fails.
"""
import numpy as np
from mpi4py import MPI

from ..errors import InputError, ReturnMapError

#: Relative change of the stress under a zero increment taken as "outside".
TOLERANCE = 1e-8


def region_depths(tagged, region):
    """(z_min, z_max) of a region's cells over all ranks; collective."""
    mesh = tagged.mesh
    cells = tagged.cell_tags.find(tagged.regions[region])
    dofmap = mesh.geometry.dofmap.array.reshape(-1, mesh.geometry.dofmap.links(0).size)
    z = mesh.geometry.x[dofmap[cells].ravel(), mesh.geometry.dim - 1]   # z: the mesh's last axis
    return (mesh.comm.allreduce(z.min(initial=np.inf), op=MPI.MIN),
            mesh.comm.allreduce(z.max(initial=-np.inf), op=MPI.MAX))


def check_initial_stress(scene, tagged):
    """InputError naming the region, material and depth where the in-situ stress lies
    outside the yield surface; collective (every rank raises alike)."""
    if scene.geostatic is None:
        return
    for region, material in scene.regions.items():
        model = scene.materials[material]
        z = np.array(region_depths(tagged, region))
        x = np.column_stack([np.zeros(2), np.zeros(2), z])
        stress = scene.geostatic.stress(x)
        try:
            returned = model.update(np.zeros((2, 6)), model.initial_state(2, stress))[0]
            moved = np.linalg.norm(returned - stress, axis=1)
            outside = moved > TOLERANCE * max(np.abs(stress).max(), 1e-300)
        except ReturnMapError:
            outside = np.ones(2, dtype=bool)
        if outside.any():
            depth = z[np.argmax(outside)]
            raise InputError(
                f"{scene.path}: geostatic: the in-situ stress (unit_weight {scene.geostatic.unit_weight:g}, "
                f"K0 {scene.geostatic.K0:g}) at z = {depth:g} in region {region!r} lies outside "
                f"the yield surface of materials.{material}; raise its strength, or change K0")
