"""The Jacobian's assembly: FFCx's element kernels in one compiled loop that sums the
element matrices at positions found once, the sums handed to PETSc as COO values.

DOLFINx 0.5 inserts each element matrix with ``MatSetValuesLocal``, PETSc looking every
entry up in its row: half of the tine's Jacobian (docs/performance.md, *The assembly*).
Here every entry's position is found once per mesh: the (row, column) pairs of all element
matrices of the form's cell and exterior-facet integrals are reduced to the matrix's
nonzeros by a compiled pass over the rows, and ``MatSetPreallocationCOOLocal`` takes them
as the matrix's pattern. An assembly calls the same FFCx kernels on the coefficients and constants DOLFINx
packs, from a compiled loop that adds each element matrix into the nonzeros' sums, and
hands the sums to ``MatSetValuesCOO``. As in DOLFINx's assembler, the rows and columns of
Dirichlet dofs are zeroed and their diagonal set to one, and every sum takes its element
contributions in DOLFINx's order (cells, then facets, each in the form's order): the same
matrix to the bit in serial.
"""
import ctypes
from pathlib import Path

import numpy as np
import petsc4py
from dolfinx import cpp
from petsc4py import PETSc

from ..models.jit import kernel
from .jit import ufcx_ffi

#: UFCx's integral types that the assembler computes (interior facets are not used).
INTEGRAL_TYPES = (cpp.fem.IntegralType.cell, cpp.fem.IntegralType.exterior_facet)

_TABULATE = ctypes.CFUNCTYPE(None, *(ctypes.c_void_p,) * 6)


def _petsc():
    """PETSc's C library (the one petsc4py is built on) with the COO calls declared."""
    lib = ctypes.CDLL(str(Path(petsc4py.get_config()["PETSC_DIR"]) / "lib" / "libpetsc_real.so"))
    lib.MatSetPreallocationCOOLocal.argtypes = (ctypes.c_void_p, ctypes.c_int64,
                                                ctypes.c_void_p, ctypes.c_void_p)
    lib.MatSetValuesCOO.argtypes = (ctypes.c_void_p, ctypes.c_void_p, ctypes.c_int)
    return lib


_LIB = _petsc()


def _check(error, call):
    if error:
        raise RuntimeError(f"PETSc's {call} failed (error {error})")


@kernel
def add_element_matrices(tabulate, entities, dofs, coefficients, constants, x, geometry,
                         permutations, fixed, positions, coordinates, element, sums):
    """Add the element matrix of every entity (a cell, or a cell's local facet: ``entities``
    (n, 2)), with the rows and columns of the ``fixed`` dofs zeroed, into ``sums`` at its
    entries' ``positions`` (n m m, row-major); ``permutations``: the facets' quadrature
    permutations (cell-major), or one entry never read if the kernel takes none;
    ``coordinates`` and ``element`` (m, m): scratch."""
    n_facets = permutations.shape[0] // geometry.shape[0]
    m = element.shape[0]
    for k in range(entities.shape[0]):
        cell, local = entities[k, 0], entities[k, 1]
        for j in range(geometry.shape[1]):
            for d in range(3):
                coordinates[j, d] = x[geometry[cell, j], d]
        element[:] = 0.0
        tabulate(element.ctypes.data, coefficients[k].ctypes.data, constants.ctypes.data,
                 coordinates.ctypes.data, entities[k, 1:].ctypes.data,
                 permutations[cell * n_facets + local:].ctypes.data)
        cell_dofs = dofs[cell]
        for i in range(m):
            if fixed[cell_dofs[i]]:
                element[i, :] = 0.0
                element[:, i] = 0.0
        first = k * m * m
        for i in range(m):
            for j in range(m):
                sums[positions[first + i * m + j]] += element[i, j]


@kernel
def nonzero_pattern(element_dofs, row_items, row_offsets, seen, position_of, positions,
                    rows, columns):
    """The nonzeros of the element matrices of ``element_dofs`` (n, m), row by row, each
    (row, column) once: the element entries' ``positions`` (n m m, row-major) among them and,
    if ``rows`` is not empty, their ``rows`` and ``columns``; ``row_items`` lists the (entity,
    local dof) items k m + i of each row, from ``row_offsets``; ``seen`` (-1) and
    ``position_of``: scratch over the columns. Returns the number of nonzeros."""
    m = element_dofs.shape[1]
    count = 0
    for row in range(row_offsets.shape[0] - 1):
        for item in row_items[row_offsets[row]:row_offsets[row + 1]]:
            k, i = item // m, item % m
            for j in range(m):
                column = element_dofs[k, j]
                if seen[column] != row:
                    seen[column], position_of[column] = row, count
                    if rows.shape[0]:
                        rows[count], columns[count] = row, column
                    count += 1
                positions[(k * m + i) * m + j] = position_of[column]
    return count


