"""Remeshing during a large-deformation run: the deformed soil meshed afresh and its state moved
onto the new mesh (:mod:`.outline`: the deformed boundary and the old cells, gathered on rank 0;
:mod:`.mesher`: the new mesh; :mod:`.transfer`: the state; :mod:`.remesher`: the run's problem
swapped for one on the new mesh, re-equilibrated at the same load)."""
from .remesher import Remeshing, RemeshError

__all__ = ["Remeshing", "RemeshError"]
