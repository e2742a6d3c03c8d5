"""Static condensation of the cell-local mean-dilatation fields, and the rigid-body modes.

The ``hex8-bbar`` (``tet10-bbar``) system, ordered (u, c) with c = (θ_K, p_K) per cell K,

    [K   Z] [x_u]   [r_u]
    [Zr  D] [x_c] = [r_c],    D block diagonal with one 2x2 block per cell,

is solved exactly through the displacement-only Schur complement
S = K − Z D⁻¹ Zr (the B-bar stiffness): S x_u = r_u − Z D⁻¹ r_c, then
x_c = D⁻¹ (r_c − Zr x_u). The blocks are submatrices of the assembled
mixed matrix, D⁻¹ is formed cell by cell in NumPy, S by two sparse
products, in the matrix of K (its sparsity holds them). It is what the AMG
and block low-rank solvers work on; for MUMPS's LU and LDLᵀ it does not pay
(forming S costs about what factorising S instead of the mixed matrix
saves). Dirichlet rows of the mixed matrix are identity rows with zero
columns, so they stay identity rows of S.
"""
import numpy as np
from dolfinx import fem
from petsc4py import PETSc

from .resources import release


def _rigid_motions(x):
    """The rigid-body motions at the points x (n, d): d translations, then the rotations
    (about each axis in 3D, in the plane in 2D), each (n, d)."""
    d = x.shape[1]
    translations = [np.tile(np.eye(d)[k], (len(x), 1)) for k in range(d)]
    if d == 2:
        return translations + [np.column_stack([-x[:, 1], x[:, 0]])]
    return translations + [np.cross(np.eye(3)[k], x) for k in range(3)]   # e_k x x


def rigid_body_modes(template, coordinates):
    """The rigid-body modes (six in 3D, three in 2D) at the nodes with ``coordinates``
    (n_owned, d), as vectors laid out like ``template`` (d components per node,
    node-major), orthonormalised; a near-nullspace for GAMG."""
    modes = []
    for values in _rigid_motions(coordinates):
        vector = template.duplicate()
        vector.array[:] = values.ravel()
        for previous in modes:   # Gram-Schmidt (a global dot product each)
            vector.axpy(-vector.dot(previous), previous)
        vector.scale(1.0 / vector.norm())
        modes.append(vector)
    return PETSc.NullSpace().create(vectors=modes)


class Uncondensed:
    """A displacement-only system: solved as it is."""
    description = "displacement only"

    def __init__(self, disc):
        self._space, self._disc = disc.space, disc
        self._nullspace = None

    def condense(self, A):
        if self._nullspace is None:
            n_owned = self._space.dofmap.index_map.size_local
            coordinates = self._disc.in_dof_axes(self._space.tabulate_dof_coordinates()[:n_owned])
            self._nullspace = rigid_body_modes(A.createVecRight(), coordinates)
            A.setNearNullSpace(self._nullspace)
        return A

    @staticmethod
    def solve(ksp, rhs, x):
        ksp.solve(rhs, x)

    def destroy(self):
        release(self._nullspace)


