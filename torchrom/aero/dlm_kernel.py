"""Aerodynamic influence coefficients of the vortex- and doublet-lattice methods in torch.

Hand-written, vectorised over box pairs *and* reduced frequencies (PanelAero, the reference
implementation kept in ``tests/test_aero_dlm_kernel.py``, evaluates one frequency at a time in
NumPy and has no batched torch version). The method is the published one that PanelAero also
implements, with the same branches and constants so that both agree to rounding:

* steady part: horseshoe vortices (bound vortex on the quarter-chord line, trailing legs to
  +x) with the Prandtl–Glauert stretch x/β (Katz & Plotkin Sec. 10.4.5–10.4.7; Hedman 1965);
* oscillatory increment (the steady kernel subtracted): Albano & Rodden 1969 with Rodden,
  Giesing & Kálmán 1971/1972 (K1, K2 of Landahl, Eqs. 7–16; integrals I1, I2 Eqs. A.1–A.9 with
  the u1 < 0 reflection A.5/A.9) and either the parabolic spanwise approximation (Rodden 1971
  Eqs. 28–41, Laschka's 11-term exponential fit of u/√(1+u²)) or the quartic one (Rodden,
  Taylor & McIntosh 1998 Eqs. 15–34, Desmarais' 12-term fit).

All k-independent pair geometry is evaluated once; the k-dependent kernel is written in real
arithmetic so that ``torch.compile`` can fuse it into one loop over (k, pair) — unfused, the
~10³ elementwise passes per pair are bound by memory bandwidth. Small problems, and machines
where compilation fails, run the same functions eagerly.

Conventions: PanelAero's — receiving points at the three-quarter chord, sending (doublet)
lines on the quarter chord, k = ω/V (the caller converts Nastran's k = ω b / V), A_jj the
normalwash per unit Δc_p; the total AIC is ``steady_aic + oscillatory_aic``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..errors import InputError

#: Desmarais' 12-term fit (quartic kernel): a_n, exponents c_n = 2^n b
_DESMARAIS_A = (0.000319759140, -0.000055461471, 0.002726074362, 0.005749551566,
                0.031455895072, 0.106031126212, 0.406838011567, 0.798112357155,
                -0.417749229098, 0.077480713894, -0.012677284771, 0.001787032960)
_DESMARAIS_C = tuple(2.0**n * 0.009054814793 for n in range(1, 13))
#: Laschka's 11-term fit (parabolic kernel, Rodden 1971 Eq. A.4; Blair 1992 p. 89): c_n = 0.372 n
_LASCHKA_A = (+0.24186198, -2.7918027, +24.991079, -111.59196, +271.43549, -305.75288,
              -41.183630, +545.98537, -644.78155, +328.72755, -64.279511)
_LASCHKA_C = tuple(0.372 * n for n in range(1, 12))

#: spanwise stations of the sending line, in units of its semiwidth e
_STATIONS = {"quartic": (-1.0, -0.5, 0.0, 0.5, 1.0), "parabolic": (-1.0, 0.0, 1.0)}
_FITS = {"quartic": (_DESMARAIS_A, _DESMARAIS_C), "parabolic": (_LASCHKA_A, _LASCHKA_C)}
KERNELS = tuple(_STATIONS)

#: (k, pair) elements per chunk, compiled: bounds the working memory (~20 float64 arrays of
#: this size); eager: small enough that the ~10³ elementwise passes stay in the CPU cache
CHUNK_ELEMENTS = 1_500_000
EAGER_CHUNK_ELEMENTS = 1 << 15
#: most frequencies evaluated together, and the budget of one chunk's AIC output (bytes)
K_PER_CHUNK = 8
OUTPUT_BYTES = 256 * 2**20
#: below this many (k, pair) elements in a call the kernel runs eagerly (compiling costs more)
COMPILE_MIN_ELEMENTS = 50_000_000


@dataclass
class LatticeGeometry:
    """Receiving points (rows) and sending boxes (columns) of an AIC, basic axes.

    receive:      (nr, 3) three-quarter-chord points at mid-span
    receive_normal: (nr, 3) unit normals of the receiving boxes
    receive_dihedral: (nr,) dihedral of the receiving boxes' quarter-chord lines (rad)
    doublet:      (ns, 3) quarter-chord points at mid-span (sending points)
    left, right:  (ns, 3) ends of the quarter-chord lines (left to right)
    chord:        (ns,) box chords at mid-span
    """

    receive: np.ndarray
    receive_normal: np.ndarray
    receive_dihedral: np.ndarray
    doublet: np.ndarray
    left: np.ndarray
    right: np.ndarray
    chord: np.ndarray

    @classmethod
    def from_panels(cls, panels, rows=None) -> LatticeGeometry:
        """All boxes send; ``rows`` (indices) receive (None: all)."""
        rows = slice(None) if rows is None else np.asarray(rows)
        left, right = panels.vortex_left, panels.vortex_right
        dy, dz = right[:, 1] - left[:, 1], right[:, 2] - left[:, 2]
        dihedral = np.arcsin(dz / np.hypot(dy, dz))
        return cls(panels.control_points[rows], panels.normals[rows], dihedral[rows],
                   panels.doublet_points, left, right, panels.chords)

    @property
    def shape(self) -> tuple[int, int]:
        return len(self.receive), len(self.doublet)


def _t(a) -> torch.Tensor:
    return torch.as_tensor(np.ascontiguousarray(a), dtype=torch.float64)


# -- steady part (vortex lattice) -----------------------------------------------------------
def steady_aic(geom: LatticeGeometry, mach: float) -> np.ndarray:
    """Steady normalwash AIC (nr, ns): horseshoe vortices in the x/β-stretched frame.

    Influences of a vortex segment on a point closer than 1e-5 to it (on the segment's line)
    are set to zero, pair by pair.
    """
    beta = math.sqrt(1.0 - mach**2)
    stretch = torch.tensor([1.0 / beta, 1.0, 1.0], dtype=torch.float64)
    p0 = _t(geom.receive)[:, None, :] * stretch
    p1 = _t(geom.left)[None] * stretch
    p3 = _t(geom.right)[None] * stretch
    n = _t(geom.receive_normal)
    nz, ny = n[:, 2:3], n[:, 1:2]
    eps = 1e-5
    r1v, r2v = p0 - p1, p0 - p3
    r0v = p3 - p1
    r1 = r1v.norm(dim=-1)
    r2 = r2v.norm(dim=-1)
    # bound vortex (Katz & Plotkin Eq. 10.115)
    cross = torch.cross(r1v, r2v, dim=-1)
    mod2 = (cross**2).sum(-1)
    base = ((r0v * r1v).sum(-1) / r1 - (r0v * r2v).sum(-1) / r2) / (4.0 * math.pi * mod2)
    bound = base * (cross[..., 2] * nz + cross[..., 1] * ny)
    bound = torch.where((r1 < eps) | (r2 < eps) | (mod2.sqrt() < eps), 0.0, bound)
    # trailing legs: from +∞ to the left end, from the right end to +∞ (Katz & Plotkin 10.4.7)
    d2 = torch.hypot(r1v[..., 1], r1v[..., 2])
    left = -(1.0 + r1v[..., 0] / r1) / (4.0 * math.pi * d2**2) * (
        r1v[..., 1] * nz - r1v[..., 2] * ny)
    left = torch.where((r1 < eps) | (d2 < eps), 0.0, left)
    d3 = torch.hypot(r2v[..., 1], r2v[..., 2])
    right = -(r2v[..., 0] / r2 + 1.0) / (4.0 * math.pi * d3**2) * (
        -r2v[..., 1] * nz + r2v[..., 2] * ny)
    right = torch.where((r2 < eps) | (d3 < eps), 0.0, right)
    return ((bound + left + right) * (0.5 * _t(geom.chord))).numpy()


# -- oscillatory part (doublet lattice) --------------------------------------------------------
def _station_kernel(k, pg: _PairGeometry, station, mach, *, fit: str, nonplanar: bool):
    """P1 (and P2) at one sending-line station for every k (rows) and pair (columns).

    Rodden 1971 Eqs. 7–8 (K1, K2 with I1, I2 of Eqs. A.1/A.6 and the reflection A.5/A.9 for
    u1 < 0), Eqs. 27b/36b (P1, P2: the steady K10, K20 subtracted). Real arithmetic; the
    k-independent factors (:func:`_station_geometry`) are recomputed inside the fused loop,
    which is cheaper than storing them.
    """
    (r1, u1, x0, m1, k10, t1, r0_value1, r0,
     t2, m2, m3, k20, r0_value2) = _station_geometry(pg, station, mach, nonplanar)
    a_n, c_n = _FITS[fit]
    k1 = k * r1
    ua = u1.abs()
    neg = u1 < 0
    # Σ a_n e^{-c_n u} / (c_n + i k1) at u = |u1| and at u = 0, and (nonplanar) the sums with
    # 1/(c_n + i k1)²: J0 = S + u I0 in closed form (Rodden 1971 Eq. A.8 summed by parts)
    i0r = i0i = z0r = z0i = s_r = s_i = s0r = s0i = 0.0
    kk = k1 * k1
    for a, c in zip(a_n, c_n):
        d = 1.0 / (c * c + kk)
        zr, zi = c * d, -k1 * d
        w = a * torch.exp(-c * ua)
        i0r = i0r + w * zr
        i0i = i0i + w * zi
        z0r = z0r + a * zr
        z0i = z0i + a * zi
        if nonplanar:
            qr, qi = zr * zr - zi * zi, 2.0 * zr * zi
            s_r = s_r + w * qr
            s_i = s_i + w * qi
            s0r = s0r + a * qr
            s0i = s0i + a * qi
    sq = torch.sqrt(1.0 + ua * ua)
    g = 1.0 - ua / sq
    ph = k1 * ua
    er, ei = torch.cos(ph), -torch.sin(ph)  # e^{-i k1 |u1|}
    # I1(|u1|) = (g - i k1 I0) e^{-i k1 u} ; I1(0) = 1 - i k1 I0(0)
    ar, ai = g + k1 * i0i, -k1 * i0r
    j1r, j1i = ar * er - ai * ei, ar * ei + ai * er
    i1r = torch.where(neg, 2.0 * (1.0 + k1 * z0i) - j1r, j1r)
    i1i = j1i
    # e^{-i k1 u1} for the signed u1
    eur, eui = er, torch.where(neg, -ei, ei)
    # K1 = -I1 - e^{-i k1 u1} M r1 / (R √(1+u1²))
    k1r = -i1r - eur * m1
    k1i = -i1i - eui * m1
    xpos = r0_value1
    k1r = torch.where(r0, xpos, k1r)
    k1i = torch.where(r0, 0.0, k1i)
    # e^{-i k x0}
    xr, xi = torch.cos(k * x0), -torch.sin(k * x0)
    p1r = -((k1r * xr - k1i * xi) - k10) * t1
    p1i = -(k1r * xi + k1i * xr) * t1
    if not nonplanar:
        return p1r, p1i
    # I2(u) = [(2 + i k1 u) g - u/(1+u²)^{3/2} - i k1 I0 + k1² J0] e^{-i k1 u} / 3
    jr, ji = s_r + ua * i0r, s_i + ua * i0i
    br = 2.0 * g - ua / (sq * sq * sq) + k1 * i0i + kk * jr
    bi = k1 * ua * g - k1 * i0r + kk * ji
    j2r, j2i = (br * er - bi * ei) / 3.0, (br * ei + bi * er) / 3.0
    i2_0r = (2.0 + k1 * z0i + kk * s0r) / 3.0
    i2r = torch.where(neg, 2.0 * i2_0r - j2r, j2r)
    i2i = j2i
    # K2 = 3 I2 + i k1 e^{-i k1 u1} M² r1² / (R² √(1+u1²)) + e^{-i k1 u1} m3
    k2r = 3.0 * i2r - k1 * eui * m2 + eur * m3
    k2i = 3.0 * i2i + k1 * eur * m2 + eui * m3
    k2r = torch.where(r0, r0_value2, k2r)
    k2i = torch.where(r0, 0.0, k2i)
    p2r = -((k2r * xr - k2i * xi) - k20) * t2
    p2i = -(k2r * xi + k2i * xr) * t2
    return p1r, p1i, p2r, p2i


@dataclass
class _PairGeometry:
    """k-independent geometry of a block of (receiver, sender) pairs, flattened to (P,)."""

    xsr: torch.Tensor
    ybar: torch.Tensor
    zbar: torch.Tensor
    e: torch.Tensor
    chord: torch.Tensor
    tan_sweep: torch.Tensor
    gamma_sr: torch.Tensor
    nonplanar: bool


def _pair_geometry(geom: LatticeGeometry, rows: slice) -> _PairGeometry:
    pr = _t(geom.receive[rows])
    ps, pm, pp = _t(geom.doublet), _t(geom.left), _t(geom.right)
    dy, dz = pp[:, 1] - pm[:, 1], pp[:, 2] - pm[:, 2]
    e = (0.5 * (dz**2 + dy**2) ** 0.5).abs()
    sin_g, cos_g = dz / (2.0 * e), dy / (2.0 * e)
    tan_sweep = (pp[:, 0] - pm[:, 0]) / (2.0 * e)
    gamma_s = torch.arcsin(sin_g)
    gamma_r = _t(geom.receive_dihedral[rows])
    d = pr[:, None, :] - ps[None, :, :]
    ybar = d[..., 1] * cos_g + d[..., 2] * sin_g
    zbar = d[..., 2] * cos_g - d[..., 1] * sin_g
    nrow = pr.shape[0]
    ex = e.expand(nrow, -1)
    nonplanar = bool(torch.any(zbar.abs() / ex > 0.001))
    return _PairGeometry(
        d[..., 0].reshape(-1), ybar.reshape(-1), zbar.reshape(-1), ex.reshape(-1),
        _t(geom.chord).expand(nrow, -1).reshape(-1), tan_sweep.expand(nrow, -1).reshape(-1),
        (gamma_s[None, :] - gamma_r[:, None]).reshape(-1), nonplanar)


def _station_geometry(pg: _PairGeometry, station, mach, nonplanar: bool) -> tuple:
    """k-independent inputs of :func:`_station_kernel` at ebar = station · e (Rodden 1971
    Eqs. 4, 9–11, 15–16, 21a)."""
    eb = station * pg.e
    beta2 = 1.0 - mach**2
    r1 = ((pg.ybar - eb) ** 2 + pg.zbar**2) ** 0.5
    x0 = pg.xsr - eb * pg.tan_sweep
    big_r = (x0**2 + beta2 * r1**2) ** 0.5
    u1 = (mach * big_r - x0) / (beta2 * r1)
    sq = (1.0 + u1**2) ** 0.5
    m1 = mach * r1 / big_r / sq
    k10 = -1.0 - x0 / big_r
    t1 = torch.cos(pg.gamma_sr)
    r0 = r1 == 0
    # r1 = 0 (receiver on the sending line's extension): K1 = -2, K2 = 4 downstream, 0 upstream
    r0_1 = torch.where(pg.xsr >= 0.0, -2.0, 0.0).to(torch.float64)
    out = [r1, u1, x0, m1, k10, t1, r0_1, r0]
    if nonplanar:
        t2 = pg.zbar * (pg.zbar * torch.cos(pg.gamma_sr) + (pg.ybar - eb) * torch.sin(pg.gamma_sr))
        m2 = mach**2 * r1**2 / big_r**2 / sq
        m3 = mach * r1 * ((1.0 + u1**2) * beta2 * r1**2 / big_r**2 + 2.0
                          + mach * r1 * u1 / big_r) / big_r / (1.0 + u1**2) ** 1.5
        k20 = 2.0 + x0 * (2.0 + beta2 * r1**2 / big_r**2) / big_r
        r0_2 = torch.where(pg.xsr >= 0.0, 4.0, 0.0).to(torch.float64)
        out += [t2, m2, m3, k20, r0_2]
    else:
        out += [None] * 5
    # the kernel is evaluated where u1, m1, ... are NaN (r1 = 0) and replaced there
    return tuple(out)


def _spanwise_terms(pg: _PairGeometry, kernel: str) -> dict:
    """k-independent factors of the spanwise integration (Rodden 1971 Eqs. 31–33, 40–41;
    Rodden 1998 Eqs. 22–25, 33–34)."""
    y, z, e = pg.ybar, pg.zbar, pg.e
    y2, z2, e2 = y * y, z * z, e * e
    q = y2 + z2 - e2
    ratio = 2.0 * e * z.abs() / q
    big_l = torch.log(((y - e) ** 2 + z2) / ((y + e) ** 2 + z2))
    planar = z.abs() / e <= 0.001
    ia = (ratio.abs() <= 0.3) & ~planar
    ir = (ratio.abs() > 0.3) & ~planar
    series = sum((-1.0) ** n / (2.0 * n - 1.0) * ratio ** (2 * n - 4) for n in range(2, 8))
    alpha = torch.where(ia, 4.0 * e**4 / q**2 * series, 0.0)
    if kernel == "parabolic":
        f = torch.where(planar, 2.0 * e / (y2 - e2),
                        torch.where(ia, 2.0 * e / q * (1.0 - alpha * z2 / e2),
                                    torch.where(ir, torch.atan2(2.0 * e * z.abs(), q) / z.abs(),
                                                0.0)))
        alpha = torch.where(planar, (2.0 * e2 / (y2 - e2)) ** 2,
                            torch.where(ir, (1.0 - f * q / (2.0 * e)) / z2 * e2, alpha))
        d1 = d2 = None
        eps_q = None
    else:
        d1 = torch.where(q == 0.0, 0.0, 1.0).to(torch.float64)
        d2 = torch.where(q > 0.0, 0.0, torch.where(q == 0.0, 0.5, 1.0)).to(torch.float64)
        eps_q = torch.where(planar, 2.0 * e / (y2 - e2),
                            torch.where(ia, alpha, torch.where(
                                ir, e2 / z2 * (1.0 - torch.atan(ratio) / ratio), 0.0)))
        f = torch.where(planar, d1 * 2.0 * e / (y2 - e2),
                        torch.where(ia | ir, d1 * 2.0 * e / q * (1.0 - eps_q * z2 / e2)
                                    + d2 * math.pi / z.abs(), 0.0))
    inv = (1.0 / ratio).abs()
    return dict(f=f, big_l=big_l, alpha=alpha, d1=d1, d2=d2, eps=eps_q, ratio=ratio,
                ib=(inv <= 0.1) & ~planar, ic=(inv > 0.1) & ~planar)


def _planar_part(p, pg, kernel):
    """D1 (Rodden 1971 Eq. 34 / Rodden 1998 Eq. 20) from P1 at the stations (one real part)."""
    st = _spanwise_terms(pg, kernel)
    y, z, e, ch = pg.ybar, pg.zbar, pg.e, pg.chord
    y2, z2, e2 = y * y, z * z, e * e
    f, big_l = st["f"], st["big_l"]
    if kernel == "parabolic":
        pm, ps, pp = p
        a = (pm - 2.0 * ps + pp) / (2.0 * e2)
        b = (pp - pm) / (2.0 * e)
        return ch / (math.pi * 8.0) * (((y2 - z2) * a + y * b + ps) * f
                                       + (0.5 * b + y * a) * big_l + 2.0 * e * a)
    a, b, c, d, ee = _quartic_coefficients(p, e)
    return ch / (math.pi * 8.0) * (
        ((y2 - z2) * a + y * b + c + y * (y2 - 3.0 * z2) * d
         + (y2 * y2 - 6.0 * y2 * z2 + z2 * z2) * ee) * f
        + (0.5 * b + y * a + 0.5 * (3.0 * y2 - z2) * d + 2.0 * y * (y2 - z2) * ee) * big_l
        + 2.0 * e * (a + 2.0 * y * d + (3.0 * y2 - z2 + 1.0 / 3.0 * e2) * ee))


def _quartic_coefficients(p, e):
    """A..E of the quartic fit through the five stations (Rodden 1998 Eqs. 15–19, 28–32)."""
    pm, pmh, ps, pph, pp = p
    e2 = e * e
    a = -1.0 / (6.0 * e2) * (pm - 16.0 * pmh + 30.0 * ps - 16.0 * pph + pp)
    b = 1.0 / (6.0 * e) * (pm - 8.0 * pmh + 8.0 * pph - pp)
    d = -2.0 / (3.0 * e2 * e) * (pm - 2.0 * pmh + 2.0 * pph - pp)
    ee = 2.0 / (3.0 * e2 * e2) * (pm - 4.0 * pmh + 6.0 * ps - 4.0 * pph + pp)
    return a, b, ps, d, ee


def _nonplanar_part(p, pg, kernel):
    """D2 (Rodden 1971 Eqs. 40–41 / Rodden 1998 Eqs. 33–34) from P2 (one real part)."""
    st = _spanwise_terms(pg, kernel)
    y, z, e, ch = pg.ybar, pg.zbar, pg.e, pg.chord
    y2, z2, e2 = y * y, z * z, e * e
    y4, z4 = y2 * y2, z2 * z2
    f, big_l = st["f"], st["big_l"]
    rp, rm = (y + e) ** 2 + z2, (y - e) ** 2 + z2
    if kernel == "parabolic":
        pm, ps, pp = p
        a = (pm - 2.0 * ps + pp) / (2.0 * e2)
        b = (pp - pm) / (2.0 * e)
        c = ps
        part_b = ch / (16.0 * math.pi * z2) * (
            ((y2 + z2) * a + y * b + c) * f
            + 1.0 / rp * (((y2 + z2) * y + (y2 - z2) * e) * a + (y2 + z2 + y * e) * b + (y + e) * c)
            - 1.0 / rm * (((y2 + z2) * y - (y2 - z2) * e) * a + (y2 + z2 - y * e) * b
                          + (y - e) * c))
        part_c = ch * e / (8.0 * math.pi * (y2 + z2 - e2)) * (
            (2.0 * (y2 + z2 + e2) * (e2 * a + c) + 4.0 * y * e2 * b) / (rp * rm)
            - st["alpha"] / e2 * ((y2 + z2) * a + y * b + c))
    else:
        a, b, c, d, ee = _quartic_coefficients(p, e)
        part_b = ch / (16.0 * math.pi * z2) * (
            f * ((y2 + z2) * a + y * b + c + y * (y2 + 3.0 * z2) * d
                 + (y4 + 6.0 * y2 * z2 - 3.0 * z4) * ee)
            + 1.0 / rp * (((y2 + z2) * y + (y2 - z2) * e) * a + (y2 + z2 + y * e) * b
                          + (y + e) * c + (y4 - z4 + (y2 - 3.0 * z2) * y * e) * d
                          + ((y4 - 2.0 * y2 * z2 - 3.0 * z4) * y
                             + (y4 - 6.0 * y2 * z2 + z4) * e) * ee)
            - 1.0 / rm * (((y2 + z2) * y - (y2 - z2) * e) * a + (y2 + z2 - y * e) * b
                          + (y - e) * c + (y4 - z4 - (y2 - 3.0 * z2) * y * e) * d
                          + ((y4 - 2.0 * y2 * z2 - 3.0 * z4) * y
                             - (y4 - 6.0 * y2 * z2 + z4) * e) * ee)
            + (z2 * big_l) * d + 4.0 * z2 * (e + y * big_l) * ee)
        d1, d2, eps_q, ratio = st["d1"], st["d2"], st["eps"], st["ratio"]
        part_c = ch * e / (8.0 * math.pi * (y2 + z2 - e2)) * (
            1.0 / (rp * rm) * (
                2.0 * (y2 + z2 + e2) * (e2 * a + c) + 4.0 * y * e2 * b
                + 2.0 * y * (y4 - 2.0 * e2 * y2 + 2.0 * y2 * z2 + 3.0 * e2 * e2 + 2.0 * e2 * z2
                             + z4) * d
                + 2.0 * (3.0 * y4 * y2 - 7.0 * e2 * y4 + 5.0 * y4 * z2 + 6.0 * e2 * e2 * y2
                         + 6.0 * e2 * y2 * z2 - 3.0 * e2 * z4 - z4 * z2 + y2 * z4
                         - 2.0 * e2 * e2 * z2) * ee)
            - (d1 * eps_q + e2 / z2 * (1.0 - d1 - d2 * math.pi / ratio)) / e2
            * ((y2 + z2) * a + y * b + c + y * (y2 + 3.0 * z2) * d
               + (y4 + 6.0 * y2 * z2 - 3.0 * z4) * ee)
        ) + ch / (8.0 * math.pi) * (d / 2.0 * big_l + 2.0 * (e + y * big_l) * ee)
    return torch.where(st["ib"], part_b, torch.where(st["ic"], part_c, 0.0))


def _aic_block(kpa, pg, mach, kernel: str, compiled: bool):
    """Oscillatory AIC (re, im) of one pair block at the frequencies ``kpa`` (nk, 1)."""
    if compiled and _COMPILED != [False]:
        try:
            return _evaluate(kpa, pg, mach, kernel, _functions(True))
        except Exception:  # compiling failed (no C++ toolchain...): the same math, eagerly
            _COMPILED[:] = [False]
    return _evaluate(kpa, pg, mach, kernel, _functions(False))


def _evaluate(kpa, pg, mach, kernel, functions):
    station, planar, nonplanar = functions
    # stations and Mach as 0-d tensors: as Python floats each value would compile anew
    m = torch.tensor(float(mach), dtype=torch.float64)
    vals = [station(kpa, pg, torch.tensor(s, dtype=torch.float64), m, fit=kernel,
                    nonplanar=pg.nonplanar) for s in _STATIONS[kernel]]
    d_re = planar([v[0] for v in vals], pg, kernel)
    d_im = planar([v[1] for v in vals], pg, kernel)
    if pg.nonplanar:
        d_re = d_re + nonplanar([v[2] for v in vals], pg, kernel)
        d_im = d_im + nonplanar([v[3] for v in vals], pg, kernel)
    return d_re, d_im


_COMPILED: list = []


def _functions(compiled: bool):
    """(station kernel, planar part, nonplanar part), compiled once per process when asked
    (three small graphs compile far faster than one)."""
    plain = (_station_kernel, _planar_part, _nonplanar_part)
    if not compiled:
        return plain
    if not _COMPILED:
        _COMPILED.extend(torch.compile(f, dynamic=True) for f in plain)
    return tuple(_COMPILED)


def oscillatory_aic(geom: LatticeGeometry, mach: float, k_list, kernel: str = "quartic",
                    compile: bool | None = None):
    """Yield ``(k_indices, D)``: the oscillatory AIC increments D (nk_chunk, nr, ns) complex
    for chunks of PanelAero-convention reduced frequencies k = ω/V (all > 0).

    ``compile``: fuse the kernel with ``torch.compile`` (None: when the problem is large).
    """
    if kernel not in _STATIONS:
        raise InputError(f"DLM kernel: expected one of {KERNELS}, got {kernel!r}")
    k = np.asarray(k_list, dtype=float).reshape(-1)
    if np.any(~(k > 0)):
        raise InputError(f"DLM: oscillatory part needs reduced frequencies > 0, got {k_list!r}")
    nr, ns = geom.shape
    if compile is None:
        compile = len(k) * nr * ns >= COMPILE_MIN_ELEMENTS
    # k chunks of at least two frequencies (see below) and within the output budget; row
    # blocks within the element budget
    k_per = int(np.clip(OUTPUT_BYTES // (16 * nr * ns), 2, max(2, min(len(k), K_PER_CHUNK))))
    budget = CHUNK_ELEMENTS if compile else EAGER_CHUNK_ELEMENTS
    rows_per = max(1, min(nr, budget // (max(ns, 1) * k_per)))
    row_blocks = [slice(i, min(i + rows_per, nr)) for i in range(0, nr, rows_per)]
    threads = torch.get_num_threads()
    try:
        # one thread: on shared cores torch's intra-op barriers cost more than they gain
        # (measured 40x slower eagerly with 2 threads on 2 busy cores)
        torch.set_num_threads(1)
        yield from _chunks(geom, mach, k, kernel, compile, k_per, row_blocks)
    finally:
        torch.set_num_threads(threads)


def _chunks(geom, mach, k, kernel, compile, k_per, row_blocks):
    nr, ns = geom.shape
    for k0 in range(0, len(k), k_per):
        idx = np.arange(k0, min(k0 + k_per, len(k)))
        # a chunk of one k is evaluated twice: a size-1 dimension would be specialised by the
        # compiler and compile a second set of kernels
        kpa = torch.as_tensor(k[np.r_[idx, idx[:1]] if len(idx) == 1 else idx],
                              dtype=torch.float64)[:, None]
        out = np.empty((len(idx), nr, ns), dtype=complex)
        for rows in row_blocks:
            d_re, d_im = _aic_block(kpa, _pair_geometry(geom, rows), mach, kernel, compile)
            nrow = rows.stop - rows.start
            out[:, rows, :].real = d_re[:len(idx)].reshape(len(idx), nrow, ns).numpy()
            out[:, rows, :].imag = d_im[:len(idx)].reshape(len(idx), nrow, ns).numpy()
        yield idx, out
