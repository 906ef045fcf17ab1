"""Concentrated masses and scalar springs: CONM2 (rigid mass with offset and inertia), CONM1 (a
6x6 mass matrix), CMASS1/CMASS2 (scalar mass), CELAS1/CELAS2 (scalar spring), CBUSH (six
springs at a point rigidly linked to two grids), GENEL (a general stiffness or flexibility matrix).

CONM2: a rigid body whose CG sits at ``offset`` r from its grid; with the grid's
translation t and rotation θ (small rotations) the CG moves t + θ × r = t − [r×] θ, so

    M = [[ m I,      −m [r×]           ],
         [ m [r×],   I_cg − m [r×][r×] ]]

(I_cg the inertia tensor about the CG; Nastran's CONM2 products of inertia enter with a minus
sign, handled by the reader). CMASS1/2: m (u1 − u2)² / 2 on two scalar DOFs, each a component of
a grid in its displacement system (grid 2 may be ground); CELAS1/2 the same with k.
"""

from __future__ import annotations

import numpy as np

from .mesh import Bush, GeneralElement, MassMatrix6, PointMass, ScalarMass, ScalarSpring


def skew(r: np.ndarray) -> np.ndarray:
    """[r×] such that [r×] a = r × a."""
    return np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])


def rigid_links(w: np.ndarray) -> np.ndarray:
    """(n, 6, 6) maps of a grid's (t, θ) (basic) onto the (t, θ) of points at w (n, 3) from it,
    small rotations: t + θ × w = t − [w×] θ, θ unchanged (Nastran's rigid offsets and links)."""
    w = np.asarray(w, dtype=float).reshape(-1, 3)
    A = np.tile(np.eye(6), (len(w), 1, 1))
    # −[w×] for every point at once
    A[:, 0, 4], A[:, 0, 5], A[:, 1, 5] = w[:, 2], -w[:, 1], w[:, 0]
    A[:, 1, 3], A[:, 2, 3], A[:, 2, 4] = -w[:, 2], w[:, 1], -w[:, 0]
    return A


def conm2_blocks(masses: list[PointMass]) -> tuple[np.ndarray, np.ndarray]:
    dofs = np.zeros((len(masses), 6), dtype=int)
    blocks = np.zeros((len(masses), 6, 6))
    for k, pm in enumerate(masses):
        S = skew(np.asarray(pm.offset, dtype=float))
        m = pm.mass
        blocks[k, :3, :3] = m * np.eye(3)
        blocks[k, :3, 3:] = -m * S
        blocks[k, 3:, :3] = m * S
        blocks[k, 3:, 3:] = np.asarray(pm.inertia, dtype=float) - m * S @ S
        dofs[k] = pm.grid * 6 + np.arange(6)
    return dofs, blocks


def scalar_blocks(items, cd_axes: np.ndarray, values) -> tuple[np.ndarray, np.ndarray]:
    """(n, 6) DOFs (both grids' translation or rotation triplets) and (n, 6, 6) blocks of
    value · a aᵀ, a picking (grid1, comp1) minus (grid2, comp2) in basic axes."""
    dofs = np.zeros((len(items), 6), dtype=int)
    blocks = np.zeros((len(items), 6, 6))
    for k, (sm, value) in enumerate(zip(items, values)):
        a = np.zeros(6)
        a[:3] = cd_axes[sm.grid1][:, sm.comp1 % 3]
        base1 = sm.grid1 * 6 + 3 * (sm.comp1 // 3)
        if sm.grid2 >= 0:
            a[3:] = -cd_axes[sm.grid2][:, sm.comp2 % 3]
            base2 = sm.grid2 * 6 + 3 * (sm.comp2 // 3)
        else:
            base2 = base1  # ground: the second half of ``a`` is zero
        dofs[k] = np.concatenate((base1 + np.arange(3), base2 + np.arange(3)))
        blocks[k] = value * np.outer(a, a)
    return dofs, blocks


def cmass2_blocks(masses: list[ScalarMass], cd_axes: np.ndarray):
    """Scalar masses (CMASS1/CMASS2)."""
    return scalar_blocks(masses, cd_axes, [m.mass for m in masses])


def celas_blocks(springs: list[ScalarSpring], cd_axes: np.ndarray):
    """Scalar springs (CELAS1/CELAS2)."""
    return scalar_blocks(springs, cd_axes, [s.stiffness for s in springs])


def conm1_blocks(masses: list[MassMatrix6]) -> tuple[np.ndarray, np.ndarray]:
    dofs = np.array([m.grid * 6 + np.arange(6) for m in masses], dtype=int).reshape(-1, 6)
    blocks = np.array([m.matrix for m in masses], dtype=float).reshape(-1, 6, 6)
    return dofs, blocks


def bush_blocks(bushes: list[Bush]) -> tuple[np.ndarray, np.ndarray]:
    """CBUSH: k (u_PA − u_PB)² / 2 per axis of its element system, u_PA and u_PB the motions
    of the spring point carried rigidly by grid A and by grid B (MSC QRG CBUSH: the spring sits
    at S on the line GA-GB, rigidly connected to both grids); (n, 12, 12) on both grids' six
    DOFs (basic); a grounded bush acts on grid A alone."""
    dofs = np.zeros((len(bushes), 12), dtype=int)
    blocks = np.zeros((len(bushes), 12, 12))
    for k, b in enumerate(bushes):
        R = np.zeros((6, 6))
        R[:3, :3] = R[3:, 3:] = b.axes
        K6 = R @ np.diag(b.stiffness) @ R.T
        g2 = b.grid1 if b.grid2 < 0 else b.grid2
        dofs[k] = np.concatenate((b.grid1 * 6 + np.arange(6), g2 * 6 + np.arange(6)))
        A1, A2 = rigid_links(np.array([b.arm1, b.arm2]))
        if b.grid2 < 0:
            blocks[k, :6, :6] = A1.T @ K6 @ A1
        else:
            D = np.hstack((A1, -A2))  # u_PA − u_PB from the two grids' DOFs
            blocks[k] = D.T @ K6 @ D
    return dofs, blocks


def genel_stiffness(K_ii: np.ndarray, S: np.ndarray | None) -> np.ndarray:
    """Stiffness of a GENEL on (u_i, u_d) from the stiffness K_ii of its independent DOFs (the
    inverse of Z for a flexibility GENEL) and S, u_i = S u_d in a rigid-body motion (MSC QRG,
    GENEL, remark 4):

        K = [[ K_ii,      −K_ii S     ],
             [ −Sᵀ K_ii,  Sᵀ K_ii S   ]],

    so that K [S; I] = 0: the element carries no load in a rigid-body motion."""
    if S is None:
        return K_ii
    KS = K_ii @ S
    return np.block([[K_ii, -KS], [-KS.T, S.T @ KS]])


def genel_blocks(elements: list[GeneralElement], cd_axes: np.ndarray):
    """(dofs, K) pairs, one per GENEL: its n scalar DOFs mapped to the 3n basic DOFs of their
    translation or rotation triplets, K_basic = Aᵀ K A."""
    parts = []
    for g in elements:
        n = len(g.dofs)
        A = np.zeros((n, 3 * n))
        dofs = np.zeros(3 * n, dtype=int)
        for i, (row, comp) in enumerate(g.dofs):
            A[i, 3 * i: 3 * i + 3] = cd_axes[row][:, comp % 3]
            dofs[3 * i: 3 * i + 3] = row * 6 + 3 * (comp // 3) + np.arange(3)
        parts.append((dofs[None], (A.T @ g.K @ A)[None]))
    return parts
