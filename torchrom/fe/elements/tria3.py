"""CTRIA3/PSHELL: nonlinear CST membrane, linear DKT plate bending, drilling spring, mass.

Written here (no library), the triangular companion of :mod:`torchrom.fe.elements.quad4`:

- **Membrane**: constant-strain triangle with the full Green–Lagrange strain of the 3-D
  displacement field (one integration point, :class:`~torchrom.fe.elements.green.GreenPoints`),
  so its internal forces are exactly cubic like the quad's.
- **Bending**: Discrete Kirchhoff Triangle (Batoz, Bathe & Ho, IJNME 15, 1980, Eqs. 30–31 and
  Table I): the normal rotations βx = θy, βy = −θx are quadratic, tied to the Kirchhoff
  constraint at the vertices and along the edges; curvatures κ = [βx,x, βy,y, βx,y + βy,x]
  integrated with the 3-point rule (exact: κ is linear). Thin-plate theory: no transverse shear
  flexibility (PSHELL MID3 does not enter). Linear in the element's axes, as the quad's MITC4
  (large rotations through :mod:`torchrom.fe.elements.corotational`).
- **Drilling**: k Σ_n (θz_n − ω)², ω the CST membrane rotation, k = ``drilling`` · G t A, only
  on elements with bending (as the quad).
- **Mass**: ρ t + NSM per area on the translations; consistent A/12 [2 1 1; 1 2 1; 1 1 2] or
  lumped A/3 per node. No rotary inertia.
"""

from __future__ import annotations

import numpy as np

from ..mesh import TriaSet
from .green import GreenPoints
from .quad4 import bending_matrix, plane_stress, plate_on_six

# 3-point rule on the unit triangle (exact for quadratics), weights sum to 1/2
GAUSS_TRI = ((1 / 6, 1 / 6), (2 / 3, 1 / 6), (1 / 6, 2 / 3))
W_TRI = 1.0 / 6.0


def tria_frames(X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frames R (n, 3, 3) (rows e1 along G1→G2, e2, e3 the normal), in-plane coordinates
    xy (n, 3, 2) relative to G1, and areas (n,)."""
    a = X[:, 1] - X[:, 0]
    c = np.cross(a, X[:, 2] - X[:, 0])
    area = 0.5 * np.linalg.norm(c, axis=1)
    e3 = c / (2.0 * area)[:, None]
    e1 = a / np.linalg.norm(a, axis=1, keepdims=True)
    e2 = np.cross(e3, e1)
    R = np.stack((e1, e2, e3), axis=1)
    xy = np.einsum("nai,nji->naj", X - X[:, :1], R)[:, :, :2]
    return R, xy, area


def _inverse_jacobian(xy: np.ndarray) -> np.ndarray:
    """J⁻¹ (n, 2, 2) of x = x1 + ξ x21 + η x31 (J rows: ∂(x, y)/∂ξ, ∂(x, y)/∂η)."""
    J = np.stack((xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]), axis=1)
    det = J[:, 0, 0] * J[:, 1, 1] - J[:, 0, 1] * J[:, 1, 0]
    inv = np.empty_like(J)
    inv[:, 0, 0], inv[:, 1, 1] = J[:, 1, 1], J[:, 0, 0]
    inv[:, 0, 1], inv[:, 1, 0] = -J[:, 0, 1], -J[:, 1, 0]
    return inv / det[:, None, None]


def linear_gradients(xy: np.ndarray) -> np.ndarray:
    """∂L_a/∂(x, y) (n, 3, 2) of the linear shape functions (constant on the triangle)."""
    dnat = np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])  # (ξ, η) x node
    return np.einsum("nir,ra->nai", _inverse_jacobian(xy), dnat)


def tria_points(trias: TriaSet, xyz: np.ndarray) -> GreenPoints:
    """One Green-strain point per triangle (constant strain)."""
    _, xy, area = tria_frames(xyz[trias.nodes])
    D = plane_stress(trias.E, trias.nu, trias.G)
    lam = trias.laminated
    if lam.any():  # PCOMP: the laminate's A per unit thickness
        D[lam] = trias.lam_A[lam] / trias.t[lam, None, None]
    return GreenPoints("CTRIA3", trias.eids.copy(), trias.nodes.copy(), linear_gradients(xy),
                       D * (area * trias.t)[:, None, None])


def _quadratic(xi: float, eta: float) -> tuple[np.ndarray, np.ndarray]:
    """N1..N6 (vertices, then mid-sides 23, 31, 12) and their (ξ, η) derivatives (2, 6)."""
    L = 1.0 - xi - eta
    N = np.array([L * (2 * L - 1), xi * (2 * xi - 1), eta * (2 * eta - 1), 4 * xi * eta,
                  4 * eta * L, 4 * xi * L])
    dxi = np.array([-(4 * L - 1), 4 * xi - 1, 0.0, 4 * eta, -4 * eta, 4 * (L - xi)])
    deta = np.array([-(4 * L - 1), 0.0, 4 * eta - 1, 4 * xi, 4 * (L - eta), -4 * xi])
    return N, np.stack((dxi, deta))


def _dkt_coefficients(xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cx, Cy (n, 9, 6): Hx = Cx N, Hy = Cy N (Batoz et al. 1980), DOFs (w, θx, θy) per node."""
    n = len(xy)
    sides = ((1, 2), (2, 0), (0, 1))  # k = 4, 5, 6
    a, b, c, d, e = (np.zeros((n, 3)) for _ in range(5))
    for k, (i, j) in enumerate(sides):
        x = xy[:, i, 0] - xy[:, j, 0]
        y = xy[:, i, 1] - xy[:, j, 1]
        l2 = x**2 + y**2
        a[:, k] = -x / l2
        b[:, k] = 0.75 * x * y / l2
        c[:, k] = (0.25 * x**2 - 0.5 * y**2) / l2
        d[:, k] = -y / l2
        e[:, k] = (0.25 * y**2 - 0.5 * x**2) / l2
    Cx = np.zeros((n, 9, 6))
    Cy = np.zeros((n, 9, 6))
    # node v with its two sides (p, q): the side ending at v in the cyclic order and the one
    # starting there; mid-side indices 3 + k
    for v, (p, q) in enumerate(((1, 2), (2, 0), (0, 1))):  # node 1: sides 5, 6; 2: 6, 4; 3: 4, 5
        r = 3 * v
        mp, mq = 3 + p, 3 + q
        Cx[:, r, mq], Cx[:, r, mp] = 1.5 * a[:, q], -1.5 * a[:, p]
        Cx[:, r + 1, mp], Cx[:, r + 1, mq] = b[:, p], b[:, q]
        Cx[:, r + 2, v] = 1.0
        Cx[:, r + 2, mp], Cx[:, r + 2, mq] = -c[:, p], -c[:, q]
        Cy[:, r, mq], Cy[:, r, mp] = 1.5 * d[:, q], -1.5 * d[:, p]
        Cy[:, r + 1, v] = -1.0
        Cy[:, r + 1, mp], Cy[:, r + 1, mq] = e[:, p], e[:, q]
        Cy[:, r + 2, mp], Cy[:, r + 2, mq] = -b[:, p], -b[:, q]
    return Cx, Cy


def dkt_local(xy: np.ndarray, Eb: np.ndarray, nub: np.ndarray, t: np.ndarray,
              lam_D: np.ndarray | None = None) -> np.ndarray:
    """DKT bending stiffness (n, 9, 9) in local DOFs (w, θx, θy) per node."""
    n = len(xy)
    Db = bending_matrix(Eb, nub, t, lam_D)
    Cx, Cy = _dkt_coefficients(xy)
    inv = _inverse_jacobian(xy)
    area2 = 2.0 * tria_frames_area(xy)
    K = np.zeros((n, 9, 9))
    for xi, eta in GAUSS_TRI:
        _, dnat = _quadratic(xi, eta)
        dxy = np.einsum("nir,ra->nia", inv, dnat)  # (n, 2: x/y, 6)
        hx = np.einsum("nka,nia->nik", Cx, dxy)  # (n, 2, 9): ∂Hx/∂x, ∂Hx/∂y
        hy = np.einsum("nka,nia->nik", Cy, dxy)
        B = np.stack((hx[:, 0], hy[:, 1], hx[:, 1] + hy[:, 0]), axis=1)  # (n, 3, 9)
        K += W_TRI * area2[:, None, None] * (B.transpose(0, 2, 1) @ Db @ B)
    return K


def tria_frames_area(xy: np.ndarray) -> np.ndarray:
    """Areas (n,) from in-plane coordinates (n, 3, 2)."""
    u, v = xy[:, 1] - xy[:, 0], xy[:, 2] - xy[:, 0]
    return 0.5 * np.abs(u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0])


