"""Closed-form (limit-equilibrium) estimates to set beside the finite element results.

Pure Python and NumPy: nothing here imports dolfinx, gmsh, PETSc or matplotlib.
"""
from .narrow_tine import (MODEL, DraftEstimate, chapter_viii_cases, chapter_viii_table,
                          narrow_tine_draft)

__all__ = ["MODEL", "DraftEstimate", "chapter_viii_cases", "chapter_viii_table", "narrow_tine_draft"]
