"""Graded divisions of an interval: the edges of structured hexahedral blocks (no gmsh).

The builders' parameter records use them to count their cells before gmsh
runs; :func:`.blocks.block_grid` meshes with them.
"""
import math
from dataclasses import dataclass


@dataclass(frozen=True)
class Segment:
    """[lo, hi] cut into n elements, each ``ratio`` times as long as the previous one (from lo to hi)."""

    lo: float
    hi: float
    n: int
    ratio: float = 1.0

    @classmethod
    def growing(cls, start: float, end: float, size: float, growth: float = 1.0) -> "Segment":
        """From ``start`` to ``end`` (either way round) in the fewest elements that are at most
        ``size`` long at ``start`` and grow by ``growth`` (>= 1) from one to the next."""
        length = abs(end - start)
        if growth == 1.0:
            count = length / size
        else:
            count = math.log1p(length * (growth - 1.0) / size) / math.log(growth)
        n = max(1, math.ceil(count - 1e-9))
        return cls(min(start, end), max(start, end), n, growth if end > start else 1.0 / growth)

    def refined(self, k: int) -> "Segment":
        """Every element split into k, keeping the nodes: k n elements, ratio ** (1 / k)."""
        return Segment(self.lo, self.hi, self.n * k, self.ratio ** (1.0 / k))
