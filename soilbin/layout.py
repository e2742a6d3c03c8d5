"""What a part's state array is laid out over, on one rank (for checkpoints and remeshing).

A stateful part (the kinematics, the material points, the tool) gives its
state as named ``(kind, array)`` pairs; the array's first axis runs over this
rank's entities of that kind, ghosts included. ``app.checkpoint`` stores each
kind by the mesh's input cell numbering (or, for contact points, by their face
and place), so a checkpoint does not depend on how the mesh was distributed;
:class:`CellLayout` gathers a state onto rank 0 that way and hands it back out
(a checkpoint's, or a state transferred to a new mesh).
"""
import numpy as np

#: The unknown's dofs (a flat array, block after block of ``disc.space``).
DOFS = "dofs"
#: The quadrature points, cell by cell.
POINTS = "points"
#: The mesh geometry's nodes.
NODES = "nodes"
#: The tool's contact points on this rank.
CONTACT = "contact"
#: One value, the same on every rank.
GLOBAL = "global"


class CellLayout:
    """This rank's cells by their input numbers, and the entities of each kind (of
    ``problem.entities()``)."""

    def __init__(self, problem):
        mesh = problem.mesh
        cells = mesh.topology.index_map(mesh.topology.dim)
        self.comm = mesh.comm
        self.n_owned, self.n_global = cells.size_local, cells.size_global
        n_local = cells.size_local + cells.num_ghosts
        self.number = np.asarray(mesh.topology.original_cell_index)[:n_local]
        self.tables, self.contact = problem.entities()
        # this rank's rows among the contact points gathered one rank after another
        n_contact = 0 if self.contact is None else len(self.contact)
        first = self.comm.exscan(n_contact) or 0
        self._contact_rows = slice(first, first + n_contact)
        nodes = mesh.geometry.dofmap.array.reshape(n_local, -1)
        self.centres = mesh.geometry.x[nodes].mean(axis=1)   # taken before the mesh moves

    def by_cell(self, kind, values):
        """(n_owned, k, ...): the values of each owned cell's entities."""
        table, values = self.tables[kind], np.asarray(values)
        if kind == DOFS:   # flat: by block
            values = values.reshape(table.max(initial=-1) + 1, -1)
        return values[table[:self.n_owned]]

    def local(self, kind, stored):
        """This rank's array (ghosts included) from the stored (n_global, k, ...) one; for the
        contact points this rank's rows of the gathered ones (:meth:`gather_state`)."""
        if kind == CONTACT:
            return stored[self._contact_rows]
        table = self.tables[kind]
        out = np.empty((table.max(initial=-1) + 1,) + stored.shape[2:], dtype=stored.dtype)
        out[table] = stored[self.number]
        return out.ravel() if kind == DOFS else out

    def gather(self, values):
        """On rank 0, (n_global, ...): every owned cell's rows at its input number; None
        elsewhere (collective)."""
        return gather_by_number(self.comm, self.number[:self.n_owned], values)

    def gather_state(self, state):
        """A :meth:`SoilProblem.state` on rank 0 by input cell number (the contact points'
        rows one rank after another): name -> (kind, array); None elsewhere (collective)."""
        gathered = {}
        for name, (kind, values) in state.items():
            if kind == GLOBAL:
                gathered[name] = (kind, np.asarray(values))
            elif kind == CONTACT:
                gathered[name] = (kind, gather_rows(self.comm, np.asarray(values)))
            else:
                gathered[name] = (kind, self.gather(self.by_cell(kind, values)))
        return gathered if self.comm.rank == 0 else None


def gather_by_number(comm, numbers, values):
    """On rank 0, (n_global, ...) with each rank's rows at their numbers; None elsewhere."""
    numbers, values = comm.gather(numbers, root=0), comm.gather(values, root=0)
    if comm.rank != 0:
        return None
    numbers = np.concatenate(numbers)
    out = np.empty((len(numbers),) + values[0].shape[1:], dtype=values[0].dtype)
    out[numbers] = np.concatenate(values)
    return out


def gather_rows(comm, values):
    """On rank 0, every rank's rows one after the other; None elsewhere."""
    values = comm.gather(values, root=0)
    return np.concatenate(values) if comm.rank == 0 else None
