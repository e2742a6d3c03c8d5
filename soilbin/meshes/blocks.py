"""Structured hexahedral blocks in gmsh's geo kernel, and the geometry queries that tag them.

Call these inside a ``geometry`` function of :func:`.tagged.build_tagged_mesh`.
"""
import itertools
from typing import Callable, Sequence, Union

import gmsh
import numpy as np

from .segments import Segment


Mapping = Callable[[float, float, float], tuple[float, float, float]]


def block_grid(xs: Sequence[Segment], ys: Sequence[Segment], zs: Sequence[Segment],
               keep: Callable[[int, int, int], bool] = lambda i, j, k: True,
               mapping: Mapping = lambda x, y, z: (x, y, z), dimension: int = 3,
               simplices: bool = False) -> None:
    """Transfinite hexahedral blocks: the products of the x, y and z segments (each sequence
    contiguous and ascending) whose indices (i, j, k) ``keep`` accepts; with ``dimension``
    = 2 only each block's face at its low y, a transfinite quadrilateral surface. With
    ``simplices`` the faces are not recombined: gmsh splits each hexahedron of the grid into
    six tetrahedra (each quadrilateral into two triangles), on the same nodes.

    ``mapping`` moves the block corners; the blocks' faces must stay planar
    (e.g. a map bilinear in each block). Synchronizes the model.
    """
    geo = gmsh.model.geo
    segments = (xs, ys, zs)
    ticks = [[s[0].lo] + [t.hi for t in s] for s in segments]
    blocks = [b for b in itertools.product(*(range(len(s)) for s in segments)) if keep(*b)]
    points, lines, faces = {}, {}, {}

    def shift(corner, axis):
        return tuple(c + (a == axis) for a, c in enumerate(corner))

    def point(corner):
        if corner not in points:
            points[corner] = geo.addPoint(*mapping(*(t[c] for t, c in zip(ticks, corner))))
        return points[corner]

    def line(corner, axis):
        if (corner, axis) not in lines:
            tag = geo.addLine(point(corner), point(shift(corner, axis)))
            s = segments[axis][corner[axis]]
            geo.mesh.setTransfiniteCurve(tag, s.n + 1, "Progression", s.ratio)
            lines[corner, axis] = tag
        return lines[corner, axis]

    def face(corner, normal):
        if (corner, normal) not in faces:
            a, b = (axis for axis in range(3) if axis != normal)
            loop = [line(corner, a), line(shift(corner, a), b), -line(shift(corner, b), a), -line(corner, b)]
            tag = geo.addPlaneSurface([geo.addCurveLoop(loop)])
            geo.mesh.setTransfiniteSurface(tag)
            if not simplices:
                geo.mesh.setRecombine(2, tag)
            faces[corner, normal] = tag
        return faces[corner, normal]

    for block in blocks:
        if dimension == 2:
            face(block, 1)
            continue
        sides = [face(c, axis) for axis in range(3) for c in (block, shift(block, axis))]
        volume = geo.addVolume([geo.addSurfaceLoop(sides)])
        geo.mesh.setTransfiniteVolume(volume)
    geo.synchronize()


def extruded_grid(xs: Sequence[Segment], zs: Sequence[Segment], thickness: float, layers: int,
                  dimension: int = 3, simplices: bool = False) -> None:
    """Blocks of transfinite quads on the x-z plane, extruded to y = thickness in hexahedra
    (``dimension`` = 2: not extruded; ``simplices``: split, as :func:`block_grid`).

    The blocks are the products of the x segments ``xs`` and the z segments
    ``zs`` (each sequence contiguous and ascending); ``layers`` elements span
    the thickness. Synchronizes the model.
    """
    block_grid(xs, [Segment(0.0, thickness, layers)], zs, dimension=dimension,
               simplices=simplices)


Limit = Union[None, float, tuple[float, float]]


def _tolerance() -> float:
    """1e-6 of the model's largest extent."""
    box = gmsh.model.getBoundingBox(-1, -1)
    return 1e-6 * max(b - a for a, b in zip(box[:3], box[3:]))


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
    tol = _tolerance()
    found = gmsh.model.getEntitiesInBoundingBox(*(v - tol for v in lo), *(v + tol for v in hi), dim=dim)
    return [tag for _, tag in found]


def on_plane(dim: int, tags: Sequence[int], point, normal) -> list[int]:
    """Those of the ``dim``-entities ``tags`` whose corner points all lie on the plane through
    ``point`` with unit ``normal`` (same tolerance as :func:`entities_within`)."""
    tol = _tolerance()

    def distance(corner):
        return abs(np.dot(np.asarray(gmsh.model.getValue(0, corner, [])) - point, normal))

    return [tag for tag in tags
            if all(distance(c) <= tol for _, c in gmsh.model.getBoundary([(dim, tag)], recursive=True))]


def plane_strain_groups(in_plane: dict, dimension: int, thickness: float) -> tuple[dict, dict]:
    """(regions, boundaries) of a plane-strain builder's model: the one region "soil", the
    boundaries ``in_plane`` (group -> entities) and, on a slab, its faces y = 0 ("front")
    and y = thickness ("back")."""
    boundaries = dict(in_plane)
    if dimension == 3:
        boundaries.update(front=entities_within(2, y=0.0), back=entities_within(2, y=thickness))
    return {"soil": entities_within(dimension)}, boundaries
