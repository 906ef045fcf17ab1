"""Splines from structural grids to aerodynamic boxes (SPLINE1-like and SPLINE2-like).

Written here (numpy/scipy): the infinite-plate spline of Harder & Desmarais (Nastran SPLINE1:
w = a0 + a1 x + a2 y + Σ F_i r_i² ln r_i², with Σ F_i = Σ F_i x_i = Σ F_i y_i = 0) and a beam
spline along an axis (Nastran SPLINE2-like: bending deflection w(s), bending slope dw/ds and
torsion θ(s) along the y axis of the spline coordinate system). Both are *linear operators*:
``operators(points)`` returns matrices H, Hx with h = H u and ∂h/∂x = Hx u at the points, where
u is the flattened (n_grid, 6) field T1..T3, R1..R3 of the spline's grids in BASIC axes (the
layout of ``FEModel.expand``). h is the displacement along the box normal and ∂h/∂x its slope in
the flow (basic x) direction, as the doublet-lattice normalwash needs.

Simplifications (documented, not Nastran's exact algebra): the spline is exact-interpolating
(DZ acts only as a diagonal regularisation of the plate spline; DTOR, DTHX, DTHY only switch the
attachment of the rotations on (>= 0) or off (< 0)); the beam spline is a cubic Hermite
interpolant when the bending slopes are attached, a natural cubic spline through the deflections
otherwise, with linear extrapolation beyond the end grids, and a piecewise-linear torsion with
constant extrapolation (the shapes of a beam under end loads between attachment points).
Both reproduce rigid plunge and pitch exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy

from ..errors import InputError


def _merge_coincident(xy: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Unique points (within ``tol``) and the averaging matrix unique <- original."""
    n = len(xy)
    key = np.round(xy / tol).astype(np.int64)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    avg = np.zeros((len(first), n))
    avg[inverse, np.arange(n)] = 1.0
    avg /= avg.sum(axis=1, keepdims=True)
    return avg @ xy, avg


