"""CHEXA (8 or 20 grids), CPENTA (6 or 15), CTETRA (4 or 10) with PSOLID: isoparametric solids,
the 8- and 6-grid ones with condensed incompatible modes.

One code path (shape functions + integration rule per number of grids), Nastran's grid order
(corners, then edge grids; MSC Quick Reference Guide), shape functions after Zienkiewicz & Taylor
Vol. 1, §§6.4–6.5. Isotropic linear elasticity (MAT1), **linear** (a nonlinear analysis includes
them through their linear stiffness and warns). Full Gauss integration always (hexa 2×2×2 or
3×3×3, penta 3 × 2 or 7 × 3, tetra 1 or 4 points): PSOLID IN/ISOP are not honoured, because the
reduced 20-grid rule leaves spurious zero-energy modes. The 8-grid CHEXA adds the bubbles
(1 − ξ²), (1 − η²), (1 − ζ²) (Wilson, Taylor, Doherty & Ghaboussi 1973) with the centre-Jacobian
form of Taylor, Beresford & Wilson (IJNME 10, 1976), which passes the patch test on any shape
(``incompatible="wilson"`` keeps the plain form for comparison); the 6-grid CPENTA one bubble
(1 − ζ²). The internal DOFs are condensed per element, so a rectangular hexahedron bends exactly.
Mass: consistent, or lumped (row sums; the quadratic forms by scaling the consistent diagonal to
the element mass, Hinton–Rock–Zienkiewicz, as Nastran's COUPMASS does). Solids with only some of
their edge grids are refused by the reader.
"""

from __future__ import annotations

import numpy as np

_G = 1.0 / np.sqrt(3.0)
_HEX_NODES = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                       [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], dtype=float)


def _hexa(p):
    xi, eta, zeta = p
    s = _HEX_NODES
    N = 0.125 * (1 + xi * s[:, 0]) * (1 + eta * s[:, 1]) * (1 + zeta * s[:, 2])
    d = np.stack((0.125 * s[:, 0] * (1 + eta * s[:, 1]) * (1 + zeta * s[:, 2]),
                  0.125 * s[:, 1] * (1 + xi * s[:, 0]) * (1 + zeta * s[:, 2]),
                  0.125 * s[:, 2] * (1 + xi * s[:, 0]) * (1 + eta * s[:, 1])))
    return N, d


def _penta(p):
    r, s, z = p  # triangle (r, s), line z in [-1, 1]; nodes 1-3 at z = -1, 4-6 at z = +1
    L = np.array([1 - r - s, r, s])
    dL = np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])
    lo, hi = 0.5 * (1 - z), 0.5 * (1 + z)
    N = np.concatenate((L * lo, L * hi))
    d = np.zeros((3, 6))
    d[0] = np.concatenate((dL[0] * lo, dL[0] * hi))
    d[1] = np.concatenate((dL[1] * lo, dL[1] * hi))
    d[2] = np.concatenate((-0.5 * L, 0.5 * L))
    return N, d


def _tetra(p):
    r, s, t = p
    N = np.array([1 - r - s - t, r, s, t])
    d = np.array([[-1.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 1.0]])
    return N, d


def _tetra10(p):
    r, s, t = p
    L = np.array([1 - r - s - t, r, s, t])
    dL = np.array([[-1.0, 1.0, 0.0, 0.0], [-1.0, 0.0, 1.0, 0.0], [-1.0, 0.0, 0.0, 1.0]])
    edges = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
    N = np.concatenate((L * (2 * L - 1), [4 * L[i] * L[j] for i, j in edges]))
    d = np.concatenate((dL * (4 * L - 1), np.stack([4 * (dL[:, i] * L[j] + L[i] * dL[:, j])
                                                     for i, j in edges], axis=1)), axis=1)
    return N, d


#: natural coordinates of the 20-grid hexahedron: corners, then the mid-points of the edges
#: in Nastran's order
_HEX20_EDGES = ((0, 1), (1, 2), (2, 3), (3, 0), (0, 4), (1, 5), (2, 6), (3, 7), (4, 5), (5, 6),
                (6, 7), (7, 4))
_HEX20_NODES = np.vstack([_HEX_NODES] + [(_HEX_NODES[i] + _HEX_NODES[j]) / 2
                                         for i, j in _HEX20_EDGES])


