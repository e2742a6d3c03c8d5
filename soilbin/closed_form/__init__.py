"""Closed-form (limit-equilibrium) estimates to set beside the finite element results.

Pure Python and NumPy: nothing here imports dolfinx, gmsh, PETSc or matplotlib.
"""
from .equivalent_strength import (EquivalentStrength, mohr_coulomb_of_compression_cone,
                                  passive_wedge_strength)
from .narrow_tine import (ARTIFICIAL_SOIL, MODEL, DraftEstimate, NoWedge, chapter_viii_cases, chapter_viii_table,
                          narrow_tine_draft)

__all__ = ["ARTIFICIAL_SOIL", "MODEL", "DraftEstimate", "EquivalentStrength", "NoWedge", "chapter_viii_cases", "chapter_viii_table",
           "mohr_coulomb_of_compression_cone", "narrow_tine_draft", "passive_wedge_strength"]
