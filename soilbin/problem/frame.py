"""The frame of a scene: an optional rotation of the whole problem (a frame-indifference check).

The rotation is applied once, before any part is built: to the mesh
coordinates here, to every direction the parts read from the records
(:meth:`Frame.vector`: loads, gravity) and to the initial stress field
(:meth:`Frame.stress_field`). The displacement dofs stay components along the
scene's axes (:attr:`Frame.basis`, ``forms.discretisation``), so supports,
rollers and plane strain hold the same dofs as in the unrotated scene.
Results along the loading direction, and the dofs, must not change.
"""
import numpy as np

from ..tensors import from_mandel, rotation_matrix, to_mandel


class Frame:
    def __init__(self, rotation_vector_deg):
        self.matrix = rotation_matrix(rotation_vector_deg)
        self.rotated = not np.allclose(self.matrix, np.eye(3))

    @property
    def basis(self):
        """The scene's axes in the world (columns of a nested tuple), None if not rotated."""
        return tuple(map(tuple, self.matrix)) if self.rotated else None

    def vector(self, direction):
        """A scene direction (a signed axis record, or a 3-vector) in the world frame."""
        local = direction.vector if hasattr(direction, "vector") else direction
        return self.matrix @ np.asarray(local, dtype=float)

    def stress_field(self, stress):
        """``stress(x)`` (Mandel, at points in the scene's axes) as a field of world points,
        in world components: σ(x) = Q σ_s(Qᵀ x) Qᵀ."""
        if not self.rotated:
            return stress
        Q = self.matrix
        return lambda x: to_mandel(Q @ from_mandel(stress(x @ Q)) @ Q.T)

    def turn_mesh(self, mesh):
        """Rotate the mesh coordinates in place."""
        x = mesh.geometry.x
        x[:, :3] = x[:, :3] @ self.matrix.T