def _hexa20(p):
    p = np.asarray(p, dtype=float)
    N = np.empty(20)
    d = np.empty((3, 20))
    for a, s in enumerate(_HEX20_NODES):
        f = 1 + p * s  # (1 + ξ ξ_a), (1 + η η_a), (1 + ζ ζ_a); 1 along an edge's own direction
        if a < 8:
            c = s @ p - 2
            N[a] = 0.125 * f.prod() * c
            for k in range(3):
                d[k, a] = 0.125 * s[k] * np.prod(np.delete(f, k)) * (c + f[k])
        else:
            m = int(np.flatnonzero(s == 0)[0])  # the edge runs along natural direction m
            g = np.prod(np.delete(f, m))
            N[a] = 0.25 * (1 - p[m] ** 2) * g
            for k in range(3):
                d[k, a] = (-0.5 * p[m] * g if k == m else
                           0.25 * (1 - p[m] ** 2) * s[k] * np.prod(np.delete(f, [k, m])))
    return N, d


#: the 15-grid wedge's edges: triangle 1-2-3, the edges along ζ, triangle 4-5-6
_PENTA15_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 4), (2, 5), (3, 4), (4, 5), (5, 3))


def _penta15(p):
    r, s, z = p
    L = np.array([1 - r - s, r, s])
    dL = np.array([[-1.0, 1.0, 0.0], [-1.0, 0.0, 1.0]])
    q = 1 - z * z
    N = np.empty(15)
    gL = np.zeros((3, 15))  # ∂N/∂L_k, then chained to (r, s) by dL
    dz = np.empty(15)
    for a in range(6):  # corners: side σ = −1 (grids 1-3) or +1 (grids 4-6)
        i, sg = a % 3, (-1.0 if a < 3 else 1.0)
        lin = 1 + sg * z
        N[a] = 0.5 * L[i] * (2 * L[i] - 1) * lin - 0.5 * L[i] * q
        gL[i, a] = 0.5 * (4 * L[i] - 1) * lin - 0.5 * q
        dz[a] = 0.5 * sg * L[i] * (2 * L[i] - 1) + L[i] * z
    for k, (i, j) in enumerate(_PENTA15_EDGES):
        a = 6 + k
        if 3 <= k < 6:  # edge along ζ
            N[a], gL[i, a], dz[a] = L[i] * q, q, -2 * z * L[i]
        else:
            sg = -1.0 if k < 3 else 1.0
            i, j = i % 3, j % 3
            lin = 1 + sg * z
            N[a] = 2 * L[i] * L[j] * lin
            gL[i, a], gL[j, a] = 2 * L[j] * lin, 2 * L[i] * lin
            dz[a] = 2 * sg * L[i] * L[j]
    return N, np.vstack((dL @ gL, dz))


def _gauss_cube(n: int):
    x, w = np.polynomial.legendre.leggauss(n)
    return ([(a, b, c) for a in x for b in x for c in x],
            [wa * wb * wc for wa in w for wb in w for wc in w])


def _wedge_rule():
    """Degree-5 7-point triangle rule (Radon; weights on the unit triangle, sum ½) × 3 Gauss."""
    r15 = np.sqrt(15.0)
    a, b = (6 - r15) / 21, (6 + r15) / 21
    wa, wb = (155 - r15) / 2400, (155 + r15) / 2400
    tri = ([(1 / 3, 1 / 3)] + [(a, a), (1 - 2 * a, a), (a, 1 - 2 * a)]
           + [(b, b), (1 - 2 * b, b), (b, 1 - 2 * b)])
    wt = [9 / 80] + [wa] * 3 + [wb] * 3
    x, w = np.polynomial.legendre.leggauss(3)
    return ([(r, s, z) for (r, s) in tri for z in x],
            [wr * wz for wr in wt for wz in w])


def collapsed_tetra_rule(n: int) -> tuple[list[tuple[float, float, float]], list[float]]:
    """Gauss–Legendre n×n×n on the unit cube mapped to the unit tetrahedron (Duffy:
    r = u, s = v (1 − u), t = w (1 − u)(1 − v), Jacobian (1 − u)² (1 − v)): exact for
    polynomials of degree ≤ 2n − 3 (Stroud's conical product)."""
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * (x + 1.0), 0.5 * w
    pts, wts = [], []
    for u, wu in zip(x, w):
        for v, wv in zip(x, w):
            for z, wz in zip(x, w):
                pts.append((u, v * (1 - u), z * (1 - u) * (1 - v)))
                wts.append(wu * wv * wz * (1 - u) ** 2 * (1 - v))
    return pts, wts