@dataclass
class PlateSpline:
    """Infinite-plate (thin-plate) spline on the plane through ``origin`` with normal ``normal``.

    grid_xyz: (n_grid, 3) basic positions of the spline's structural grids; the displacement
    component along ``normal`` is interpolated. ``dz`` regularises (smooths) the fit.
    """

    grid_xyz: np.ndarray
    normal: np.ndarray = (0.0, 0.0, 1.0)
    dz: float = 0.0

    def __post_init__(self):
        self.grid_xyz = np.asarray(self.grid_xyz, dtype=float).reshape(-1, 3)
        nrm = np.asarray(self.normal, dtype=float)
        self.normal = nrm / np.linalg.norm(nrm)
        # In-plane axes: x along the flow (basic x projected on the plane), s across it.
        ex = np.array([1.0, 0.0, 0.0]) - self.normal[0] * self.normal
        if np.linalg.norm(ex) < 1e-8:
            raise InputError("SPLINE1: the spline plane is normal to the flow (x) direction")
        self._ex = ex / np.linalg.norm(ex)
        self._es = np.cross(self.normal, self._ex)
        xy = self._local(self.grid_xyz)
        scale = float(np.ptp(xy, axis=0).max()) or 1.0
        self._scale = scale
        uxy, self._avg = _merge_coincident(xy / scale, 1e-9)
        if len(uxy) < 3 or np.linalg.matrix_rank(np.c_[np.ones(len(uxy)), uxy]) < 3:
            raise InputError(
                "SPLINE1: needs at least three structural grids that are not on one line "
                f"(got {len(uxy)} distinct points)"
            )
        self._uxy = uxy
        n = len(uxy)
        a = np.zeros((n + 3, n + 3))
        a[:n, :n] = self._kernel(uxy[:, None, :] - uxy[None, :, :]) + self.dz * np.eye(n)
        p = np.c_[np.ones(n), uxy]
        a[:n, n:] = p
        a[n:, :n] = p.T
        # Coefficients [F; a] = inv(A)[:, :n] w_unique
        self._coef = np.linalg.solve(a, np.r_[np.eye(n), np.zeros((3, n))])

    def _local(self, xyz: np.ndarray) -> np.ndarray:
        return np.c_[xyz @ self._ex, xyz @ self._es]

    @staticmethod
    def _kernel(d: np.ndarray) -> np.ndarray:
        r2 = np.sum(d**2, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(r2 > 0.0, r2 * np.log(r2), 0.0)
        return k / (16.0 * np.pi)

    @staticmethod
    def _kernel_dx(d: np.ndarray) -> np.ndarray:
        r2 = np.sum(d**2, axis=-1)
        with np.errstate(divide="ignore", invalid="ignore"):
            k = np.where(r2 > 0.0, 2.0 * d[..., 0] * (np.log(r2) + 1.0), 0.0)
        return k / (16.0 * np.pi)

    def scalar_operators(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Matrices (n_pts, n_grid) giving w and ∂w/∂x at ``points`` from the grids' normal w."""
        xy = self._local(np.asarray(points, dtype=float).reshape(-1, 3)) / self._scale
        d = xy[:, None, :] - self._uxy[None, :, :]
        n = len(self._uxy)
        basis = np.c_[self._kernel(d), np.ones(len(xy)), xy]
        basis_x = np.c_[self._kernel_dx(d), np.zeros(len(xy)), np.ones(len(xy)), np.zeros(len(xy))]
        # ∂/∂x in the plane's x; the flow x differs only for a plane inclined about y.
        h = basis @ self._coef[: n + 3] @ self._avg
        hx = (basis_x @ self._coef[: n + 3] @ self._avg) / self._scale
        return h, hx * self._ex[0]

    def operators(self, points) -> tuple[np.ndarray, np.ndarray]:
        """H, Hx (n_pts, n_grid*6) acting on the flattened (n_grid, 6) basic displacement field."""
        h, hx = self.scalar_operators(points)
        pick = np.kron(np.eye(len(self.grid_xyz)), np.r_[self.normal, np.zeros(3)][None, :])
        return h @ pick, hx @ pick


@dataclass
class BeamSpline:
    """Beam spline along the y axis of a coordinate system (Nastran SPLINE2-like).

    origin, axes: the spline coordinate system (rows of ``axes`` are its x, y, z unit vectors in
    basic); the beam runs along y, deflects along z and twists about y.
    attach_slope: use the grids' bending rotations (about the spline x axis; DTHX >= 0).
    attach_torsion: use the grids' torsional rotations (about the spline y axis; DTHY >= 0).
    """

    grid_xyz: np.ndarray
    origin: np.ndarray = (0.0, 0.0, 0.0)
    axes: np.ndarray = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    attach_slope: bool = True
    attach_torsion: bool = True

    def __post_init__(self):
        self.grid_xyz = np.asarray(self.grid_xyz, dtype=float).reshape(-1, 3)
        self.origin = np.asarray(self.origin, dtype=float)
        self.axes = np.asarray(self.axes, dtype=float)
        s = (self.grid_xyz - self.origin) @ self.axes[1]
        self._order = np.argsort(s)
        self._s = s[self._order]
        if len(self._s) < 2 or np.any(np.diff(self._s) <= 1e-12 * max(1.0, np.ptp(self._s))):
            raise InputError(
                "SPLINE2: needs at least two structural grids at distinct positions along the "
                "spline axis"
            )

    def _interp(self, s_eval: np.ndarray):
        """Operators (n_pts, n) for w(s), w'(s) from w_i (and w'_i), θ(s), θ'(s) from θ_i."""
        s, n = self._s, len(self._s)
        eye = np.eye(n)
        if self.attach_slope:
            spl_w = scipy.interpolate.CubicHermiteSpline(s, eye, np.zeros((n, n)))  # from w_i
            spl_d = scipy.interpolate.CubicHermiteSpline(s, np.zeros((n, n)), eye)  # from w'_i
        else:
            # Natural cubic spline = beam under point loads at the grids (a line for 2 grids).
            spl_w = scipy.interpolate.CubicSpline(s, eye, bc_type="natural")
            spl_d = None
        inside = np.clip(s_eval, s[0], s[-1])
        ds = s_eval - inside  # linear extrapolation beyond the end grids
        w = spl_w(inside) + ds[:, None] * spl_w(inside, 1)
        wd = spl_w(inside, 1)
        if spl_d is not None:
            w_from_d = spl_d(inside) + ds[:, None] * spl_d(inside, 1)
            wd_from_d = spl_d(inside, 1)
        else:
            w_from_d = wd_from_d = np.zeros((len(s_eval), n))
        # Torsion: piecewise linear between grids, constant beyond the ends.
        idx = np.clip(np.searchsorted(s, inside, side="right") - 1, 0, n - 2)
        t = (inside - s[idx]) / (s[idx + 1] - s[idx])
        th = np.zeros((len(s_eval), n))
        th[np.arange(len(s_eval)), idx] = 1 - t
        th[np.arange(len(s_eval)), idx + 1] += t
        thd = np.zeros((len(s_eval), n))
        interior = ds == 0
        rows = np.arange(len(s_eval))[interior]
        h = s[idx[interior] + 1] - s[idx[interior]]
        thd[rows, idx[interior]] = -1 / h
        thd[rows, idx[interior] + 1] = 1 / h
        return w, wd, w_from_d, wd_from_d, th, thd

    def operators(self, points) -> tuple[np.ndarray, np.ndarray]:
        """H, Hx (n_pts, n_grid*6) acting on the flattened (n_grid, 6) basic displacement field."""
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        ex, ey, ez = self.axes
        rel = pts - self.origin
        s_eval, d = rel @ ey, rel @ ex
        w, wd, w_d, wd_d, th, thd = self._interp(s_eval)
        n = len(self._s)
        # Per (sorted) grid data in spline axes: w = T·ez, w' = R·ex, θ = R·ey. A grid off the
        # axis by d_i along x carries its deflection to the axis over a rigid arm: + d_i θ_i.
        d_grid = ((self.grid_xyz - self.origin) @ ex)[self._order]
        sel_w = np.zeros((n, 6))
        sel_w[:, :3] = ez
        if self.attach_torsion:
            sel_w[:, 3:] = d_grid[:, None] * ey[None, :]
        sel_slope = np.zeros((n, 6))
        sel_slope[:, 3:] = ex
        sel_tor = np.zeros((n, 6))
        sel_tor[:, 3:] = ey
        # h = w(s) - d θ(s);  ∂h/∂x = (w' - d θ') (ey·x̂) - θ (ex·x̂)
        slope_on = 1.0 if self.attach_slope else 0.0
        tor_on = 1.0 if self.attach_torsion else 0.0
        ey_x, ex_x = ey[0], ex[0]
        h_blocks = []
        hx_blocks = []
        for i in range(n):
            h_i = np.outer(w[:, i], sel_w[i]) + slope_on * np.outer(w_d[:, i], sel_slope[i])
            h_i -= tor_on * np.outer(d * th[:, i], sel_tor[i])
            hx_i = ey_x * (
                np.outer(wd[:, i], sel_w[i]) + slope_on * np.outer(wd_d[:, i], sel_slope[i])
            )
            hx_i -= tor_on * np.outer(d * thd[:, i] * ey_x + th[:, i] * ex_x, sel_tor[i])
            h_blocks.append(h_i)
            hx_blocks.append(hx_i)
        h_sorted = np.stack(h_blocks, axis=1)  # (n_pts, n, 6) in sorted-grid order
        hx_sorted = np.stack(hx_blocks, axis=1)
        inv = np.empty(n, int)
        inv[self._order] = np.arange(n)
        return (
            h_sorted[:, inv, :].reshape(len(pts), n * 6),
            hx_sorted[:, inv, :].reshape(len(pts), n * 6),
        )


@dataclass
class SectionSpline:
    """Chordwise-rigid strip spline for a wing box with rigid ribs (built-in Goland planform).

    At every spanwise station (grids with the same y within ``tol``) the normal displacements are
    fitted by least squares with a chordwise-rigid section, w = a + b (x - x_ref); a(y) and b(y)
    are then interpolated spanwise by cubic splines (not-a-knot; linear extrapolation beyond the
    end stations). A box point gets h = a(y) + b(y) (x - x_ref) and ∂h/∂x = b(y). Exact for
    rigid sections whose deflection and twist are cubic in y; extrapolates chordwise exactly
    (unlike a plate spline) beyond the structural box.
    """

    grid_xyz: np.ndarray
    x_ref: float = 0.0
    tol: float = 1e-6

    def __post_init__(self):
        self.grid_xyz = np.asarray(self.grid_xyz, dtype=float).reshape(-1, 3)
        y = self.grid_xyz[:, 1]
        key = np.round(y / self.tol).astype(np.int64)
        stations, inverse = np.unique(key, return_inverse=True)
        inverse = inverse.reshape(-1)
        n_grid = len(y)
        self._y = np.array([y[inverse == j].mean() for j in range(len(stations))])
        if len(self._y) < 2:
            raise InputError("section spline: needs structural grids at two or more span stations")
        # per station: [a; b] = pinv([1, x - x_ref]) w_station
        self._a = np.zeros((len(self._y), n_grid))
        self._b = np.zeros((len(self._y), n_grid))
        for j in range(len(self._y)):
            idx = np.flatnonzero(inverse == j)
            dx = self.grid_xyz[idx, 0] - self.x_ref
            if np.ptp(dx) > self.tol:
                coef = np.linalg.pinv(np.c_[np.ones(len(idx)), dx])
                self._a[j, idx], self._b[j, idx] = coef[0], coef[1]
            else:  # one chordwise position: deflection only
                self._a[j, idx] = 1.0 / len(idx)

    def _span(self, y):
        s = self._y
        n = len(s)
        eye = np.eye(n)
        spl = scipy.interpolate.CubicSpline(s, eye, bc_type="not-a-knot" if n >= 4 else "natural")
        inside = np.clip(y, s[0], s[-1])
        return spl(inside) + (y - inside)[:, None] * spl(inside, 1)

    def operators(self, points) -> tuple[np.ndarray, np.ndarray]:
        """H, Hx (n_pts, n_grid*6) acting on the flattened (n_grid, 6) basic displacement field."""
        pts = np.asarray(points, dtype=float).reshape(-1, 3)
        span = self._span(pts[:, 1])  # (n_pts, n_stations)
        a, b = span @ self._a, span @ self._b  # (n_pts, n_grid) from grid T3
        h = a + (pts[:, 0] - self.x_ref)[:, None] * b
        pick = np.kron(np.eye(len(self.grid_xyz)), np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]))
        return h @ pick, b @ pick
