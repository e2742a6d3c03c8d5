"""The frame of a scene: an optional rotation of the whole problem (a frame-indifference check).

The rotation is applied once, before any part is built: to the mesh
coordinates here, and to every direction the parts read from the records
(:meth:`Frame.vector`). Results along the loading direction must not change.
"""
import numpy as np

from ..tensors import rotation_matrix


class Frame:
    def __init__(self, rotation_vector_deg):
        self.matrix = rotation_matrix(rotation_vector_deg)
        self.rotated = not np.allclose(self.matrix, np.eye(3))

    def vector(self, direction):
        """A scene direction (a signed axis record, or a 3-vector) in the world frame."""
        local = direction.vector if hasattr(direction, "vector") else direction
        return self.matrix @ np.asarray(local, dtype=float)

    def turn_mesh(self, mesh):
        """Rotate the mesh coordinates in place."""
        x = mesh.geometry.x
        x[:, :3] = x[:, :3] @ self.matrix.T
