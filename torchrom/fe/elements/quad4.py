"""CQUAD4/PSHELL: nonlinear membrane, linear MITC4 plate bending, drilling spring, mass, pressure.

Written here (no library). Choices that change numbers:

- **Membrane**: bilinear isoparametric, full Green–Lagrange strain (in-plane stretching from
  out-of-plane deflection included), St Venant–Kirchhoff plane stress; normal strains at 2×2
  Gauss points, shear at the centre (no parasitic shear in in-plane bending, no zero-energy
  mode). Internal forces exactly cubic in the displacements.
- **Bending**: MITC4 (Bathe–Dvorkin 1985), linear in the element's axes (large rotations through
  the co-rotational layer, :mod:`torchrom.fe.elements.corotational`); transverse shear from
  PSHELL MID3 × TS/T, else MID2's with 5/6; plus MacNeal's residual bending flexibility ℓ²/(12 D)
  on the constant part of the shear (Comput. Struct. 8, 1978; the QUAD4 of MSC Nastran;
  :func:`residual_bending_shear`), without which curved shells are too stiff.
- **Drilling**: a small penalty k Σ (θz_n − ω)², k = ``drilling`` · G t A, only with bending.
- **Mass**: ρ t + NSM per unit area on the translations, consistent or lumped; no rotary inertia.
- **Pressure**: consistent nodal forces ∫ p N_a n dA, n by the G1-G2-G3 right-hand rule.
"""

from __future__ import annotations

import numpy as np

from ..mesh import QuadSet
from .green import GreenPoints

XI = np.array([-1.0, 1.0, 1.0, -1.0])
ETA = np.array([-1.0, -1.0, 1.0, 1.0])
G2 = 1.0 / np.sqrt(3.0)
GAUSS_2x2 = [(-G2, -G2), (G2, -G2), (G2, G2), (-G2, G2)]