class CellCondensation:
    """The B-bar displacement system of a mixed system with P0 cell fields (see the module
    docstring)."""
    description = "dilatation and pressure condensed out"

    def __init__(self, disc):
        if not disc.element.cell_dilatation:
            raise ValueError("static condensation needs P0 cell fields (hex8-bbar, tet10-bbar)")
        space, mesh = disc.space, disc.mesh
        imap = space.dofmap.index_map
        to_global = imap.local_to_global
        dim = disc.dimension
        cells = mesh.topology.index_map(mesh.topology.dim)
        n_local = cells.size_local + cells.num_ghosts
        # the components of each node, and the node's coordinates, cell by cell
        # (no space.sub(0).collapse(): its dof reordering takes minutes on 10^6 dofs)
        components = np.stack([space.sub(0).sub(i).dofmap.list.array.reshape(n_local, -1)
                               for i in range(dim)], axis=-1).reshape(-1, dim)
        # the nodes' coordinates in the same cell-local order (the scalar space's, whose
        # cells list their nodes as the mixed space's displacement block does)
        scalar = fem.FunctionSpace(mesh, ("Lagrange", disc.element.degree))
        nodes = scalar.dofmap.list.array.reshape(n_local, -1).ravel()
        _, first = np.unique(components[:, 0], return_index=True)
        first = first[components[first, 0] < imap.size_local]       # owned nodes
        u_local = components[first].ravel().astype(np.int32)
        self._coordinates = disc.in_dof_axes(scalar.tabulate_dof_coordinates()[nodes[first]])
        n_cells = cells.size_local
        cell_fields = np.stack([space.sub(i).dofmap.list.array[:n_cells] for i in (1, 2)], axis=1)
        comm = space.mesh.comm
        self.is_u = PETSc.IS().createGeneral(to_global(u_local).astype(PETSc.IntType), comm=comm)
        self.is_u.setBlockSize(dim)
        self.is_c = PETSc.IS().createGeneral(
            to_global(cell_fields.ravel().astype(np.int32)).astype(PETSc.IntType), comm=comm)
        self._n_cells = n_cells
        self._S = self._Z = self._Zr = self._D = self._Dinv = None
        self._x_u = self._f = self._x_c = self._r_c = None
        self._nullspace = None

    def condense(self, A):
        """S = K − Z D⁻¹ Zr for this iterate's mixed matrix ``A`` (S is reused)."""
        reuse = self._S is not None
        self._S = A.createSubMatrix(self.is_u, self.is_u, submat=self._S)
        self._Z = A.createSubMatrix(self.is_u, self.is_c, submat=self._Z)
        self._Zr = A.createSubMatrix(self.is_c, self.is_u, submat=self._Zr)
        self._D = A.createSubMatrix(self.is_c, self.is_c, submat=self._D)
        self._invert_cell_blocks()
        product = self._Z.matMult(self._Dinv.matMult(self._Zr))
        self._S.axpy(-1.0, product, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        product.destroy()
        if not reuse:
            self._nullspace = rigid_body_modes(self._S.createVecRight(), self._coordinates)
            self._S.setNearNullSpace(self._nullspace)
            self._x_u, self._f = self._S.createVecs()
            self._x_c, self._r_c = self._D.createVecs()
        return self._S

    def destroy(self):
        release(self.is_u, self.is_c, self._S, self._Z, self._Zr, self._D, self._Dinv,
                self._nullspace, self._x_u, self._f, self._x_c, self._r_c)

    def _invert_cell_blocks(self):
        """D⁻¹ from the 2x2 blocks of D (rows and columns ordered θ_K, p_K per owned cell)."""
        start = self._D.getOwnershipRange()[0]
        indptr, indices, values = self._D.getValuesCSR()
        rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
        cols = indices - start
        blocks = np.zeros((self._n_cells, 2, 2))
        np.add.at(blocks, (rows // 2, rows % 2, cols % 2), values)
        inverse = np.linalg.inv(blocks)
        pairs = 2 * (np.arange(2 * self._n_cells) // 2)
        csr = (np.arange(0, 4 * self._n_cells + 1, 2, dtype=PETSc.IntType),
               (start + np.stack([pairs, pairs + 1], axis=1)).ravel().astype(PETSc.IntType),
               inverse.ravel())
        if self._Dinv is not None:
            self._Dinv.destroy()
        self._Dinv = PETSc.Mat().createAIJ(self._D.getSizes(), csr=csr, comm=self._D.getComm())
        self._Dinv.assemble()

    def solve(self, ksp, rhs, x):
        """x = A⁻¹ rhs through the condensed system (``ksp`` holds S)."""
        r_u = rhs.getSubVector(self.is_u)
        r_c = rhs.getSubVector(self.is_c)
        self._Dinv.mult(r_c, self._x_c)                    # D⁻¹ r_c
        self._Z.mult(self._x_c, self._f)
        self._f.aypx(-1.0, r_u)                            # r_u − Z D⁻¹ r_c
        ksp.solve(self._f, self._x_u)
        self._Zr.mult(self._x_u, self._r_c)
        self._r_c.aypx(-1.0, r_c)                          # r_c − Zr x_u
        rhs.restoreSubVector(self.is_u, r_u)
        rhs.restoreSubVector(self.is_c, r_c)
        x_u = x.getSubVector(self.is_u)
        self._x_u.copy(x_u)
        x.restoreSubVector(self.is_u, x_u)
        x_c = x.getSubVector(self.is_c)
        self._Dinv.mult(self._r_c, x_c)
        x.restoreSubVector(self.is_c, x_c)
