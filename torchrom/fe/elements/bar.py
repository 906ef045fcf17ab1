"""CBAR/CBEAM: linear (Timoshenko) beam with an orientation vector, offsets and pin flags.

Written here (the card semantics are MSC Nastran's, Quick Reference Guide CBAR/CBEAM/PBAR).
Element ends: the grids moved by the offsets WA/WB (basic here, converted by the reader), each
end rigidly linked to its grid (small rotations): u_end = u_grid + θ_grid × w, θ_end = θ_grid.
Element axes (Nastran): x from end A to end B (between the offset points), y in the plane of x
and the orientation vector v (plane 1), z = x × y. Stiffness: axial E A / L, torsion G J / L,
bending with the section tensor D = E [[I1, I12], [I12, I2]] (I1 = ∫y² dA in plane 1, I2 = ∫z² dA
in plane 2, I12 = ∫yz dA: exact for an unsymmetric section) and the shear flexibility
s = diag(1/(K1 G A), 1/(K2 G A)) (0 where PBAR K1/K2 is blank). The bending stiffness is the
inverse of the cantilever flexibility (clamped end A, tip force P and moment C at end B, in
plane coordinates q = (v, w), φ = (θz, −θy)):

    F = [[L³/3 D⁻¹ + L s, L²/2 D⁻¹], [L²/2 D⁻¹, L D⁻¹]],

whose inverse, with Φ = 12 D s / L² (a 2 × 2 matrix), is K_qq = 12/L³ (I + Φ)⁻¹ D,
K_qφ = −L/2 K_qq, K_φφ = D/L + L²/4 K_qq (no inverse of D: a section with I2 = 0 is allowed),
completed by equilibrium (the rigid-body motions q_B = q_A + L φ_A, φ_B = φ_A carry no force).
For I12 = 0 this is the exact two-node Timoshenko stiffness (Przemieniecki, Theory of Matrix
Structural Analysis, Eq. 5.116; Φ = 0, Euler–Bernoulli, when K = 0).
Pin flags PA/PB (components 1-6 in the element system) release the force there: the released
element DOFs are condensed out statically, K* = K_kk − K_kr K_rr⁻¹ K_rk, before the
transformation to basic (a release that leaves the element a mechanism is refused by the reader).
Tapered CBEAM (PBEAM/PBEAML stations, :class:`~torchrom.fe.mesh.Taper`, properties linear
between stations): the same element from the flexibility integrated along it
(:func:`tapered_stiffness`, exact for end loads) and the mass integrated with the same shapes
(:func:`tapered_mass`).
PBEAM neutral axis N1/N2 (MSC QRG PBEAM: the (y, z) of the neutral axis relative to the shear
centre, element system, at ends A and B): the element ends above are on the shear-centre axis;
the axial force acts along the neutral axis, bending moments are about it (I1, I2, I12 are the
neutral axis's), torsion and transverse shear act about the shear centre. Since curvatures and
shear strains are measured by the rotations, which are the same on any parallel axis, only the
axial displacement differs: at the neutral axis it is u + N2 θy − N1 θz. The element stiffness
(:func:`element_stiffness`, the one local stiffness every analysis uses) is therefore
K = Aᵀ K₀ A with A the identity but for those two axial rows (:func:`neutral_axis_links`); the
structural mass (ρ A, ρ (I1 + I2)) is at the neutral axis, moved there by the whole rigid link
(u + θ × r, r = (0, N1, N2)), the non-structural mass stays at the shear centre (M1/M2 offsets of
an NSM are refused by the reader).
The element is linear here; in a geometrically nonlinear analysis (``FEModel(rotations=
"large")``, the default for decks) the same local matrix is used in the co-rotational frame of
:mod:`torchrom.fe.elements.corotational` (large rotations, offsets as rigid arms that rotate
with their grid); with ``rotations="small"`` it contributes K u.
Mass (at the offset ends, through the same rigid links): lumped (half of (ρA + NSM) L on each
end's translations, and for CBEAM half of ρ (I1 + I2) L on each end's torsional rotation, as
Nastran's CBEAM; pin flags leave it on the grids) or consistent (cubic Hermite transverse, linear
axial; no rotary inertia, as Nastran's CBAR; CBEAM's torsional inertia lumped as above, which
is what MSC Nastran's coupled CBEAM mass gives on tests/decks/pynastran_buckled), with pin
flags taken through the same condensed shape as the stiffness (u_r = −K_rr⁻¹ K_rk u_k), so
that both use one interpolation. Whether Nastran condenses its coupled mass so is not known
here (no f06 with pin flags and COUPMASS was at hand).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..mass import rigid_links
from ..mesh import BarSet, Taper


def bar_ends(bars: BarSet, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Basic positions (n, 3) of the element ends A and B (grids plus offsets)."""
    return xyz[bars.nodes[:, 0]] + bars.wa, xyz[bars.nodes[:, 1]] + bars.wb


