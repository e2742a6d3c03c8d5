"""Structured hexahedral blocks in gmsh's geo kernel, and the geometry queries that tag them.

Call these inside a ``geometry`` function of :func:`.tagged.build_tagged_mesh`.
"""
import itertools
from dataclasses import dataclass
from typing import Sequence, Union

import gmsh


@dataclass(frozen=True)
class Segment:
    """[lo, hi] cut into n elements, each ``ratio`` times as long as the previous one (from lo to hi)."""

    lo: float
    hi: float
    n: int
    ratio: float = 1.0


def extruded_grid(xs: Sequence[Segment], zs: Sequence[Segment], thickness: float, layers: int) -> None:
    """Blocks of transfinite quads on the x-z plane, extruded to y = thickness in hexahedra.

    The blocks are the products of the x segments ``xs`` and the z segments
    ``zs`` (each sequence contiguous and ascending); ``layers`` elements span
    the thickness. Synchronizes the model.
    """
    geo = gmsh.model.geo
    x = [xs[0].lo] + [s.hi for s in xs]
    z = [zs[0].lo] + [s.hi for s in zs]
    point = {(i, j): geo.addPoint(x[i], 0.0, z[j]) for i in range(len(x)) for j in range(len(z))}

    def line(start, end, segment):
        tag = geo.addLine(point[start], point[end])
        geo.mesh.setTransfiniteCurve(tag, segment.n + 1, "Progression", segment.ratio)
        return tag

    along_x = {(i, j): line((i, j), (i + 1, j), s) for i, s in enumerate(xs) for j in range(len(z))}
    along_z = {(i, j): line((i, j), (i, j + 1), s) for i in range(len(x)) for j, s in enumerate(zs)}
    faces = []
    for i, j in itertools.product(range(len(xs)), range(len(zs))):
        loop = geo.addCurveLoop([along_x[i, j], along_z[i + 1, j], -along_x[i, j + 1], -along_z[i, j]])
        face = geo.addPlaneSurface([loop])
        geo.mesh.setTransfiniteSurface(face)
        geo.mesh.setRecombine(2, face)
        faces.append((2, face))
    geo.extrude(faces, 0.0, thickness, 0.0, numElements=[layers], recombine=True)
    geo.synchronize()


Limit = Union[None, float, tuple[float, float]]


def entities_within(dim: int, x: Limit = None, y: Limit = None, z: Limit = None) -> list[int]:
    """Tags of the ``dim``-entities lying within the given limits.

    Each limit is a coordinate (a plane), a (lo, hi) pair, or None (the whole
    model's extent). The tolerance is 1e-6 of the model's largest extent.
    """
    box = gmsh.model.getBoundingBox(-1, -1)
    lo, hi = list(box[:3]), list(box[3:])
    for k, limit in enumerate((x, y, z)):
        if limit is not None:
            lo[k], hi[k] = limit if isinstance(limit, tuple) else (limit, limit)
    tol = 1e-6 * max(b - a for a, b in zip(box[:3], box[3:]))
    found = gmsh.model.getEntitiesInBoundingBox(*(v - tol for v in lo), *(v + tol for v in hi), dim=dim)
    return [tag for _, tag in found]