def compile_loops():
    """The two loops compiled (or loaded from numba's cache) for the argument types an
    assembly passes them, on empty arrays: ``python -m soilbin.solver`` (``make setup``), so
    that a first run does not wait for numba."""
    pairs, dofs = np.zeros((0, 2), np.int32), np.zeros((0, 1), np.int32)
    index = np.zeros(0, np.int32)
    never_called = _TABULATE(lambda *pointers: None)
    add_element_matrices(never_called, pairs, dofs, np.zeros((0, 1)), np.zeros(0),
                         np.zeros((0, 3)), dofs, np.zeros(1, np.uint8), np.zeros(0, np.bool_),
                         index, np.zeros((1, 3)), np.zeros((1, 1)), np.zeros(0))
    none = np.zeros(0, dtype=PETSc.IntType)
    nonzero_pattern(dofs, index, np.zeros(1, np.int64), index, index, index, none, none)


class ElementAssembler:
    """Assembles the bilinear form ``form`` (on ``space``, Dirichlet conditions ``bcs``)
    into the matrix ``A`` made for it by ``dolfinx.fem.petsc.create_matrix``, whose
    preallocation it replaces by the COO pattern of the form's element matrices; if
    ``coupled``, it keeps that pattern for :meth:`couple`."""

    def __init__(self, form, space, bcs, A, coupled=False):
        self._coupled_pattern = coupled
        if set(form.integral_types) - set(INTEGRAL_TYPES):
            raise ValueError("the element assembler takes cell and exterior-facet integrals")
        if space.element.needs_dof_transformations:
            raise ValueError("the element assembler takes elements without dof transformations")
        self._form = form
        mesh = space.mesh
        bs = space.dofmap.bs
        nodes = space.dofmap.list.array.reshape(space.dofmap.list.num_nodes, -1)
        self._dofs = (nodes[:, :, None] * bs + np.arange(bs, dtype=np.int32)).reshape(
            len(nodes), -1).astype(np.int32)
        imap = space.dofmap.index_map
        n_local = (imap.size_local + imap.num_ghosts) * bs
        self._fixed = np.zeros(n_local, dtype=np.bool_)
        owned_fixed = [np.zeros(0, dtype=np.int32)]
        for bc in bcs:
            indices, first_ghost = bc.dof_indices()
            self._fixed[indices] = True
            owned_fixed.append(indices[:first_ghost])
        diagonal = np.unique(np.concatenate(owned_fixed))
        self._x = mesh.geometry.x
        self._geometry = mesh.geometry.dofmap.array.reshape(len(mesh.geometry.dofmap), -1)
        self._coordinates = np.zeros((self._geometry.shape[1], 3))
        m = self._dofs.shape[1]
        self._element = np.zeros((m, m))
        ffi = ufcx_ffi("double")
        ufcx = form.ufcx_form
        self._integrals, cells, start = [], [], 0
        for kind in INTEGRAL_TYPES:
            if kind not in form.integral_types:
                continue
            pointers = ufcx.integrals(int(kind))
            ids = ufcx.integral_ids(int(kind))
            for i in range(ufcx.num_integrals(int(kind))):
                entities = np.asarray(form.domains(kind, ids[i]), dtype=np.int32)
                entities = (np.column_stack([entities, np.zeros_like(entities)])
                            if kind == cpp.fem.IntegralType.cell else entities.reshape(-1, 2))
                permutations = np.zeros(1, dtype=np.uint8)
                if pointers[i].needs_facet_permutations:
                    mesh.topology.create_entity_permutations()
                    permutations = mesh.topology.get_facet_permutations()
                tabulate = _TABULATE(int(ffi.cast("uintptr_t", pointers[i].tabulate_tensor_float64)))
                self._integrals.append((kind, ids[i], tabulate, entities, permutations,
                                        slice(start, start + len(entities) * m * m)))
                cells.append(entities[:, 0])
                start += len(entities) * m * m
        self._positions, self._sums, self._diagonal = self._pattern(
            np.concatenate(cells), n_local, diagonal, A)

    def _pattern(self, cells, n_local, diagonal, A):
        """The nonzeros of the element matrices of ``cells`` (in the integrals' order) made
        ``A``'s pattern: (each element entry's position among them, their sums, the
        positions of the Dirichlet ``diagonal``)."""
        element_dofs = self._dofs[cells]
        m = element_dofs.shape[1]
        items = element_dofs.ravel()
        row_items = np.argsort(items, kind="stable").astype(np.int32)
        row_offsets = np.concatenate([[0], np.cumsum(np.bincount(items, minlength=n_local))])
        positions = np.empty(len(cells) * m * m, dtype=np.int32)
        seen, position_of = np.full(n_local, -1, dtype=np.int32), np.empty(n_local, np.int32)
        none = np.zeros(0, dtype=PETSc.IntType)
        count = nonzero_pattern(element_dofs, row_items, row_offsets, seen, position_of,
                                positions, none, none)
        rows, columns = np.empty(count, PETSc.IntType), np.empty(count, PETSc.IntType)
        seen[:] = -1
        nonzero_pattern(element_dofs, row_items, row_offsets, seen, position_of, positions,
                        rows, columns)
        at_diagonal = np.flatnonzero(rows == columns)
        on_diagonal = np.full(n_local, -1, dtype=np.int64)
        on_diagonal[rows[at_diagonal]] = at_diagonal
        if np.any(on_diagonal[diagonal] < 0):
            raise ValueError("a Dirichlet dof outside every element: no diagonal entry for it")
        if self._coupled_pattern:   # global, for :meth:`couple`
            rmap, cmap = A.getLGMap()
            self._entries = (rmap.apply(rows), cmap.apply(columns))
        # PETSc maps the local indices to global ones in place (and may change them further)
        _check(_LIB.MatSetPreallocationCOOLocal(A.handle, count, rows.ctypes.data,
                                                columns.ctypes.data),
               "MatSetPreallocationCOOLocal")
        return positions, np.zeros(count), on_diagonal[diagonal]

    def couple(self, A, rows, columns):
        """Make the fresh matrix ``A`` (``create_matrix``'s, not yet assembled) the element
        matrices' pattern and the entries (``rows``, ``columns``, global indices, possibly
        another rank's) that couple dofs of no common element: their values follow the
        element sums in :meth:`assemble`'s ``coupling``. (PETSc 3.18 keeps a matrix's old
        COO map when the COO preallocation is called again: hence a fresh matrix.)"""
        element_rows, element_columns = self._entries
        all_rows = np.concatenate([element_rows, rows]).astype(PETSc.IntType)
        all_columns = np.concatenate([element_columns, columns]).astype(PETSc.IntType)
        _check(_LIB.MatSetPreallocationCOO(A.handle, len(all_rows), all_rows.ctypes.data,
                                           all_columns.ctypes.data), "MatSetPreallocationCOO")
        self._sums = np.zeros(len(all_rows))
        self._coupled = slice(len(element_rows), len(all_rows))

    def assemble(self, A, coupling=None):
        """The form at the current coefficients into ``A`` (its values replaced), with the
        values of the entries :meth:`couple` added."""
        self.tabulate(cpp.fem.pack_coefficients(self._form), cpp.fem.pack_constants(self._form))
        if coupling is not None:
            self._sums[self._coupled] = coupling
        self.insert(A)

    def tabulate(self, coefficients, constants):
        """Every element matrix summed into the nonzeros, from the coefficients and constants
        DOLFINx packs; the Dirichlet diagonal set to one."""
        self._sums[:] = 0.0   # the coupling entries too
        for kind, id_, tabulate, entities, permutations, part in self._integrals:
            add_element_matrices(tabulate, entities, self._dofs, coefficients[(kind, id_)],
                                 constants, self._x, self._geometry, permutations, self._fixed,
                                 self._positions[part], self._coordinates, self._element,
                                 self._sums)
        self._sums[self._diagonal] = 1.0

    def insert(self, A):
        """The sums into ``A`` (its values replaced)."""
        _check(_LIB.MatSetValuesCOO(A.handle, self._sums.ctypes.data,
                                    int(PETSc.InsertMode.INSERT_VALUES)), "MatSetValuesCOO")