def frames_between(a: np.ndarray, b: np.ndarray, v: np.ndarray):
    """Lengths (n,) and rotation matrices (n, 3, 3) whose rows are the x (from a to b), y (in
    the plane of x and v) and z axes."""
    d = b - a
    L = np.linalg.norm(d, axis=1)
    ex = d / L[:, None]
    vy = v - np.einsum("ni,ni->n", v, ex)[:, None] * ex
    ey = vy / np.linalg.norm(vy, axis=1, keepdims=True)
    return L, np.stack((ex, ey, np.cross(ex, ey)), axis=1)


def bar_frames(bars: BarSet, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Lengths (n,) and element axes (n, 3, 3, rows x, y, z) between the offset ends."""
    return frames_between(*bar_ends(bars, xyz), bars.v)


def _to_grids(bars: BarSet, R: np.ndarray, K: np.ndarray) -> np.ndarray:
    """Element-system matrices (n, 12, 12) → grid DOFs in basic: rotate to basic, then the
    rigid offsets from the grids to the ends."""
    n = len(R)
    Tr = np.zeros((n, 12, 12))
    for b in range(4):
        Tr[:, 3 * b : 3 * b + 3, 3 * b : 3 * b + 3] = R
    if np.any(bars.wa) or np.any(bars.wb):
        Tr[:, :6, :6] = Tr[:, :6, :6] @ rigid_links(bars.wa)
        Tr[:, 6:, 6:] = Tr[:, 6:, 6:] @ rigid_links(bars.wb)
    return Tr.transpose(0, 2, 1) @ K @ Tr


def bar_dofs(nodes: np.ndarray) -> np.ndarray:
    return (nodes[:, :, None] * 6 + np.arange(6)).reshape(len(nodes), 12)


# Hermite cubic beam mass for (w_A, θ_A, w_B, θ_B) with θ = dw/dx; entry (a, b) carries one
# factor L for each rotation index.
HERMITE_M = np.array(
    [[156, 22, 54, -13], [22, 4, 13, -3], [54, 13, 156, -22], [-13, -3, -22, 4]], float
)
# Bending planes in element DOFs: (transverse DOF, rotation DOF, sign of θ relative to dw/dx).
# Plane 1: v along y with θz = +dv/dx; plane 2: w along z with θy = −dw/dx.
PLANES = ((1, 5, 1.0), (2, 4, -1.0))
# Plane coordinates of one end, (q1, q2, φ1, φ2) = (v, w, θz, −θy): element DOF and sign.
BENDING_DOFS = np.array([1, 2, 5, 4])
BENDING_SIGNS = np.array([1.0, 1.0, 1.0, -1.0])


def _add_plane(M: np.ndarray, Mh: np.ndarray, plane) -> None:
    """Add the (n, 4, 4) mass Mh of one bending plane, on (w_A, θ_A, w_B, θ_B) with θ = dw/dx,
    to the element matrices M (n, 12, 12)."""
    w, th, sgn = plane
    idx = np.array([w, th, w + 6, th + 6])
    scale = np.array([1.0, sgn, 1.0, sgn])
    M[:, idx[:, None], idx[None, :]] += Mh * np.outer(scale, scale)


def hermite(xi: np.ndarray, L: float) -> np.ndarray:
    """(m, 4) cubic Hermite shapes of (w_A, θ_A, w_B, θ_B) at the fractions ξ of length L."""
    return np.stack((1 - 3 * xi**2 + 2 * xi**3, L * (xi - 2 * xi**2 + xi**3),
                     3 * xi**2 - 2 * xi**3, L * (xi**3 - xi**2)), axis=1)


def bending_stiffness(L: np.ndarray, D: np.ndarray, s: np.ndarray) -> np.ndarray:
    """(n, 8, 8) bending stiffness on the plane coordinates (q, φ) of end A, then end B, from
    the section tensor D (n, 2, 2) and the shear flexibility s (n, 2, 2) (module docstring)."""
    n = len(L)
    L3 = L[:, None, None]
    eye = np.broadcast_to(np.eye(2), (n, 2, 2))
    Kqq = 12.0 / L3**3 * np.linalg.solve(eye + 12.0 * D @ s / L3**2, D)
    Kqq = 0.5 * (Kqq + Kqq.transpose(0, 2, 1))  # symmetric in exact arithmetic
    Kbb = np.zeros((n, 4, 4))
    Kbb[:, :2, :2] = Kqq
    Kbb[:, :2, 2:] = Kbb[:, 2:, :2] = -0.5 * L3 * Kqq
    Kbb[:, 2:, 2:] = D / L3 + 0.25 * L3**2 * Kqq
    return bending_from_end_b(L, Kbb)


def bending_from_end_b(L: np.ndarray, Kbb: np.ndarray) -> np.ndarray:
    """(n, 8, 8) bending stiffness of both ends from Kbb (n, 4, 4), the stiffness of end B's
    (q, φ) with end A clamped, completed by equilibrium."""
    n = len(L)
    L3 = L[:, None, None]
    # End B relative to the rigid motion carried from end A: d = u_B − Rig u_A
    rig = np.tile(np.eye(4), (n, 1, 1))
    rig[:, :2, 2:] = L3 * np.eye(2)
    KR = Kbb @ rig
    K = np.zeros((n, 8, 8))
    K[:, :4, :4] = rig.transpose(0, 2, 1) @ KR
    K[:, :4, 4:] = -KR.transpose(0, 2, 1)
    K[:, 4:, :4] = -KR
    K[:, 4:, 4:] = Kbb
    return K


#: Gauss–Legendre points per segment between the stations of a tapered CBEAM (the integrands
#: 1/A, x²/I of linear A, I are smooth: 16 points give round-off for station ratios below 10)
TAPER_POINTS = 16


def taper_quadrature(taper: Taper, L: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (fractions ξ of the length) and weights (length units) over each segment."""
    g, w = np.polynomial.legendre.leggauss(TAPER_POINTS)
    a, b = taper.x[:-1, None], taper.x[1:, None]
    return (a + (b - a) * (g + 1.0) / 2.0).ravel(), ((b - a) / 2.0 * w * L).ravel()


def tapered_stiffness(taper: Taper, E: float, G: float, k: tuple[float, float],
                      L: float) -> np.ndarray:
    """(12, 12) element-system stiffness of a tapered CBEAM: the inverse of its cantilever
    flexibility (end A clamped, end B loaded), integrated along the element with the section
    of :class:`~torchrom.fe.mesh.Taper` at each point — exact for end loads (the internal
    forces are statically determinate):

        f_axial = ∫ dx / (E A),  f_torsion = ∫ dx / (G J),
        F = ∫ [[(L−x)² D⁻¹ + s, (L−x) D⁻¹], [(L−x) D⁻¹, D⁻¹]] dx,

    D(x) = E [[I1, I12], [I12, I2]], s(x) = diag(1 / (K1 G A), 1 / (K2 G A)); for a prismatic
    section F is the module docstring's closed form."""
    xi, w = taper_quadrature(taper, L)
    p = taper.at(xi)
    K = np.zeros((12, 12))
    ka = 1.0 / np.sum(w / (E * p["A"]))
    kt = 1.0 / np.sum(w / (G * p["J"])) if np.all(p["J"] > 0) else 0.0
    for i, j, sg in ((0, 0, 1), (0, 6, -1), (6, 0, -1), (6, 6, 1)):
        K[i, j] = sg * ka
        K[i + 3, j + 3] = sg * kt
    D = E * np.stack((np.stack((p["I1"], p["I12"]), 1), np.stack((p["I12"], p["I2"]), 1)), 1)
    Dinv = np.linalg.inv(D)
    arm = (L - xi * L)[:, None, None]
    F = np.zeros((4, 4))
    F[:2, :2] = np.einsum("m,mij->ij", w, arm**2 * Dinv)
    for c, factor in enumerate(k):
        if factor > 0:
            F[c, c] += np.sum(w / (factor * G * p["A"]))
    F[:2, 2:] = F[2:, :2] = np.einsum("m,mij->ij", w, arm * Dinv)
    F[2:, 2:] = np.einsum("m,mij->ij", w, Dinv)
    Kbb = np.linalg.inv(F)
    Kbb = 0.5 * (Kbb + Kbb.T)
    idx = np.concatenate((BENDING_DOFS, BENDING_DOFS + 6))
    sgn = np.concatenate((BENDING_SIGNS, BENDING_SIGNS))
    K[idx[:, None], idx[None, :]] += (bending_from_end_b(np.array([L]), Kbb[None])[0]
                                      * np.outer(sgn, sgn))
    return K


def neutral_axis_links(na: np.ndarray, axial_only: bool) -> np.ndarray:
    """(n, 12, 12) maps of the element DOFs at the shear-centre ends onto those at the
    neutral-axis points r = (0, N1, N2) of each end (``na`` (n, 4): N1A, N2A, N1B, N2B, element
    system): the rigid link u + θ × r, θ unchanged (:func:`torchrom.fe.mass.rigid_links`), or
    with ``axial_only`` its axial rows alone, u_x + N2 θy − N1 θz (the stiffness: module
    docstring)."""
    na = np.asarray(na, dtype=float).reshape(-1, 4)
    A = np.tile(np.eye(12), (len(na), 1, 1))
    for end, (n1, n2) in enumerate(((na[:, 0], na[:, 1]), (na[:, 2], na[:, 3]))):
        r = np.stack((np.zeros_like(n1), n1, n2), axis=1)
        link = rigid_links(r)
        s = slice(6 * end, 6 * end + 6)
        if axial_only:
            A[:, 6 * end] = 0.0
            A[:, 6 * end, s] = link[:, 0]
        else:
            A[:, s, s] = link
    return A


def element_stiffness(bars: BarSet, L: np.ndarray) -> np.ndarray:
    """(n, 12, 12) stiffness in the element system (shear-centre ends, the neutral-axis offset
    N1/N2 included), before the pin-flag releases."""
    n = len(bars)
    K = np.zeros((n, 12, 12))
    ka = bars.E * bars.A / L
    kt = bars.G * bars.J / L
    for i, j, sg in ((0, 0, 1), (0, 6, -1), (6, 0, -1), (6, 6, 1)):
        K[:, i, j] = sg * ka
        K[:, i + 3, j + 3] = sg * kt
    D = bars.E[:, None, None] * np.stack(
        (np.stack((bars.I1, bars.I12), 1), np.stack((bars.I12, bars.I2), 1)), 1)
    s = np.zeros((n, 2, 2))
    for k, factor in enumerate((bars.k1, bars.k2)):
        GAs = factor * bars.G * bars.A
        s[:, k, k] = np.divide(1.0, GAs, out=np.zeros(n), where=GAs > 0)
    idx = np.concatenate((BENDING_DOFS, BENDING_DOFS + 6))
    sgn = np.concatenate((BENDING_SIGNS, BENDING_SIGNS))
    K[:, idx[:, None], idx[None, :]] += bending_stiffness(L, D, s) * np.outer(sgn, sgn)
    for e, taper in bars.taper.items():
        if taper.varies:
            K[e] = tapered_stiffness(taper, bars.E[e], bars.G[e], (bars.k1[e], bars.k2[e]), L[e])
    off = np.flatnonzero(np.any(bars.na != 0.0, axis=1))
    if len(off):
        A = neutral_axis_links(bars.na[off], axial_only=True)
        K[off] = A.transpose(0, 2, 1) @ K[off] @ A
    return K


def released(bars: BarSet) -> np.ndarray:
    """(n, 12) True for the element DOFs released by the pin flags PA (0..5), PB (6..11)."""
    return np.concatenate((bars.pa, bars.pb), axis=1) > 0


def condense_pins(K: np.ndarray, free: np.ndarray) -> np.ndarray:
    """Static condensation of the released DOFs (``free`` True) of one element matrix: no force
    there, K* = K_kk − K_kr K_rr⁻¹ K_rk on the kept DOFs, zero rows/columns on the released."""
    r, k = np.nonzero(free)[0], np.nonzero(~free)[0]
    out = np.zeros_like(K)
    Kkr = K[np.ix_(k, r)]
    out[np.ix_(k, k)] = K[np.ix_(k, k)] - Kkr @ np.linalg.solve(K[np.ix_(r, r)], Kkr.T)
    return out


def pin_shape(K: np.ndarray, free: np.ndarray) -> np.ndarray:
    """(12, 12) map of the element DOFs tied to the grids onto all of them: the released ones
    follow the condensation, u_r = −K_rr⁻¹ K_rk u_k (the element's deformed shape)."""
    r, k = np.nonzero(free)[0], np.nonzero(~free)[0]
    C = np.eye(len(K))
    C[r, r] = 0.0
    C[np.ix_(r, k)] = -np.linalg.solve(K[np.ix_(r, r)], K[np.ix_(r, k)])
    return C


def mechanism_pins(bars: BarSet, xyz: np.ndarray) -> np.ndarray:
    """Indices of the bars whose pin flags release DOFs without stiffness or leave a mechanism
    (K_rr singular relative to the element's stiffness)."""
    if not np.any(bars.pa) and not np.any(bars.pb):
        return np.zeros(0, dtype=int)
    L, _ = bar_frames(bars, xyz)
    K = element_stiffness(bars, L)
    rel = released(bars)
    bad = []
    for e in np.nonzero(rel.any(axis=1))[0]:
        r = np.nonzero(rel[e])[0]
        Krr = K[e][np.ix_(r, r)]
        d = np.diag(Krr)
        # each released DOF needs stiffness of its own (relative to the element's largest, so
        # that a small J is fine), and together they must not form a mechanism (K_rr scaled to
        # a unit diagonal is then well away from singular)
        if d.min() <= 1e-14 * np.abs(np.diag(K[e])).max():
            bad.append(e)
        elif np.linalg.eigvalsh(Krr / np.sqrt(np.outer(d, d))).min() <= 1e-10:
            bad.append(e)
    return np.array(bad, dtype=int)


def bar_local_stiffness(bars: BarSet, xyz: np.ndarray):
    """Lengths (n,), element axes R (n, 3, 3, rows x, y, z) and the element-system stiffness
    (n, 12, 12) with the pin-flag releases condensed: the one local matrix of the linear
    element (:func:`bar_stiffness_blocks`) and of its co-rotational form
    (:mod:`torchrom.fe.elements.corotational`)."""
    L, R = bar_frames(bars, xyz)
    K = element_stiffness(bars, L)
    rel = released(bars)
    for e in np.nonzero(rel.any(axis=1))[0]:
        K[e] = condense_pins(K[e], rel[e])
    return L, R, K


def bar_stiffness_blocks(bars: BarSet, xyz: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    _, R, K = bar_local_stiffness(bars, xyz)
    return bar_dofs(bars.nodes), _to_grids(bars, R, K)


def bar_mass_blocks(bars: BarSet, xyz: np.ndarray, coupled: bool):
    L, R = bar_frames(bars, xyz)
    return bar_dofs(bars.nodes), _to_grids(bars, R, element_mass(bars, L, coupled))


def element_mass(bars: BarSet, L: np.ndarray, coupled: bool) -> np.ndarray:
    """(n, 12, 12) mass in the element system on the shear-centre ends: the structural mass at
    the neutral axis, the non-structural mass at the shear centre (module docstring), the
    pin-flag condensation last."""
    M = _axis_mass(bars, L, coupled)
    off = np.flatnonzero(np.any(bars.na != 0.0, axis=1))
    if len(off):
        # the element mass is linear in (ρ, NSM, NSI): the structural part is the difference
        # with the mass of the NSM alone
        zero = np.zeros(len(bars))
        nsm_only = _axis_mass(replace(bars, rho=zero, polar=zero), L, coupled)[off]
        B = neutral_axis_links(bars.na[off], axial_only=False)
        M[off] = B.transpose(0, 2, 1) @ (M[off] - nsm_only) @ B + nsm_only
    rel = released(bars)
    if coupled and rel.any():
        # the consistent mass follows the condensed shape of the stiffness (Rayleigh–Ritz with
        # one interpolation); without it a pinned end keeps the clamped slope's kinetic energy
        K = element_stiffness(bars, L)
        for e in np.nonzero(rel.any(axis=1))[0]:
            C = pin_shape(K[e], rel[e])
            M[e] = C.T @ M[e] @ C
    return M


def _axis_mass(bars: BarSet, L: np.ndarray, coupled: bool) -> np.ndarray:
    """(n, 12, 12) element-system mass with all of it on the element's axis (lumped or
    consistent, prismatic or tapered; module docstring)."""
    m = (bars.rho * bars.A + bars.nsm) * L
    ip = bars.polar * L  # torsional inertia of the element (CBEAM)
    M = np.zeros((len(bars), 12, 12))
    if not coupled:
        for i in (0, 1, 2, 6, 7, 8):
            M[:, i, i] = m / 2.0
        M[:, 3, 3] = M[:, 9, 9] = ip / 2.0
    else:
        for i, j, sg in ((0, 0, 2.0), (0, 6, 1.0), (6, 0, 1.0), (6, 6, 2.0)):
            M[:, i, j] = m * sg / 6.0
        # the torsional inertia stays lumped in the coupled mass too (MSC's CBEAM: the
        # strut-braced wing of tests/decks/pynastran_buckled, 14 modes within 0.1 %; linear ip
        # [2 1; 1 2] / 6: its torsion mode +20 %)
        M[:, 3, 3] = M[:, 9, 9] = ip / 2.0
        rot = np.array([0, 1, 0, 1])
        Lp = L[:, None, None] ** (rot[:, None] + rot[None, :])
        for plane in PLANES:
            _add_plane(M, (m / 420.0)[:, None, None] * HERMITE_M * Lp, plane)
    for e, taper in bars.taper.items():
        M[e] = tapered_mass(taper, bars.rho[e], L[e], coupled)
    return M


def tapered_mass(taper: Taper, rho: float, L: float, coupled: bool) -> np.ndarray:
    """(12, 12) element-system mass of a tapered CBEAM, μ = ρ A + NSM and the torsional
    inertia ρ (I1 + I2) + NSI per length varying along it: lumped, each end gets its linear
    share, ∫ μ (1 − ξ) dx and ∫ μ ξ dx (total mass and centre of mass kept); coupled, ∫ μ N Nᵀ
    dx with the linear axial and the cubic Hermite transverse shapes, the torsional inertia
    lumped as in the prismatic element. Prismatic stations give the prismatic matrices."""
    xi, w = taper_quadrature(taper, L)
    p = taper.at(xi)
    mu = w * (rho * p["A"] + p["nsm"])
    ip = w * (rho * (p["I1"] + p["I2"]) + p["nsi"])
    lin = np.stack((1.0 - xi, xi), axis=1)
    M = np.zeros((12, 12))
    ends = lin.T @ ip
    M[3, 3], M[9, 9] = ends
    if not coupled:
        for i, share in zip((0, 6), lin.T @ mu):
            M[i, i] = M[i + 1, i + 1] = M[i + 2, i + 2] = share
        return M
    M[np.ix_((0, 6), (0, 6))] = lin.T @ (mu[:, None] * lin)
    H = hermite(xi, L)
    Mh = (H.T @ (mu[:, None] * H))[None]
    for plane in PLANES:
        _add_plane(M[None], Mh, plane)
    return M
