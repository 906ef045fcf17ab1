"""CQUAD4/CTRIA3 with ZOFFS: the shell's reference plane offset from the plane of its grids.

MSC Nastran Quick Reference Guide (CQUAD4, CTRIA3, ZOFFS): the reference plane lies at z0 = ZOFFS
along the element normal. Each grid is tied to its point of the reference plane by a rigid
offset (small rotations), u_ref = u − [z0 n]× θ, and the element's matrices are transformed
K = Tᵀ K_ref T: the membrane–bending coupling B = z0 A and D + z0² A of plate theory (Reddy,
*Mechanics of Laminated Composite Plates and Shells*, §3.3), A integrated by the membrane's own
rule. Choices: **linear only** (the model refuses nonlinear analyses of a deck with ZOFFS);
the drilling spring stays at the grids (a stabiliser, not part of A); the mass sits on the
reference plane (M = Tᵀ M_ref T, adding the rotary inertia m z0²); loads stay at the grids (a
PLOAD4 with an in-plane direction gains no moment z0 × F).
"""

from __future__ import annotations

import numpy as np

from ..mass import rigid_links
from ..mesh import QuadSet, TriaSet
from .green import GreenKernel
from .quad4 import area_mass_blocks, bending_blocks, membrane_points, quad_dofs, quad_frames
from .tria3 import tria_bending_blocks, tria_dofs, tria_frames, tria_mass_blocks, tria_points


def offset_transform(normal: np.ndarray, z0: np.ndarray, nn: int) -> np.ndarray:
    """T (n, 6nn, 6nn) from the grids' six DOFs to the reference plane's: per grid the rigid
    link to the point z0 n from it (:func:`~torchrom.fe.mass.rigid_links`)."""
    block = rigid_links(z0[:, None] * normal)
    T = np.zeros((len(z0), 6 * nn, 6 * nn))
    for a in range(nn):
        T[:, 6 * a : 6 * a + 6, 6 * a : 6 * a + 6] = block
    return T


def _translations_to_six(blocks: np.ndarray, nn: int) -> np.ndarray:
    """Blocks on the translations (n, 3nn, 3nn) placed on six DOFs per grid (n, 6nn, 6nn)."""
    idx = (6 * np.arange(nn)[:, None] + np.arange(3)).reshape(-1)
    out = np.zeros((len(blocks), 6 * nn, 6 * nn))
    out[:, idx[:, None], idx[None, :]] = blocks
    return out


def _membrane_linear(points, xyz: np.ndarray, n: int, nn: int) -> np.ndarray:
    """The Green-strain membrane's stiffness at u = 0 (n, 6nn, 6nn), summed over each element's
    integration points (``points`` lists them point by point, all elements each time)."""
    per_point = GreenKernel(points, xyz).point_matrices(np.zeros(6 * len(xyz)), geometric=0.0)
    return _translations_to_six(per_point.reshape(-1, n, 3 * nn, 3 * nn).sum(axis=0), nn)


def _bending_and_drilling(shells, xyz, drilling, blocks_of, nn):
    """(bending, drilling) stiffness (n, 6nn, 6nn) of all elements (zero where membrane only).

    The element modules return bending + drilling together; the drilling part is their
    difference with drilling = 0, so that only the bending is moved to the reference plane."""
    n = len(shells)
    sel = shells.bend_E > 0
    bend, drill = np.zeros((n, 6 * nn, 6 * nn)), np.zeros((n, 6 * nn, 6 * nn))
    if sel.any():
        bend[sel] = blocks_of(shells, xyz, 0.0)[1]
        drill[sel] = blocks_of(shells, xyz, drilling)[1] - bend[sel]
    return bend, drill


def _normals(shells, xyz) -> np.ndarray:
    X = xyz[shells.nodes]
    return (quad_frames(X)[0] if isinstance(shells, QuadSet) else tria_frames(X)[0])[:, 2]


def offset_stiffness_blocks(shells: QuadSet | TriaSet, xyz: np.ndarray, drilling: float = 1e-4):
    """(dofs, K) of offset quads or triangles: membrane and bending on the reference plane,
    drilling at the grids, on six DOFs per grid (basic)."""
    quad = isinstance(shells, QuadSet)
    nn, n = (4 if quad else 3), len(shells)
    points = membrane_points(shells, xyz) if quad else tria_points(shells, xyz)
    blocks_of = bending_blocks if quad else tria_bending_blocks
    K_ref = _membrane_linear(points, xyz, n, nn)
    bend, drill = _bending_and_drilling(shells, xyz, drilling, blocks_of, nn)
    T = offset_transform(_normals(shells, xyz), shells.zoffs, nn)
    K = T.transpose(0, 2, 1) @ (K_ref + bend) @ T + drill
    return (quad_dofs if quad else tria_dofs)(shells.nodes), K


def offset_mass_blocks(shells: QuadSet | TriaSet, xyz: np.ndarray, coupled: bool):
    """(dofs, M) of offset quads or triangles: the translational mass on the reference plane
    (ρ t + NSM per area, lumped or consistent as without offset), on six DOFs per grid."""
    quad = isinstance(shells, QuadSet)
    nn = 4 if quad else 3
    if quad:
        M3 = area_mass_blocks(xyz, shells.nodes, shells.rho * shells.t + shells.nsm, coupled)[1]
    else:
        M3 = tria_mass_blocks(shells, xyz, coupled)[1]
    T = offset_transform(_normals(shells, xyz), shells.zoffs, nn)
    M = T.transpose(0, 2, 1) @ _translations_to_six(M3, nn) @ T
    return (quad_dofs if quad else tria_dofs)(shells.nodes), M
