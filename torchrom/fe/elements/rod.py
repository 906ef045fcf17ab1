"""CROD/CONROD: geometrically nonlinear truss (Green strain) plus linear torsion; rod mass.

Axial: one integration point with dN = [−1/L, 1/L] and C = E A L, so the strain
energy is ½ E A L E11² with E11 = (l² − L²) / (2 L²) — exactly quartic in the displacements.
Torsion (PROD J) is a linear spring G J / L between the rotations about the axis: about the
undeformed axis with ``FEModel(rotations="small")``, in the co-rotated frame
(:mod:`torchrom.fe.elements.corotational`) with large rotations (J = 0 in the Goland model).
Mass: lumped (half to each end), or MSC Nastran's coupled rod mass (PARAM COUPMASS > 0): along
the axis ρ A L / 12 [5 1; 1 5] — the mean of the lumped and the consistent [2 1; 1 2] / 6 —
and lumped across it. The CROD/CONROD coupled mass is not the consistent one: a 10-bar truss
with COUPMASS (tests/decks/cofe_ten_bar_truss) matches MSC's f06 to 1e-6 with it and is up to 9 %
stiff with the consistent mass in all three directions.
"""

from __future__ import annotations

import numpy as np

from ..mesh import RodSet
from .green import GreenPoints


def rod_geometry(nodes: np.ndarray, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lengths (n,) and unit axes (n, 3) of two-node elements."""
    d = xyz[nodes[:, 1]] - xyz[nodes[:, 0]]
    L = np.linalg.norm(d, axis=1)
    return L, d / L[:, None]


def rod_points(rods: RodSet, xyz: np.ndarray) -> GreenPoints:
    L, _ = rod_geometry(rods.nodes, xyz)
    dN = np.stack((-1.0 / L, 1.0 / L), axis=1)[:, :, None]
    C = (rods.E * rods.A * L)[:, None, None]
    return GreenPoints("CROD", rods.eids.copy(), rods.nodes.copy(), dN, C)


def two_node_dofs(nodes: np.ndarray, offset: int) -> np.ndarray:
    """(n, 6) all-grid indices of three components starting at ``offset`` (0: T, 3: R)."""
    c = np.arange(3) + offset
    return np.concatenate((nodes[:, :1] * 6 + c, nodes[:, 1:2] * 6 + c), axis=1)


def rod_torsion_blocks(rods: RodSet, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    L, e = rod_geometry(rods.nodes, xyz)
    k = rods.G * rods.J / L
    ee = np.einsum("ni,nj->nij", e, e) * k[:, None, None]
    blocks = np.block([[ee, -ee], [-ee, ee]]) if len(rods) else np.zeros((0, 6, 6))
    return two_node_dofs(rods.nodes, 3), blocks


def rod_torsion_local(rods: RodSet, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The rods with torsion stiffness (mask) and their element-system stiffness (n, 12, 12) on
    (t, θ) of both ends, x along the rod: G J / L between the twists θx (the local matrix of
    :func:`rod_torsion_blocks` and of the co-rotational rod torsion)."""
    sel = rods.J > 0
    L, _ = rod_geometry(rods.nodes[sel], xyz)
    k = rods.G[sel] * rods.J[sel] / L
    K = np.zeros((len(k), 12, 12))
    K[:, 3, 3] = K[:, 9, 9] = k
    K[:, 3, 9] = K[:, 9, 3] = -k
    return sel, K


def rod_mass_blocks(rods: RodSet, xyz: np.ndarray, coupled: bool):
    """Translational mass (n, 6, 6) of rods on both grids' translations (basic axes): lumped,
    or with ``coupled`` m / 12 [5 1; 1 5] along the axis e and m / 2 [1 0; 0 1] across it."""
    L, e = rod_geometry(rods.nodes, xyz)
    mass = (rods.rho * rods.A + rods.nsm) * L
    lumped = np.eye(2) / 2.0
    eye = np.broadcast_to(np.eye(3), (len(rods), 3, 3))
    if not coupled:
        blocks = np.einsum("n,ab,nij->naibj", mass, lumped, eye)
    else:
        ee = np.einsum("ni,nj->nij", e, e)
        axial = np.array([[5.0, 1.0], [1.0, 5.0]]) / 12.0
        blocks = (np.einsum("n,ab,nij->naibj", mass, axial, ee)
                  + np.einsum("n,ab,nij->naibj", mass, lumped, eye - ee))
    return two_node_dofs(rods.nodes, 0), blocks.reshape(-1, 6, 6)