def tria_dofs(nodes: np.ndarray) -> np.ndarray:
    return (nodes[:, :, None] * 6 + np.arange(6)).reshape(len(nodes), 18)


def tria_plate_parts(trias: TriaSet, xyz: np.ndarray, drilling: float = 1e-4):
    """The triangles with bending (mask), their axes, DKT matrix (n, 9, 9), ∂L/∂(x, y) and the
    drilling stiffness ``drilling`` · G t A: the arguments of
    :func:`~torchrom.fe.elements.quad4.plate_on_six`."""
    sel = trias.bend_E > 0
    R, xy, area = tria_frames(xyz[trias.nodes[sel]])
    t = trias.t[sel]
    Kl = dkt_local(xy, trias.bend_E[sel], trias.bend_nu[sel], t, trias.lam_D[sel])
    return sel, R, Kl, linear_gradients(xy), drilling * trias.G[sel] * t * area


def tria_bending_blocks(trias: TriaSet, xyz: np.ndarray, drilling: float = 1e-4):
    """Linear DKT bending + drilling stiffness of triangles with bending, basic 6-DOF blocks."""
    if not (trias.bend_E > 0).any():
        return np.zeros((0, 18), dtype=int), np.zeros((0, 18, 18))
    sel, R, Kl, dL, k = tria_plate_parts(trias, xyz, drilling)
    return tria_dofs(trias.nodes[sel]), plate_on_six(R, Kl, dL, k)


def tria_mass_blocks(trias: TriaSet, xyz: np.ndarray, coupled: bool):
    """Translational mass blocks (n, 9, 9)."""
    _, _, area = tria_frames(xyz[trias.nodes])
    m = (trias.rho * trias.t + trias.nsm) * area
    pat = (np.array([[2.0, 1, 1], [1, 2, 1], [1, 1, 2]]) / 12.0 if coupled
           else np.eye(3) / 3.0)
    blocks = np.einsum("n,ab,ij->naibj", m, pat, np.eye(3)).reshape(-1, 9, 9)
    dofs = (trias.nodes[:, :, None] * 6 + np.arange(3)).reshape(len(trias), 9)
    return dofs, blocks
