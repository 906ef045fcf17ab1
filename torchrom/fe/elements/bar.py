"""CBAR/PBAR: linear Euler–Bernoulli beam with an orientation vector.

Hand-written. Element axes (Nastran): x from GA to GB, y in the plane of x and the orientation
vector v (plane 1), z = x × y. Stiffness: axial E A / L, torsion G J / L, bending E I1 in plane 1
(displacement along y, rotation about z) and E I2 in plane 2 (along z, about y); infinite shear
stiffness (Euler–Bernoulli; PBAR K1/K2 are ignored). No offsets, pin flags or I12 (the reader
rejects them). CBAR is **linear**: in a geometrically nonlinear analysis it contributes K u with
its small-rotation stiffness (the model warns once, :class:`LinearElementWarning`).
Mass: lumped (half of (ρA + NSM) L on each end's translations) or consistent (cubic Hermite
transverse, linear axial; no rotary or torsional inertia, as Nastran's CBAR).
"""

from __future__ import annotations

import numpy as np

from ..mesh import BarSet
from .rod import rod_geometry


def bar_frames(bars: BarSet, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lengths (n,) and rotation matrices (n, 3, 3) whose rows are the element x, y, z axes."""
    L, ex = rod_geometry(bars.nodes, xyz)
    vy = bars.v - np.einsum("ni,ni->n", bars.v, ex)[:, None] * ex
    ey = vy / np.linalg.norm(vy, axis=1, keepdims=True)
    ez = np.cross(ex, ey)
    return L, np.stack((ex, ey, ez), axis=1)


def _to_basic(R: np.ndarray, K: np.ndarray) -> np.ndarray:
    n = len(R)
    Tr = np.zeros((n, 12, 12))
    for b in range(4):
        Tr[:, 3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = R
    return Tr.transpose(0, 2, 1) @ K @ Tr


def bar_dofs(nodes: np.ndarray) -> np.ndarray:
    return (nodes[:, :, None] * 6 + np.arange(6)).reshape(len(nodes), 12)


# Hermite cubic beam matrices for (w_A, θ_A, w_B, θ_B) with θ = dw/dx; entry (a, b) carries one
# factor L for each rotation index.
HERMITE_K = np.array([[12, 6, -12, 6], [6, 4, -6, 2], [-12, -6, 12, -6], [6, 2, -6, 4]], float)
HERMITE_M = np.array(
    [[156, 22, 54, -13], [22, 4, 13, -3], [54, 13, 156, -22], [-13, -3, -22, 4]], float
)
# Bending planes in element DOFs: (transverse DOF, rotation DOF, sign of θ relative to dw/dx).
# Plane 1: v along y with θz = +dv/dx; plane 2: w along z with θy = −dw/dx.
PLANES = ((1, 5, 1.0), (2, 4, -1.0))


def _add_hermite(M: np.ndarray, coeff: np.ndarray, pattern: np.ndarray, plane, L) -> None:
    w, th, sgn = plane
    idx = [w, th, w + 6, th + 6]
    scale = np.array([1.0, sgn, 1.0, sgn])
    rot = np.array([0, 1, 0, 1])
    for a in range(4):
        for b in range(4):
            M[:, idx[a], idx[b]] += (
                coeff * pattern[a, b] * scale[a] * scale[b] * L ** (rot[a] + rot[b])
            )


def bar_stiffness_blocks(bars: BarSet, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    L, R = bar_frames(bars, xyz)
    K = np.zeros((len(bars), 12, 12))
    ka = bars.E * bars.A / L
    kt = bars.G * bars.J / L
    for i, j, s in ((0, 0, 1), (0, 6, -1), (6, 0, -1), (6, 6, 1)):
        K[:, i, j] = s * ka
        K[:, i + 3, j + 3] = s * kt
    for plane, EI in zip(PLANES, (bars.E * bars.I1, bars.E * bars.I2)):
        _add_hermite(K, EI / L**3, HERMITE_K, plane, L)
    return bar_dofs(bars.nodes), _to_basic(R, K)


def bar_mass_blocks(bars: BarSet, xyz: np.ndarray, coupled: bool):
    L, R = bar_frames(bars, xyz)
    m = (bars.rho * bars.A + bars.nsm) * L
    M = np.zeros((len(bars), 12, 12))
    if not coupled:
        for i in (0, 1, 2, 6, 7, 8):
            M[:, i, i] = m / 2.0
        return bar_dofs(bars.nodes), M
    for i, j, s in ((0, 0, 2.0), (0, 6, 1.0), (6, 0, 1.0), (6, 6, 2.0)):
        M[:, i, j] = m * s / 6.0
    for plane in PLANES:
        _add_hermite(M, m / 420.0, HERMITE_M, plane, L)
    return bar_dofs(bars.nodes), _to_basic(R, M)
