"""CBAR/CBEAM: linear (Timoshenko) beam with an orientation vector.

Hand-written. Element axes (Nastran): x from GA to GB, y in the plane of x and the orientation
vector v (plane 1), z = x × y. Stiffness: axial E A / L, torsion G J / L, bending E I1 in plane 1
(displacement along y, rotation about z) and E I2 in plane 2 (along z, about y), with shear
flexibility when the shear area factor K of the plane is non-zero: the exact two-node Timoshenko
stiffness (Przemieniecki, Theory of Matrix Structural Analysis, Eq. 5.116),

    k = E I / ((1 + Φ) L³) [[12, 6L, −12, 6L], [6L, (4+Φ)L², −6L, (2−Φ)L²], ...],
    Φ = 12 E I / (K G A L²),

Φ = 0 (Euler–Bernoulli) when K = 0 (PBAR K1/K2 blank). No offsets, pin flags or I12 (the reader
rejects them). CBAR/CBEAM are **linear**: in a geometrically nonlinear analysis they contribute
K u with their small-rotation stiffness (the model warns once, :class:`LinearElementWarning`).
Mass: lumped (half of (ρA + NSM) L on each end's translations, and for CBEAM half of
ρ (I1 + I2) L on each end's torsional rotation, as Nastran's CBEAM) or consistent (cubic
Hermite transverse, linear axial and torsional; no rotary inertia, as Nastran's CBAR).
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
    for plane, EI, kshear in zip(PLANES, (bars.E * bars.I1, bars.E * bars.I2),
                                 (bars.k1, bars.k2)):
        GAs = kshear * bars.G * bars.A
        phi = np.divide(12.0 * EI, GAs * L**2, out=np.zeros_like(L), where=GAs > 0)
        _add_hermite(K, EI / ((1.0 + phi) * L**3), HERMITE_K, plane, L)
        # Timoshenko correction of the rotation-rotation terms: (4, 2) → (4 + Φ, 2 − Φ)
        w, th, sgn = plane
        c = EI / ((1.0 + phi) * L**3) * phi * L**2
        for a, b, s in ((th, th, 1.0), (th + 6, th + 6, 1.0), (th, th + 6, -1.0),
                        (th + 6, th, -1.0)):
            K[:, a, b] += s * c
    return bar_dofs(bars.nodes), _to_basic(R, K)


def bar_mass_blocks(bars: BarSet, xyz: np.ndarray, coupled: bool):
    L, R = bar_frames(bars, xyz)
    m = (bars.rho * bars.A + bars.nsm) * L
    ip = bars.polar * L  # torsional inertia of the element (CBEAM)
    M = np.zeros((len(bars), 12, 12))
    if not coupled:
        for i in (0, 1, 2, 6, 7, 8):
            M[:, i, i] = m / 2.0
        M[:, 3, 3] = M[:, 9, 9] = ip / 2.0
        return bar_dofs(bars.nodes), (_to_basic(R, M) if np.any(ip) else M)
    for i, j, s in ((0, 0, 2.0), (0, 6, 1.0), (6, 0, 1.0), (6, 6, 2.0)):
        M[:, i, j] = m * s / 6.0
        M[:, i + 3, j + 3] = ip * s / 6.0
    for plane in PLANES:
        _add_hermite(M, m / 420.0, HERMITE_M, plane, L)
    return bar_dofs(bars.nodes), _to_basic(R, M)