_TRI3 = ((1 / 6, 1 / 6), (2 / 3, 1 / 6), (1 / 6, 2 / 3))
#: shape functions and integration rules (points, weights) per number of grids
RULES = {
    8: (_hexa, [(a, b, c) for a in (-_G, _G) for b in (-_G, _G) for c in (-_G, _G)],
        [1.0] * 8),
    6: (_penta, [(r, s, z) for (r, s) in _TRI3 for z in (-_G, _G)], [1.0 / 6.0] * 6),
    4: (_tetra, [(0.25, 0.25, 0.25)], [1.0 / 6.0]),
}
# Mass needs a higher rule for the tetrahedron (N_a N_b is quadratic): 4-point rule, degree 2;
# the same rule integrates the quadratic tetrahedron's stiffness; its mass (degree 4) needs more.
_A, _B = 0.5854101966249685, 0.1381966011250105
_TET4 = ([(_B, _B, _B), (_A, _B, _B), (_B, _A, _B), (_B, _B, _A)], [1.0 / 24.0] * 4)
RULES[10] = (_tetra10, *_TET4)
RULES[20] = (_hexa20, *_gauss_cube(3))
RULES[15] = (_penta15, *_wedge_rule())
MASS_RULES = {8: RULES[8][1:], 6: RULES[6][1:], 4: _TET4, 10: collapsed_tetra_rule(4),
              20: RULES[20][1:], 15: RULES[15][1:]}
#: grids of the quadratic forms, lumped by HRZ (their row sums are negative at the corners)
QUADRATIC = (10, 15, 20)


def elasticity(E: np.ndarray, nu: np.ndarray) -> np.ndarray:
    """Isotropic 3-D elasticity (n, 6, 6), Voigt [xx, yy, zz, xy, yz, zx] (engineering shear)."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    mu = E / (2 * (1 + nu))
    D = np.zeros((len(E), 6, 6))
    D[:, :3, :3] = lam[:, None, None]
    for i in range(3):
        D[:, i, i] += 2 * mu
        D[:, 3 + i, 3 + i] = mu
    return D


def _geometry(X: np.ndarray, dnat: np.ndarray):
    J = np.einsum("ra,nai->nri", dnat, X)  # (n, 3, 3)
    det = np.linalg.det(J)
    dxyz = np.einsum("nir,ra->nai", np.linalg.inv(J), dnat)  # (n, nn, 3)
    return det, dxyz


def solid_dofs(nodes: np.ndarray) -> np.ndarray:
    """Translational DOFs (n, 3 nn) of the grids."""
    return (nodes[:, :, None] * 6 + np.arange(3)).reshape(len(nodes), -1)


def _hexa_bubbles(p):
    """∂/∂(ξ, η, ζ) of the incompatible modes (1 − ξ²), (1 − η²), (1 − ζ²): (3, 3)."""
    return np.diag(-2.0 * np.asarray(p, dtype=float))


def _penta_bubbles(p):
    """∂/∂(r, s, ζ) of the wedge's one incompatible mode (1 − ζ²), along its axis: (3, 1)."""
    return np.array([[0.0], [0.0], [-2.0 * p[2]]])


#: incompatible (bubble) modes per number of grids: their natural derivatives and the
#: element's centre in natural coordinates (where Taylor's form takes the Jacobian)
BUBBLES = {8: (_hexa_bubbles, (0.0, 0.0, 0.0)), 6: (_penta_bubbles, (1 / 3, 1 / 3, 0.0))}
#: ``incompatible`` choices of :func:`solid_stiffness`
INCOMPATIBLE = ("taylor", "wilson", None)


def _strain_matrix(d: np.ndarray) -> np.ndarray:
    """B (n, 6, 3m) from the x, y, z derivatives d (n, m, 3) of m functions (Voigt order of
    :func:`elasticity`)."""
    n, m = d.shape[:2]
    B = np.zeros((n, 6, 3 * m))
    for i in range(3):
        B[:, i, i::3] = d[:, :, i]
    B[:, 3, 0::3], B[:, 3, 1::3] = d[:, :, 1], d[:, :, 0]
    B[:, 4, 1::3], B[:, 4, 2::3] = d[:, :, 2], d[:, :, 1]
    B[:, 5, 2::3], B[:, 5, 0::3] = d[:, :, 0], d[:, :, 2]
    return B