def shape(xi: float, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """Bilinear N (4,) and natural derivatives (2, 4) at (ξ, η)."""
    N = 0.25 * (1 + xi * XI) * (1 + eta * ETA)
    dnat = np.stack((0.25 * XI * (1 + eta * ETA), 0.25 * ETA * (1 + xi * XI)))
    return N, dnat


def quad_frames(X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local frames and in-plane coordinates of quads.

    Returns ``R (n, 3, 3)`` whose rows are e1, e2, e3 (e3 the normal from the diagonals,
    G1-G2-G3 right-hand rule; e1 along the mean of the 1-2 and 4-3 edges) and ``xy (n, 4, 2)``
    the node coordinates projected on the mean plane, relative to the centroid.
    """
    n3 = np.cross(X[:, 2] - X[:, 0], X[:, 3] - X[:, 1])
    e3 = n3 / np.linalg.norm(n3, axis=1, keepdims=True)
    a = (X[:, 1] + X[:, 2]) - (X[:, 0] + X[:, 3])
    a = a - np.einsum("ni,ni->n", a, e3)[:, None] * e3
    e1 = a / np.linalg.norm(a, axis=1, keepdims=True)
    e2 = np.cross(e3, e1)
    R = np.stack((e1, e2, e3), axis=1)
    c = X.mean(axis=1, keepdims=True)
    xy = np.einsum("nai,nji->naj", X - c, R)[:, :, :2]
    return R, xy


def inv2(J: np.ndarray, det: np.ndarray) -> np.ndarray:
    """Inverses of (n, 2, 2) matrices by the explicit formula (batched LAPACK is far slower)."""
    inv = np.empty_like(J)
    inv[:, 0, 0] = J[:, 1, 1]
    inv[:, 1, 1] = J[:, 0, 0]
    inv[:, 0, 1] = -J[:, 0, 1]
    inv[:, 1, 0] = -J[:, 1, 0]
    return inv / det[:, None, None]


def jacobian(xy: np.ndarray, dnat: np.ndarray):
    """J (n, 2, 2) with J[r, i] = ∂x_i/∂r, det J (n,), and ∂N/∂x (n, 4, 2)."""
    J = np.einsum("ra,nai->nri", dnat, xy)
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    inv = inv2(J, det)
    dxy = np.einsum("nir,ra->nai", inv, dnat)
    return J, det, dxy


def quad_area(xyz: np.ndarray, nodes: np.ndarray) -> np.ndarray:
    _, xy = quad_frames(xyz[nodes])
    return 4.0 * jacobian(xy, shape(0.0, 0.0)[1])[1]


def plane_stress(E, nu, G) -> np.ndarray:
    """(n, 3, 3) isotropic plane-stress matrix in Voigt [E11, E22, 2E12] (Nastran MAT1: G kept)."""
    c = E / (1.0 - nu**2)
    D = np.zeros((len(E), 3, 3))
    D[:, 0, 0] = D[:, 1, 1] = c
    D[:, 0, 1] = D[:, 1, 0] = c * nu
    D[:, 2, 2] = G
    return D


def membrane_points(quads: QuadSet, xyz: np.ndarray) -> GreenPoints:
    """Five points per quad: 2×2 Gauss for the normal strains, the centre for the shear."""
    _, xy = quad_frames(xyz[quads.nodes])
    D = plane_stress(quads.E, quads.nu, quads.G)
    lam = quads.laminated
    if lam.any():  # PCOMP: the laminate's A per unit thickness
        D[lam] = quads.lam_A[lam] / quads.t[lam, None, None]
    normal = D.copy()
    normal[:, 2, :] = normal[:, :, 2] = 0.0
    shear = np.zeros_like(D)
    shear[:, 2, 2] = D[:, 2, 2]
    dNs, Cs = [], []
    for xi, eta in GAUSS_2x2:
        _, det, dxy = jacobian(xy, shape(xi, eta)[1])
        dNs.append(dxy)
        Cs.append(normal * (det * quads.t)[:, None, None])
    _, det0, dxy0 = jacobian(xy, shape(0.0, 0.0)[1])
    dNs.append(dxy0)
    Cs.append(shear * (4.0 * det0 * quads.t)[:, None, None])
    n = len(quads)
    return GreenPoints(
        "CQUAD4",
        np.tile(quads.eids, 5),
        np.tile(quads.nodes, (5, 1)),
        np.concatenate(dNs).reshape(5 * n, 4, 2),
        np.concatenate(Cs).reshape(5 * n, 3, 3),
    )


def quad_dofs(nodes: np.ndarray) -> np.ndarray:
    """(n, 24) all-grid DOF indices of the six components of four nodes."""
    return (nodes[:, :, None] * 6 + np.arange(6)).reshape(len(nodes), 24)


def bending_matrix(Eb, nub, t, lam_D=None) -> np.ndarray:
    """Isotropic plate bending stiffness E t³/(12(1 − ν²)) [[1, ν, 0], [ν, 1, 0], [0, 0, (1−ν)/2]]
    (n, 3, 3), or the laminate's D where given (non-zero)."""
    Db = np.zeros((len(t), 3, 3))
    d = Eb * t**3 / (12.0 * (1.0 - nub**2))
    Db[:, 0, 0] = Db[:, 1, 1] = d
    Db[:, 0, 1] = Db[:, 1, 0] = d * nub
    Db[:, 2, 2] = d * (1.0 - nub) / 2.0
    if lam_D is not None:
        lam = np.any(lam_D != 0.0, axis=(1, 2))
        Db[lam] = lam_D[lam]
    return Db


def residual_bending_shear(xy, Db, ds) -> np.ndarray:
    """Transverse shear stiffness (n, 2, 2) of the constant part of the shear, with MacNeal's
    residual bending flexibility added to the shear flexibility.

    A bilinear rotation field bends with a curvature that cannot vary along its own direction,
    so under a constant shear (a linearly varying moment) the element misses the bending energy
    of that variation. For a beam of length ℓ the missing flexibility is exactly ℓ²/(12 EI)
    (MacNeal 1978, 1982), which added to the shear flexibility makes a linear Timoshenko element
    exact. Here in each natural direction r of the quad: ℓ_r = 2 |∂x/∂r| at the centre (the
    distance between opposite edge midpoints), s_r its unit vector and D_r = T_rᵀ D T_r the
    bending stiffness for a unit curvature along s_r (T_r = (s_x², s_y², 2 s_x s_y)), so that the
    flexibility is F = I / ds + Σ_r ℓ_r² / (12 D_r) s_r s_rᵀ and the stiffness
    ds (I + ds Σ_r …)⁻¹ (no division by ds, which may be zero). For a rectangle this is
    MacNeal's beam result along each side; for other shapes it is our generalisation.
    """
    J0 = jacobian(xy, shape(0.0, 0.0)[1])[0]
    extra = np.zeros((len(xy), 2, 2))
    for r in range(2):
        v = J0[:, r, :]
        half = np.linalg.norm(v, axis=1)
        s = v / half[:, None]
        T = np.stack((s[:, 0] ** 2, s[:, 1] ** 2, 2.0 * s[:, 0] * s[:, 1]), axis=1)
        D_r = np.einsum("ni,nij,nj->n", T, Db, T)
        extra += ((2.0 * half) ** 2 / (12.0 * D_r))[:, None, None] * np.einsum("ni,nj->nij", s, s)
    return ds[:, None, None] * np.linalg.inv(np.eye(2) + ds[:, None, None] * extra)


def _residual_bending_correction(xy, Db, ds, g_xi0, g_eta0) -> np.ndarray:
    """(n, 12, 12) stiffness that replaces the shear stiffness ds of the constant part of the
    MITC4 shear (the covariant shears at the centre, mapped to x, y) by
    :func:`residual_bending_shear`'s: A B0ᵀ (C − ds I) B0. The linear part of the shear field
    keeps ds (for a parallelogram the two parts are orthogonal over the element)."""
    J0, det0, _ = jacobian(xy, shape(0.0, 0.0)[1])
    B0 = np.einsum("nir,nrk->nik", inv2(J0, det0), np.stack((g_xi0, g_eta0), axis=1))
    C = residual_bending_shear(xy, Db, ds) - ds[:, None, None] * np.eye(2)
    return np.einsum("nvk,nvw,nwl->nkl", B0, C, B0) * (4.0 * det0)[:, None, None]


def _mitc4_local(xy, Eb, nub, t, Gs, lam_D=None, lam_shear=None) -> np.ndarray:
    """MITC4 bending + transverse shear stiffness (n, 12, 12), DOFs (w, θx, θy) per node."""
    n = xy.shape[0]
    Db = bending_matrix(Eb, nub, t, lam_D)
    ds = Gs * t
    if lam_shear is not None:
        ds = np.where(lam_shear > 0, lam_shear, ds)

    def covariant_shear(r: int, xi: float, eta: float) -> np.ndarray:
        # γ_r = ∂w/∂r + βx ∂x/∂r + βy ∂y/∂r with βx = θy, βy = −θx, at a tying point.
        N, dnat = shape(xi, eta)
        J = jacobian(xy, dnat)[0]
        row = np.zeros((n, 12))
        row[:, 0::3] = dnat[r]
        row[:, 2::3] = N[None, :] * J[:, r, 0:1]
        row[:, 1::3] = -N[None, :] * J[:, r, 1:2]
        return row

    gA, gC = covariant_shear(0, 0.0, 1.0), covariant_shear(0, 0.0, -1.0)
    gD, gB = covariant_shear(1, 1.0, 0.0), covariant_shear(1, -1.0, 0.0)
    K = _residual_bending_correction(xy, Db, ds, 0.5 * (gA + gC), 0.5 * (gD + gB))
    for xi, eta in GAUSS_2x2:
        _, dnat = shape(xi, eta)
        J, det, dxy = jacobian(xy, dnat)
        Bb = np.zeros((n, 3, 12))
        Bb[:, 0, 2::3] = dxy[:, :, 0]
        Bb[:, 1, 1::3] = -dxy[:, :, 1]
        Bb[:, 2, 2::3] = dxy[:, :, 1]
        Bb[:, 2, 1::3] = -dxy[:, :, 0]
        g_xi = 0.5 * (1 + eta) * gA + 0.5 * (1 - eta) * gC
        g_eta = 0.5 * (1 + xi) * gD + 0.5 * (1 - xi) * gB
        Bs = np.einsum("nir,nrk->nik", inv2(J, det), np.stack((g_xi, g_eta), axis=1))
        K += (Bb.transpose(0, 2, 1) @ Db @ Bb) * det[:, None, None]
        K += np.einsum("nvk,nvl->nkl", Bs, Bs) * (ds * det)[:, None, None]
    return K


def plate_on_six(R: np.ndarray, Kl: np.ndarray, dN0: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Plate bending (Kl on (w, θx, θy) per node) plus the drilling penalty
    k Σ_a (θz_a − ω)², ω = ½ Σ_b (∂N_b/∂x v_b − ∂N_b/∂y u_b) the membrane rotation at the centre
    (``dN0`` (n, nn, 2)), on six DOFs per node in the axes whose rows are ``R`` (n, 3, 3):
    the element's own axes (R = I) give the local matrix of the co-rotational form, its rows in
    basic the linear element's blocks. Shared by the quad and the triangle."""
    n, nn = dN0.shape[:2]
    L = np.zeros((n, 3 * nn, 6 * nn))
    for a in range(nn):
        L[:, 3 * a, 6 * a : 6 * a + 3] = R[:, 2]
        L[:, 3 * a + 1, 6 * a + 3 : 6 * a + 6] = R[:, 0]
        L[:, 3 * a + 2, 6 * a + 3 : 6 * a + 6] = R[:, 1]
    K = L.transpose(0, 2, 1) @ Kl @ L
    omega = np.zeros((n, 6 * nn))
    for b in range(nn):
        omega[:, 6 * b : 6 * b + 3] = 0.5 * (dN0[:, b, 0:1] * R[:, 1] - dN0[:, b, 1:2] * R[:, 0])
    for a in range(nn):
        r = -omega.copy()
        r[:, 6 * a + 3 : 6 * a + 6] += R[:, 2]
        K += k[:, None, None] * r[:, :, None] * r[:, None, :]
    return K


def plate_parts(quads: QuadSet, xyz: np.ndarray, drilling: float = 1e-4):
    """The quads with bending (boolean mask), their axes R (n, 3, 3, rows e1, e2, e3), the MITC4
    matrix (n, 12, 12), ∂N/∂(x, y) at the centre (n, 4, 2) and the drilling stiffness k (n,)
    = ``drilling`` · G t A: the arguments of :func:`plate_on_six`."""
    sel = quads.bend_E > 0
    R, xy = quad_frames(xyz[quads.nodes[sel]])
    t = quads.t[sel]
    Kl = _mitc4_local(xy, quads.bend_E[sel], quads.bend_nu[sel], t, quads.shear_G[sel],
                      quads.lam_D[sel], quads.lam_shear[sel])
    _, det0, dxy0 = jacobian(xy, shape(0.0, 0.0)[1])
    return sel, R, Kl, dxy0, drilling * quads.G[sel] * t * 4.0 * det0


def bending_blocks(
    quads: QuadSet, xyz: np.ndarray, drilling: float = 1e-4
) -> tuple[np.ndarray, np.ndarray]:
    """Linear bending + drilling stiffness of quads with bending, in basic 6-DOF blocks."""
    sel = quads.bend_E > 0
    if not sel.any():
        return np.zeros((0, 24), dtype=int), np.zeros((0, 24, 24))
    sel, R, Kl, dxy0, k = plate_parts(quads, xyz, drilling)
    return quad_dofs(quads.nodes[sel]), plate_on_six(R, Kl, dxy0, k)


def area_mass_pattern(xyz: np.ndarray, nodes: np.ndarray, coupled: bool) -> np.ndarray:
    """∫ N_a N_b dA (n, 4, 4), or its row-sum lumping on the diagonal."""
    _, xy = quad_frames(xyz[nodes])
    M = np.zeros((len(nodes), 4, 4))
    for xi, eta in GAUSS_2x2:
        N, dnat = shape(xi, eta)
        det = jacobian(xy, dnat)[1]
        M += det[:, None, None] * np.outer(N, N)[None]
    if not coupled:
        M = np.einsum("na,ab->nab", M.sum(axis=2), np.eye(4))
    return M


def area_mass_blocks(
    xyz: np.ndarray, nodes: np.ndarray, mass_per_area: np.ndarray, coupled: bool
) -> tuple[np.ndarray, np.ndarray]:
    """Translational mass blocks (n, 12, 12) of four-node surface elements."""
    pat = area_mass_pattern(xyz, nodes, coupled) * mass_per_area[:, None, None]
    blocks = np.einsum("nab,ij->naibj", pat, np.eye(3)).reshape(-1, 12, 12)
    dofs = (nodes[:, :, None] * 6 + np.arange(3)).reshape(len(nodes), 12)
    return dofs, blocks


def pressure_forces(
    xyz: np.ndarray,
    nodes: np.ndarray,
    pressure,
    corner_pressures: np.ndarray | None = None,
    direction: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Consistent nodal forces (n, 12) of a pressure on four-node faces, and their DOFs (n, 12).

    ``pressure`` is a float, an array (n,) or a callable ``p(x, y)`` evaluated at the Gauss points
    (basic x, y); ``corner_pressures (n, 4)`` interpolates bilinearly instead (PLOAD4). The load
    acts along ``direction (n, 3)`` if given (unit vectors), else along the element normal.
    """
    X = xyz[nodes]
    R, xy = quad_frames(X)
    n = len(nodes)
    dirs = R[:, 2] if direction is None else direction
    F = np.zeros((n, 4, 3))
    for xi, eta in GAUSS_2x2:
        N, dnat = shape(xi, eta)
        det = jacobian(xy, dnat)[1]
        if corner_pressures is not None:
            p = corner_pressures @ N
        elif callable(pressure):
            pos = np.einsum("a,nai->ni", N, X)
            p = np.asarray(pressure(pos[:, 0], pos[:, 1]), dtype=float) * np.ones(n)
        else:
            p = np.asarray(pressure, dtype=float) * np.ones(n)
        F += np.einsum("n,a,ni->nai", p * det, N, dirs)
    dofs = (nodes[:, :, None] * 6 + np.arange(3)).reshape(n, 12)
    return dofs, F.reshape(n, 12)
