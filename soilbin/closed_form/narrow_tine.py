"""Draft of a narrow tillage tool: the McKyes & Ali (1977) three-dimensional wedge.

McKyes, E. and Ali, O.S. (1977) The cutting of soil by narrow blades.
J. Terramechanics 14(2), 43-58; restated in McKyes, E. (1985) Soil Cutting
and Tillage, Elsevier, ch. 4. The soil ahead of the blade fails as a rigid
centre wedge, bounded by the blade, the surface and a plane through the tip
at the rupture angle beta, flanked by a side crescent on each open side.

Why McKyes & Ali and not Godwin & Spoor (1977): the chapter VIII tools are
1-4 in wide, 6 in deep (depth assumed; the dissertation does not give it),
raked at 30-90 degrees. McKyes & Ali holds for any rake and any
depth/width ratio with the same closed-form factors, and the failure angle
comes out of the minimisation rather than a chart. Godwin & Spoor was
built for near-vertical tines; it reads its passive factors from
Hettiaratchi & Reece's charts and splits the tine at a critical depth
below which the soil flows round the tine sideways. With d/w from 1.5 to 6
the bin's tools sit in the crescent-failure range on either reading, so
Godwin & Spoor's critical depth buys nothing here and its charts would
have to be digitised.

Rake alpha as in the dissertation: from the horizontal, in the direction of
travel, 90 degrees = vertical tine; below 90 the blade leans back and its tip
leads. Equations, numbered here (the paper's own numbering was not
available to check; the forms are McKyes (1985) ch. 4):

 (1) F = (gamma d^2 N_gamma + c d N_c + c_a d N_ca + q d N_q) w
 (2) r = d (cot alpha + cot beta),  r' = d sqrt(cot^2 beta + 2 cot alpha cot beta)
 (3) E = cos(alpha+delta) + sin(alpha+delta) cot(beta+phi)
     = sin(alpha+delta+beta+phi) / sin(beta+phi)
 (4) N_gamma = (r / 2d) [1 + (2/3)(r'/w)] / E
 (5) N_c = [1 + cot beta cot(beta+phi)] [1 + r'/w] / E
     N_q = (r/d) [1 + r'/w] / E
     N_ca = [1 - cot alpha cot(beta+phi)] / E
 (6) H = F sin(alpha+delta) + c_a d w cot alpha   (draft)
     V = F cos(alpha+delta) - c_a d w             (down on the tool)
 (7) beta minimises F (the soil fails on the weakest plane), with
     alpha + delta + beta + phi < 180 degrees so that E > 0.

The crescent terms (r'/w in (4), (5)) are the two side crescents; each
contributes half. ``crescents`` counts them: 2 for a tool in the open soil,
1 for a tool against the bin's frictionless glass wall (figure 8.2), 0 for
the plane (2-D, wide blade) limit. A frictionless wall is a mirror plane:
a w-wide tool against it carries half the force of a 2w-wide tool in the
open soil, which is the one-crescent result since the crescent terms do
not depend on w. The finite element half model of an embedded tool
(``configuration = "embedded"``, half the width) is the same: the tool's
half span with one crescent.
"""
import math
from dataclasses import dataclass

import numpy as np

MODEL = "McKyes & Ali (1977) narrow blade"


class NoWedge(ValueError):
    """rake + delta + phi >= 180 degrees: no rupture plane closes a wedge (F is unbounded)."""


@dataclass(frozen=True)
class DraftEstimate:
    """Forces on the tool at soil failure, in the units of the inputs."""
    draft: float             # H: horizontal, against the direction of travel
    vertical: float          # V: down on the tool (negative: the soil lifts it)
    rupture_angle: float     # beta [degrees] of the failure plane from the horizontal
    rupture_distance: float  # r: how far the failure reaches ahead of the blade's top edge
    crescent_extent: float   # r': how far each side crescent reaches beyond the blade's side
    crescents: int
    phi: float               # the soil's friction angle [degrees] and cohesion used
    c: float
    strength: str = "material"   # where phi, c came from
    model: str = MODEL


def _force(beta, alpha, delta, phi, depth, width, gamma, c, c_a, q, crescents):
    """F of (1) for rupture angles beta [rad] (array); also r and r' of (2)."""
    cot_a, cot_b = 1.0 / math.tan(alpha), 1.0 / np.tan(beta)
    r = depth * (cot_a + cot_b)                                        # (2)
    r_side = depth * np.sqrt(cot_b**2 + 2.0 * cot_a * cot_b)           # (2)
    e = np.sin(alpha + delta + beta + phi) / np.sin(beta + phi)        # (3)
    side = 0.5 * crescents * r_side / width
    n_gamma = r / (2.0 * depth) * (1.0 + 2.0 / 3.0 * side) / e         # (4)
    cot_bp = 1.0 / np.tan(beta + phi)
    n_c = (1.0 + cot_b * cot_bp) * (1.0 + side) / e                    # (5)
    n_q = r / depth * (1.0 + side) / e                                 # (5)
    n_ca = (1.0 - cot_a * cot_bp) / e                                  # (5)
    force = (gamma * depth**2 * n_gamma + c * depth * n_c + c_a * depth * n_ca
             + q * depth * n_q) * width                                # (1)
    return force, r, r_side


