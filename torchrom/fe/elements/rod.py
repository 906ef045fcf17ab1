"""CROD/CONROD: geometrically nonlinear truss (Green strain) plus linear torsion; rod mass.

Axial: one integration point with dN = [−1/L, 1/L] and C = E A L, so the strain
energy is ½ E A L E11² with E11 = (l² − L²) / (2 L²) — exactly quartic in the displacements.
Torsion (PROD J) is a linear spring G J / L between the rotations about the undeformed axis;
it does not follow large rotations (documented limitation; J = 0 in the Goland model).
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
