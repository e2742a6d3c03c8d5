"""The one 6-component convention for symmetric tensors: Mandel notation.

A symmetric tensor ``A`` is stored as

    [A11, A22, A33, sqrt2*A23, sqrt2*A13, sqrt2*A12]

for stress and strain alike, so ``A:B`` is the dot product of the two
6-vectors and a fourth-order tensor with minor symmetries is a 6x6 matrix
whose major symmetry is plain matrix symmetry. Stress is positive in tension.
"""
import numpy as np

SQRT2 = np.sqrt(2.0)

# Index pairs of the six components, in storage order.
PAIRS = ((0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1))

#: Mandel vector of the second-order identity.
IDENTITY = np.array([1.0, 1.0, 1.0, 0.0, 0.0, 0.0])
#: Volumetric and deviatoric projectors: P_vol = m m^T / 3, P_dev = I - P_vol.
P_VOL = np.outer(IDENTITY, IDENTITY) / 3.0
P_DEV = np.eye(6) - P_VOL


def to_mandel(a):
    """(..., 3, 3) symmetric arrays -> (..., 6) Mandel vectors."""
    a = np.asarray(a)
    return np.stack(
        [a[..., 0, 0], a[..., 1, 1], a[..., 2, 2],
         SQRT2 * a[..., 1, 2], SQRT2 * a[..., 0, 2], SQRT2 * a[..., 0, 1]],
        axis=-1,
    )


def from_mandel(v):
    """(..., 6) Mandel vectors -> (..., 3, 3) symmetric arrays."""
    v = np.asarray(v)
    out = np.empty(v.shape[:-1] + (3, 3), dtype=v.dtype)
    for k, (i, j) in enumerate(PAIRS):
        scale = 1.0 if i == j else 1.0 / SQRT2
        out[..., i, j] = out[..., j, i] = scale * v[..., k]
    return out


def ufl_mandel(a):
    """UFL symmetric 3x3 tensor -> UFL Mandel 6-vector (same order as above)."""
    import ufl   # here, not above: the models and the records layer load no UFL
    s = SQRT2
    return ufl.as_vector([a[0, 0], a[1, 1], a[2, 2], s * a[1, 2], s * a[0, 2], s * a[0, 1]])


def ufl_from_mandel(v):
    """UFL Mandel 6-vector -> UFL symmetric 3x3 tensor."""
    import ufl
    r = 1.0 / SQRT2
    return ufl.as_matrix([[v[0], r * v[5], r * v[4]],
                          [r * v[5], v[1], r * v[3]],
                          [r * v[4], r * v[3], v[2]]])


def trace(v):
    """Trace of (..., 6) Mandel vectors."""
    return v[..., 0] + v[..., 1] + v[..., 2]


def deviator(v):
    """Deviatoric part of (..., 6) Mandel vectors."""
    d = v.copy()
    d[..., :3] -= trace(v)[..., None] / 3.0
    return d


def rotation_matrix(vector_deg):
    """Rotation by ``|v|`` degrees about v (Rodrigues' formula)."""
    v = np.radians(np.asarray(vector_deg, dtype=float))
    angle = np.linalg.norm(v)
    if angle == 0.0:
        return np.eye(3)
    k = v / angle
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * K @ K