def narrow_tine_draft(width, depth, rake, phi, delta, gamma, c=0.0, c_a=0.0, q=0.0,
                      crescents=2, strength="material") -> DraftEstimate:
    """McKyes & Ali draft of a blade ``width`` wide, its tip ``depth`` deep, raked at
    ``rake`` degrees from the horizontal (90 = vertical); soil friction ``phi`` and
    soil-tool friction ``delta`` in degrees, unit weight ``gamma``, cohesion ``c``,
    adhesion ``c_a``, surcharge ``q``; ``crescents`` side crescents (2, 1 or 0);
    ``strength`` says where phi and c came from (recorded, not used)."""
    if crescents not in (0, 1, 2):
        raise ValueError(f"crescents = {crescents!r}: 2 (open soil), 1 (against a wall) or 0 (plane)")
    if not 0.0 < rake <= 90.0:
        raise ValueError(f"rake = {rake!r} degrees must be in (0, 90]")
    alpha, dl, ph = (math.radians(a) for a in (rake, delta, phi))
    args = (alpha, dl, ph, depth, width, gamma, c, c_a, q, crescents)
    upper = math.pi - alpha - dl - ph                                  # (7): E > 0
    if upper <= 0.0:
        raise NoWedge(f"rake + delta + phi = {rake + delta + phi:.4g} >= 180 degrees: no wedge can form")
    # (7): the least F over beta, bracketed on a grid, then golden-section search.
    grid = np.linspace(0.0, min(upper, 0.5 * math.pi), 2002)[1:-1]
    k = int(np.argmin(_force(grid, *args)[0]))
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    ratio = 0.5 * (math.sqrt(5.0) - 1.0)
    while hi - lo > 1e-12:
        a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        if _force(a, *args)[0] < _force(b, *args)[0]:
            hi = b
        else:
            lo = a
    beta = 0.5 * (lo + hi)
    force, r, r_side = (float(v) for v in _force(beta, *args))
    return DraftEstimate(
        draft=force * math.sin(alpha + dl) + c_a * depth * width / math.tan(alpha),   # (6)
        vertical=force * math.cos(alpha + dl) - c_a * depth * width,                  # (6)
        rupture_angle=math.degrees(beta), rupture_distance=r, crescent_extent=r_side,
        crescents=crescents, phi=phi, c=c, strength=strength)


# Section VII.5 artificial soil (lb, in): phi = 33 degrees, c = 0, gamma = 0.072 pci.
# delta = 22 degrees (soil on cold-rolled steel) is the tine scene's value; the
# dissertation does not state one. Depth 6 in is assumed, as in the scene.
ARTIFICIAL_SOIL = {"phi": 33.0, "c": 0.0, "gamma": 0.072, "delta": 22.0, "c_a": 0.0}
TOOL_DEPTH = 6.0

# Chapter VIII: (figure, width [in], rake [degrees], crescents).
CHAPTER_VIII = (
    ("8.2", 2.0, 90.0, 1),   # against the glass side wall (width assumed, as in the scene)
    ("8.3", 2.0, 90.0, 2),
    ("8.4", 1.0, 90.0, 2),
    ("8.5", 3.0, 90.0, 2),
    ("8.6", 4.0, 90.0, 2),
    ("8.7", 2.0, 75.0, 2),
    ("8.8", 2.0, 45.0, 2),
    ("8.9", 2.0, 30.0, 2),
)


def chapter_viii_cases(depth=TOOL_DEPTH, soil=ARTIFICIAL_SOIL):
    """[(figure, width, rake, DraftEstimate)] for the chapter VIII tools in the VII.5 soil."""
    return [(fig, w, rake, narrow_tine_draft(w, depth, rake, crescents=n, **soil))
            for fig, w, rake, n in CHAPTER_VIII]


def chapter_viii_table(depth=TOOL_DEPTH, soil=ARTIFICIAL_SOIL):
    """The chapter VIII estimates as a Markdown table (lb, in, degrees)."""
    rows = ["| figure | width [in] | rake [deg] | crescents | draft H [lb] | vertical V [lb] "
            "| beta [deg] | r [in] | r' [in] |",
            "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    rows += [f"| {fig} | {w:g} | {rake:g} | {e.crescents} | {e.draft:.1f} | {e.vertical:.1f} "
             f"| {e.rupture_angle:.1f} | {e.rupture_distance:.1f} | {e.crescent_extent:.1f} |"
             for fig, w, rake, e in chapter_viii_cases(depth, soil)]
    return "\n".join(rows)