def solid_stiffness(X: np.ndarray, E: np.ndarray, nu: np.ndarray,
                    incompatible: str | None = "taylor") -> np.ndarray:
    """K (n, 3nn, 3nn) of elements with node coordinates X (n, nn, 3), basic axes.

    ``incompatible`` (8- and 6-grid elements; ignored for the others): ``"taylor"`` adds the
    bubble modes with Taylor's centre-Jacobian derivatives (passes the patch test on any
    shape), ``"wilson"`` with the plain derivatives J⁻¹ ∂P/∂ξ (Wilson's 1973 form: fails the
    patch test on distorted elements; kept to show that), ``None`` the plain isoparametric
    element. The bubble DOFs are condensed out per element."""
    if incompatible not in INCOMPATIBLE:
        raise ValueError(f"incompatible must be one of {INCOMPATIBLE}, got {incompatible!r}")
    n, nn = X.shape[:2]
    shape, points, weights = RULES[nn]
    D = elasticity(E, nu)
    K = np.zeros((n, 3 * nn, 3 * nn))
    bubbles = BUBBLES.get(nn) if incompatible else None
    if bubbles is not None:
        bubble, centre = bubbles
        nb = 3 * bubble(centre).shape[1]
        Kci = np.zeros((n, 3 * nn, nb))
        Kii = np.zeros((n, nb, nb))
        J0 = np.einsum("ra,nai->nri", shape(centre)[1], X)
        inv0, det0 = np.linalg.inv(J0), np.linalg.det(J0)
    for p, w in zip(points, weights):
        det, d = _geometry(X, shape(p)[1])
        B = _strain_matrix(d)
        dV = w * np.abs(det)[:, None, None]
        DB = D @ B
        K += dV * (B.transpose(0, 2, 1) @ DB)
        if bubbles is not None:
            if incompatible == "taylor":  # Taylor–Beresford–Wilson: J0⁻¹ ∂P/∂ξ × det J0 / det J
                g = np.einsum("nir,rb->nbi", inv0, bubble(p)) * (det0 / det)[:, None, None]
            else:
                g = np.einsum("nir,rb->nbi", np.linalg.inv(np.einsum(
                    "ra,nai->nri", shape(p)[1], X)), bubble(p))
            G = _strain_matrix(g)
            Kci += dV * (B.transpose(0, 2, 1) @ D @ G)
            Kii += dV * (G.transpose(0, 2, 1) @ D @ G)
    if bubbles is not None:
        K -= Kci @ np.linalg.solve(Kii, Kci.transpose(0, 2, 1))
        K = 0.5 * (K + K.transpose(0, 2, 1))
    return K


def solid_volumes(X: np.ndarray) -> np.ndarray:
    nn = X.shape[1]
    shape, points, weights = RULES[nn]
    return sum(w * _geometry(X, shape(p)[1])[0] for p, w in zip(points, weights))  # signed


def solid_mass(X: np.ndarray, rho: np.ndarray, coupled: bool) -> np.ndarray:
    """M (n, 3nn, 3nn): consistent ∫ ρ N_a N_b dV ⊗ I3, or lumped by row sums."""
    n, nn = X.shape[:2]
    shape = RULES[nn][0]
    points, weights = MASS_RULES[nn]
    pat = np.zeros((n, nn, nn))
    for p, w in zip(points, weights):
        N, dnat = shape(p)
        det = _geometry(X, dnat)[0]
        pat += w * np.abs(det)[:, None, None] * np.outer(N, N)[None]
    if not coupled and nn in QUADRATIC:  # HRZ: the diagonal scaled to the element's mass
        diag = np.einsum("naa->na", pat)
        scale = pat.sum(axis=(1, 2)) / diag.sum(axis=1)
        pat = np.einsum("na,ab->nab", diag * scale[:, None], np.eye(nn))
    elif not coupled:
        pat = np.einsum("na,ab->nab", pat.sum(axis=2), np.eye(nn))
    pat *= rho[:, None, None]
    return np.einsum("nab,ij->naibj", pat, np.eye(3)).reshape(n, 3 * nn, 3 * nn)


def solid_blocks(solids, xyz: np.ndarray):
    """(dofs, K) of a :class:`~torchrom.fe.mesh.SolidSet`."""
    return solid_dofs(solids.nodes), solid_stiffness(xyz[solids.nodes], solids.E, solids.nu)


def solid_mass_blocks(solids, xyz: np.ndarray, coupled: bool):
    return solid_dofs(solids.nodes), solid_mass(xyz[solids.nodes], solids.rho, coupled)
