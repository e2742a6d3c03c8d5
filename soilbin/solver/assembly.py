"""The Jacobian's assembly: FFCx's element kernels in one compiled loop, the element
matrices handed to PETSc as COO values.

DOLFINx 0.5 inserts each element matrix with ``MatSetValuesLocal``, PETSc looking every
entry up in its row: 60% of the tine's Jacobian (docs/performance.md, *The assembly*).
Here the positions are found once: ``MatSetPreallocationCOOLocal`` takes the (row,
column) pairs of every element matrix of the form's cell and exterior-facet integrals
(and the Dirichlet diagonal), and an assembly computes all element matrices into one
array - the same FFCx kernels on the coefficients and constants DOLFINx packs, called
from a compiled loop - which ``MatSetValuesCOO`` sums into the matrix in place. As in
DOLFINx's assembler, the rows and columns of Dirichlet dofs are zeroed and their diagonal
set to one, so the matrix has DOLFINx's sparsity and values; only the order in which
PETSc adds an entry's element contributions may differ (rounding).
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
def element_matrices(tabulate, entities, dofs, coefficients, constants, x, geometry,
                     permutations, fixed, coordinates, out):
    """The element matrix of every entity (a cell, or a cell's local facet: ``entities``
    (n, 2)) into ``out`` (n, m, m), with the rows and columns of the ``fixed`` dofs zeroed;
    ``permutations``: the facets' quadrature permutations (cell-major), empty if the
    kernel takes none (then one entry, never read); ``coordinates``: scratch for a cell's
    node coordinates."""
    n_facets = permutations.shape[0] // geometry.shape[0]
    for k in range(entities.shape[0]):
        cell, local = entities[k, 0], entities[k, 1]
        for j in range(geometry.shape[1]):
            for d in range(3):
                coordinates[j, d] = x[geometry[cell, j], d]
        element = out[k]
        element[:] = 0.0
        tabulate(element.ctypes.data, coefficients[k].ctypes.data, constants.ctypes.data,
                 coordinates.ctypes.data, entities[k, 1:].ctypes.data,
                 permutations[cell * n_facets + local:].ctypes.data)
        cell_dofs = dofs[cell]
        for i in range(cell_dofs.shape[0]):
            if fixed[cell_dofs[i]]:
                element[i, :] = 0.0
                element[:, i] = 0.0


class ElementAssembler:
    """Assembles the bilinear form ``form`` (on ``space``, Dirichlet conditions ``bcs``)
    into the matrix ``A`` made for it by ``dolfinx.fem.petsc.create_matrix``, whose
    preallocation it replaces by the COO pattern of the form's element matrices."""

    def __init__(self, form, space, bcs, A):
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
        diagonal = np.unique(np.concatenate(owned_fixed))   # one on it, as DOLFINx's
        self._x = mesh.geometry.x
        self._geometry = mesh.geometry.dofmap.array.reshape(len(mesh.geometry.dofmap), -1)
        self._coordinates = np.zeros((self._geometry.shape[1], 3))
        ffi = ufcx_ffi("double")
        ufcx = form.ufcx_form
        self._integrals, rows, columns, start = [], [], [], 0
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
                element_dofs = self._dofs[entities[:, 0]]
                m = element_dofs.shape[1]
                rows.append(np.repeat(element_dofs, m, axis=1).ravel())
                columns.append(np.tile(element_dofs, (1, m)).ravel())
                self._integrals.append((kind, ids[i], tabulate, entities, permutations,
                                        slice(start, start + len(entities) * m * m), m))
                start += len(entities) * m * m
        self._values = np.empty(start + len(diagonal))
        self._values[start:] = 1.0
        rows = np.concatenate(rows + [diagonal]).astype(PETSc.IntType)
        columns = np.concatenate(columns + [diagonal]).astype(PETSc.IntType)
        # PETSc maps the local indices to global ones in place
        _check(_LIB.MatSetPreallocationCOOLocal(A.handle, len(rows), rows.ctypes.data,
                                                columns.ctypes.data),
               "MatSetPreallocationCOOLocal")

    def assemble(self, A):
        """The form at the current coefficients into ``A`` (its values replaced)."""
        self.tabulate(cpp.fem.pack_coefficients(self._form), cpp.fem.pack_constants(self._form))
        self.insert(A)

    def tabulate(self, coefficients, constants):
        """Every element matrix, from the coefficients and constants DOLFINx packs."""
        for kind, id_, tabulate, entities, permutations, part, m in self._integrals:
            element_matrices(tabulate, entities, self._dofs, coefficients[(kind, id_)],
                             constants, self._x, self._geometry, permutations, self._fixed,
                             self._coordinates, self._values[part].reshape(-1, m, m))

    def insert(self, A):
        """The element matrices summed into ``A`` (its values replaced)."""
        _check(_LIB.MatSetValuesCOO(A.handle, self._values.ctypes.data,
                                    int(PETSc.InsertMode.INSERT_VALUES)), "MatSetValuesCOO")
