"""Rational function approximation (RFA) of generalized aerodynamic forces: Roger, minimum-state.

Written here (numpy/scipy least squares). The approximation in the Laplace variable p = s b / V
(b = reference semichord, so p = ik on the imaginary axis) is

    Q(p) ≈ A0 + A1 p + A2 p² + D (p I - R)⁻¹ E p                                   (paper Eq. 49–50)

* Roger (1977): one m × m lag matrix per lag root γ_l; in state-space form
  D = [A_3 … A_{n_L+2}], R = -diag(γ_l I_m), E = [I_m; …; I_m] (n_a = m n_L states).
* Minimum state (Karpel 1982): D (m × n_L), E (n_L × m), R = -diag(γ_l) (n_a = n_L states), fitted
  by alternating least squares (D fixed → E, A1, A2 column by column; E fixed → D, A1, A2 row by
  row), each entry weighted by 1 / max(max_k |Q_ij(k)|, floor), then polished by a joint
  Levenberg–Marquardt least-squares step.

A0 = Q(0) is imposed (static consistency); A1 and A2 can be switched off. Default lag roots
γ_l = 1.7 k_max (l / (n_L + 1))² (REFERENCE Sec. 7); optionally optimised (log γ, Nelder–Mead).

The time-domain form the integrator uses (paper Eqs. 49–50, b = semichord):
    F_aero = -q∞ (b²/V²) A2 q̈ - q∞ (b/V) A1 q̇ - q∞ A0 q - q∞ D ξ,   ξ̇ = E q̇ + (V/b) R ξ.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy

from ..errors import ConvergenceError, InputError
from .dlm import GAF


def default_lag_roots(n_lags: int, k_max: float) -> np.ndarray:
    """γ_l = 1.7 k_max (l / (n_L + 1))², l = 1..n_L (the common minimum-state default)."""
    from ..bounds import MAX_LAGS, check_count

    check_count("RFA", "lag states", n_lags, MAX_LAGS)
    if n_lags < 0 or not k_max > 0:
        raise InputError(
            f"RFA: lag roots: expected n_lags >= 0 and k_max > 0, got {n_lags}, {k_max}"
        )
    j = np.arange(1, n_lags + 1)
    return 1.7 * k_max * (j / (n_lags + 1)) ** 2


@dataclass
class RFA:
    """A fitted RFA in the paper's state-space form (Eqs. 49–50). Q sign: F_aero = -q∞ Q q."""

    A0: np.ndarray
    A1: np.ndarray
    A2: np.ndarray
    D: np.ndarray
    R: np.ndarray
    E: np.ndarray
    lag_roots: np.ndarray
    kind: str
    semichord: float
    mach: float = float("nan")
    fit_error: dict = field(default_factory=dict)

    @property
    def n_modes(self) -> int:
        return self.A0.shape[0]

    @property
    def n_states(self) -> int:
        return self.R.shape[0]

    def evaluate(self, k) -> np.ndarray:
        """Q̃(ik), shape (nk, m, m)."""
        return self.evaluate_p(1j * np.asarray(k, dtype=float).reshape(-1))

    def evaluate_p(self, p) -> np.ndarray:
        """Q̃(p) for complex Laplace variables p = s b / V, shape (np, m, m)."""
        p = np.asarray(p, dtype=complex).reshape(-1)
        r_diag = np.diag(self.R)
        out = np.empty((len(p), self.n_modes, self.n_modes), dtype=complex)
        for i, pi in enumerate(p):
            lag = self.D @ ((pi / (pi - r_diag))[:, None] * self.E)
            out[i] = self.A0 + self.A1 * pi + self.A2 * pi**2 + lag
        return out


def quasi_steady_slope(gaf: GAF) -> tuple[np.ndarray, float]:
    """(dQ/dp at p = 0 from the table, the k it is taken at): Im Q(ik_d) / k_d at the lowest
    positive tabulated k_d. Q(ik) = Q0 + ik Q1 - k² Q2 - ik³ Q3 ..., so the real matrix
    Im Q(ik_d) / k_d = Q1 - k_d² Q3: its error is O(k_d²) (1e-6 relative at bah_plane's
    MKAERO k = 0.001)."""
    positive = np.flatnonzero(gaf.k > 0)
    if len(positive) == 0:
        raise InputError("RFA: the reduced-frequency list has no k > 0 (no quasi-steady slope)")
    i = positive[np.argmin(gaf.k[positive])]
    return gaf.Q[i].imag / gaf.k[i], float(gaf.k[i])


def slope_at_zero(rfa: RFA) -> np.ndarray:
    """dQ̃/dp at p = 0 of the RFA: A1 - D R⁻¹ E (the lag term D (pI - R)⁻¹ E p adds -D R⁻¹ E)."""
    if rfa.n_states == 0:
        return rfa.A1.copy()
    return rfa.A1 - rfa.D @ np.linalg.solve(rfa.R, rfa.E)


def impose_quasi_steady_slope(rfa: RFA, gaf: GAF, columns, weight_floor: float = 1.0) -> RFA:
    """The RFA with the k -> 0 slope dQ̃/dp(0) of the given mode columns j set to the table's
    (:func:`quasi_steady_slope`); Q̃(0) = A0 is already exact. Each column's missing slope
    Δ_j is added as one lag state at the root γ0 = k_d, the lowest positive tabulated k:
    Δ_j γ0 p / (p + γ0) has the slope Δ_j at p = 0 and stays below |Δ_j| γ0 at every k (a
    correction of A1 instead, Δ_j p, grows with k: 20 % of Q at k = 1 on bah_plane). Its
    ``fit_error`` is recomputed (entry weights with ``weight_floor``, as the fit's report).

    Why: a free aircraft's rigid-body columns obey a kinematic identity at k -> 0: the plunge
    velocity's force equals the steady pitch's (dQ_h/dp(0) = c Q_θ(0); a climb at constant
    speed is force-free), which makes the altitude and the flight-path angle an exact double
    root s = 0. The least-squares fit keeps it only to its fit error (bah_plane: 6e-4 relative),
    and the double root splits into a spurious real root (+0.011 1/s at 300 m/s)."""
    cols = np.flatnonzero(np.asarray(columns, dtype=bool))
    if len(cols) == 0:
        return rfa
    target, k_d = quasi_steady_slope(gaf)
    delta = (target - slope_at_zero(rfa))[:, cols]  # (m, r)
    r, m = len(cols), rfa.n_modes
    select = np.zeros((r, m))
    select[np.arange(r), cols] = 1.0
    roots = np.concatenate([rfa.lag_roots, np.full(r, k_d)])
    out = RFA(rfa.A0, rfa.A1, rfa.A2, np.hstack([rfa.D, k_d * delta]),
              scipy.linalg.block_diag(rfa.R, -k_d * np.eye(r)), np.vstack([rfa.E, select]),
              roots, rfa.kind, rfa.semichord, rfa.mach)
    out.fit_error = fit_error(gaf.Q, out.evaluate(gaf.k), _weights(gaf.Q, weight_floor))
    return out


def _weights(q: np.ndarray, floor: float) -> np.ndarray:
    return 1.0 / np.maximum(np.abs(q).max(axis=0), floor)


def fit_error(q_data: np.ndarray, q_fit: np.ndarray, weights: np.ndarray) -> dict:
    """Fit-error report: weighted RMS (relative), worst weighted error, worst entry (relative)."""
    err = q_fit - q_data
    wq = weights[None] * q_data
    we = weights[None] * err
    scale = np.abs(q_data).max(axis=0)
    big = scale > 1e-3 * scale.max()
    per_entry = np.where(big, np.abs(err).max(axis=0) / np.where(big, scale, 1.0), 0.0)
    i, j = np.unravel_index(int(np.argmax(per_entry)), per_entry.shape)
    return {
        "rms_relative": float(np.sqrt((np.abs(we) ** 2).sum() / (np.abs(wq) ** 2).sum())),
        "max_weighted": float(np.abs(we).max()),
        "max_entry_relative": float(per_entry[i, j]),
        "worst_entry": [int(i), int(j)],
    }


def _prepare(gaf: GAF, include_a1: bool, include_a2: bool):
    k, q = gaf.k, gaf.Q
    at0 = np.flatnonzero(k == 0.0)
    if len(at0) == 0:
        raise InputError(
            "RFA: the reduced-frequency list must include k = 0 (A0 = Q(0) constraint)"
        )
    a0 = q[at0[0]].real.copy()
    use = k > 0
    p = 1j * k[use]
    rhs = q[use] - a0[None]  # (nk, m, m)
    poly = []
    if include_a1:
        poly.append(p)
    if include_a2:
        poly.append(p**2)
    return a0, p, rhs, np.array(poly).reshape(len(poly), len(p))


def _stack_complex(a: np.ndarray) -> np.ndarray:
    """Real least-squares rows from complex rows: [Re; Im] along axis 0."""
    return np.concatenate([a.real, a.imag], axis=0)


def fit_roger(
    gaf: GAF,
    n_lags: int = 4,
    lag_roots=None,
    include_a1: bool = True,
    include_a2: bool = True,
) -> RFA:
    """Roger's RFA: one lag matrix per root, fitted entry by entry (A0 = Q(0) imposed)."""
    gam = (
        default_lag_roots(n_lags, gaf.k.max())
        if lag_roots is None
        else np.asarray(lag_roots, float)
    )
    a0, p, rhs, poly = _prepare(gaf, include_a1, include_a2)
    m = gaf.n_modes
    lags = p[None, :] / (p[None, :] + gam[:, None])  # (nL, nk)
    basis = np.concatenate([poly, lags], axis=0).T  # (nk, nb)
    a = _stack_complex(basis)
    b = _stack_complex(rhs.reshape(len(p), m * m))
    coef, *_ = np.linalg.lstsq(a, b, rcond=None)  # (nb, m*m)
    coef = coef.reshape(-1, m, m)
    npoly = len(poly)
    a1 = coef[0] if include_a1 else np.zeros((m, m))
    a2 = coef[npoly - 1] if include_a2 else np.zeros((m, m))
    nl = len(gam)
    d = np.concatenate([coef[npoly + l] for l in range(nl)], axis=1) if nl else np.zeros((m, 0))
    r = -np.kron(np.diag(gam), np.eye(m)) if nl else np.zeros((0, 0))
    e = np.tile(np.eye(m), (nl, 1)) if nl else np.zeros((0, m))
    rfa = RFA(a0, a1, a2, d, r, e, gam, "roger", gaf.semichord, gaf.mach)
    rfa.fit_error = fit_error(gaf.Q, rfa.evaluate(gaf.k), _weights(gaf.Q, 1.0))
    return rfa


WEIGHTINGS = ("entry", "point")


def _residual_weights(q: np.ndarray, floor: float, weighting: str):
    """Weights (nk, m, m) of the real and of the imaginary residuals at the fitted frequencies.

    "entry" (Karpel; REFERENCE Sec. 7): W_ij = 1 / max(max_k |Q_ij(k)|, floor) for both parts.
    "point": each part relative to its own size at that frequency,
    W_ij(k) = 1 / max(|part Q_ij(k)|, 0.1 max_k |part Q_ij|, floor) — so that the small
    imaginary (aerodynamic damping) parts of the bending–torsion coupling at low k, which drive
    flutter, are fitted as well as the large apparent-mass terms at high k.
    """
    if weighting == "entry":
        w = np.broadcast_to(1.0 / np.maximum(np.abs(q).max(axis=0), floor), q.shape).copy()
        return w, w
    if weighting == "point":
        out = []
        for part in (q.real, q.imag):
            size = np.abs(part)
            out.append(1.0 / np.maximum(size, np.maximum(0.1 * size.max(axis=0), floor)[None]))
        return tuple(out)
    raise InputError(f"RFA: weighting: expected one of {WEIGHTINGS}, got {weighting!r}")


def _weighted_rows(a: np.ndarray, w_re: np.ndarray, w_im: np.ndarray) -> np.ndarray:
    """Real least-squares rows [w_re Re(a); w_im Im(a)] (weights per complex row)."""
    shape = (-1,) + (1,) * (a.ndim - 1)
    return np.concatenate([a.real * w_re.reshape(shape), a.imag * w_im.reshape(shape)], axis=0)


class _MinStateProblem:
    """The weighted minimum-state least-squares problem for fixed lag roots.

    Residual r_kij = [A1 p + A2 p² + D (pI - R)⁻¹ E p - (Q - A0)]_ij at p = ik, its real part
    weighted by w_re[k, i, j] and its imaginary part by w_im[k, i, j].
    """

    def __init__(self, gaf: GAF, gam, include_a1, include_a2, weight_floor, weighting="entry"):
        self.a0, self.p, self.rhs, self.poly = _prepare(gaf, include_a1, include_a2)
        self.gam = np.asarray(gam, dtype=float)
        self.w_re, self.w_im = _residual_weights(gaf.Q[gaf.k > 0], weight_floor, weighting)
        self.m = gaf.n_modes
        self.nl = len(self.gam)
        self.npoly = len(self.poly)
        self.lag = self.p[:, None] / (self.p[:, None] + self.gam[None, :])  # (nk, nL)

    def _solve(self, coupling, rhs, w_re, w_im):
        """Least squares for one column (or row): unknowns [poly coefs (npoly·m); lag (nL)].

        coupling: (nk, m, nL) complex lag basis per residual; rhs: (nk, m); weights (nk, m).
        """
        m, nk = self.m, len(self.p)
        eye = np.eye(m)
        blocks = [
            (self.poly[t][:, None, None] * eye[None]).reshape(nk * m, m) for t in range(self.npoly)
        ]
        blocks.append(coupling.reshape(nk * m, self.nl))
        a = _weighted_rows(np.concatenate(blocks, axis=1), w_re.ravel(), w_im.ravel())
        b = _weighted_rows(rhs.reshape(nk * m), w_re.ravel(), w_im.ravel())
        x, *_ = np.linalg.lstsq(a, b, rcond=None)
        return x[: self.npoly * m].reshape(self.npoly, m), x[self.npoly * m :]

    def solve_e(self, d):
        """D fixed: columns j of (A_poly, E) by weighted least squares."""
        polys = np.zeros((self.npoly, self.m, self.m))
        e = np.zeros((self.nl, self.m))
        for j in range(self.m):
            coupling = self.lag[:, None, :] * d[None, :, :]  # (nk, m_i, nL)
            pj, e[:, j] = self._solve(
                coupling, self.rhs[:, :, j], self.w_re[:, :, j], self.w_im[:, :, j]
            )
            polys[:, :, j] = pj
        return polys, e

    def solve_d(self, e):
        """E fixed: rows i of (A_poly, D) by weighted least squares."""
        polys = np.zeros((self.npoly, self.m, self.m))
        d = np.zeros((self.m, self.nl))
        for i in range(self.m):
            coupling = self.lag[:, None, :] * e.T[None, :, :]  # (nk, m_j, nL)
            pi, d[i, :] = self._solve(
                coupling, self.rhs[:, i, :], self.w_re[:, i, :], self.w_im[:, i, :]
            )
            polys[:, i, :] = pi
        return polys, d

    def model(self, polys, d, e):
        out = np.einsum("tk,tij->kij", self.poly, polys) if self.npoly else 0.0
        return out + np.einsum("il,kl,lj->kij", d, self.lag, e)

    def fun(self, x):
        r = self.model(*self.unpack(x)) - self.rhs
        return np.concatenate([(r.real * self.w_re).ravel(), (r.imag * self.w_im).ravel()])

    def cost(self, polys, d, e) -> float:
        return float((self.fun(self.pack(polys, d, e)) ** 2).sum())

    # -- joint Levenberg–Marquardt polish ------------------------------------------------------
    def pack(self, polys, d, e):
        return np.concatenate([polys.ravel(), d.ravel(), e.ravel()])

    def unpack(self, x):
        m, nl, npl = self.m, self.nl, self.npoly
        polys = x[: npl * m * m].reshape(npl, m, m)
        d = x[npl * m * m : npl * m * m + m * nl].reshape(m, nl)
        e = x[npl * m * m + m * nl :].reshape(nl, m)
        return polys, d, e

    def jac(self, x):
        _, d, e = self.unpack(x)
        m, nl, npl, nk = self.m, self.nl, self.npoly, len(self.p)
        n_res = nk * m * m
        cols = []
        # ∂r_kij/∂poly_t,ab = poly_t(k) δ_ia δ_jb
        jp = np.zeros((n_res, npl * m * m), dtype=complex)
        idx = np.arange(m * m)
        for t in range(npl):
            for kk in range(nk):
                jp[kk * m * m + idx, t * m * m + idx] = self.poly[t, kk]
        cols.append(jp)
        # ∂r_kij/∂D_il = lag_kl E_lj
        jd = np.zeros((nk, m, m, m, nl), dtype=complex)
        for i in range(m):
            jd[:, i, :, i, :] = self.lag[:, None, :] * e.T[None, :, :]
        cols.append(jd.reshape(n_res, m * nl))
        # ∂r_kij/∂E_lj = D_il lag_kl
        je = np.zeros((nk, m, m, nl, m), dtype=complex)
        for j in range(m):
            je[:, :, j, :, j] = self.lag[:, None, :] * d[None, :, :]
        cols.append(je.reshape(n_res, nl * m))
        return _weighted_rows(np.concatenate(cols, axis=1), self.w_re.ravel(), self.w_im.ravel())


def _initial_d(problem: _MinStateProblem, gaf: GAF, include_a1, include_a2) -> np.ndarray:
    """Start from a Roger fit: column l of D = dominant left singular vector of lag matrix l."""
    roger = fit_roger(gaf, lag_roots=problem.gam, include_a1=include_a1, include_a2=include_a2)
    m = problem.m
    d = np.zeros((m, problem.nl))
    for l in range(problem.nl):
        u, s, _ = np.linalg.svd(roger.D[:, l * m : (l + 1) * m])
        d[:, l] = u[:, 0] * s[0] if s[0] > 0 else np.eye(m)[:, l % m]
    return d


def _als(problem, d, max_iter, tol):
    cost_prev = np.inf
    polys = e = None
    for it in range(max_iter):
        polys, e = problem.solve_e(d)
        # Normalise the lag rows (the D·E split is defined only up to a diagonal scaling).
        scale = np.linalg.norm(e, axis=1)
        scale[scale == 0] = 1.0
        e = e / scale[:, None]
        d = d * scale[None, :]
        polys, d = problem.solve_d(e)
        cost = problem.cost(polys, d, e)
        if abs(cost_prev - cost) <= tol * max(cost, 1e-300):
            return polys, d, e, it + 1
        cost_prev = cost
    return polys, d, e, max_iter


def fit_minimum_state(
    gaf: GAF,
    n_lags: int = 4,
    lag_roots=None,
    include_a1: bool = True,
    include_a2: bool = True,
    weight_floor: float = 1.0,
    optimize_roots: bool = False,
    max_iter: int = 300,
    tol: float = 1e-10,
    polish: bool | None = None,
    initial_d=None,
    weighting: str = "entry",
) -> RFA:
    """Karpel's minimum-state RFA (A0 = Q(0); ALS + Levenberg–Marquardt polish).

    ``weight_floor``: entries are weighted by 1/max(max_k |Q_ij|, weight_floor) (``weighting``
    "entry", Karpel's); ``weighting="point"`` weights every frequency by its own magnitude
    (see :func:`_residual_weights`).
    ``optimize_roots``: refine log(γ) by Nelder–Mead on the weighted fit cost.
    ``polish``: joint Levenberg–Marquardt refinement after the ALS (None: only for small problems,
    at most 200 unknowns — for 9 modes and 13 lags it costs a minute and gains little).
    ``initial_d``: starting D (m × n_L) of the alternating least squares (default: from a Roger
    fit with the same roots, column l = dominant singular vector of lag matrix l).
    """
    if n_lags < 1 and lag_roots is None:
        raise InputError(f"RFA: minimum-state needs at least one lag, got n_lags={n_lags}")
    gam = (
        default_lag_roots(n_lags, gaf.k.max())
        if lag_roots is None
        else np.asarray(lag_roots, float)
    )
    if np.any(gam <= 0) or len(np.unique(gam)) != len(gam):
        raise InputError(f"RFA: lag roots: expected distinct positive values, got {gam.tolist()}")

    def fit_for(g, iters):
        prob = _MinStateProblem(gaf, g, include_a1, include_a2, weight_floor, weighting)
        if initial_d is not None and len(g) == np.shape(initial_d)[1]:
            d0 = np.array(initial_d, dtype=float)
        else:
            d0 = _initial_d(prob, gaf, include_a1, include_a2)
        return prob, _als(prob, d0, iters, tol)

    if optimize_roots:

        def objective(log_g):
            g = np.sort(np.exp(log_g))
            if len(np.unique(np.round(g, 12))) != len(g):
                return np.inf
            prob, (polys, d, e, _) = fit_for(g, 40)
            return prob.cost(polys, d, e)

        res = scipy.optimize.minimize(
            objective,
            np.log(gam),
            method="Nelder-Mead",
            options={"maxiter": 200 * len(gam), "xatol": 1e-4, "fatol": 1e-12},
        )
        gam = np.sort(np.exp(res.x))

    prob, (polys, d, e, _) = fit_for(gam, max_iter)
    x0 = prob.pack(polys, d, e)
    if polish is None:
        polish = len(x0) <= 200
    # MINPACK's Levenberg–Marquardt needs at least as many residuals as unknowns.
    if polish and 2 * len(prob.p) * prob.m * prob.m >= len(x0):
        sol = scipy.optimize.least_squares(
            prob.fun,
            x0,
            jac=prob.jac,
            method="lm",
            xtol=1e-15,
            ftol=1e-15,
            gtol=1e-15,
            max_nfev=200 * (len(x0) + 1),
        )
        if prob.cost(*prob.unpack(sol.x)) <= prob.cost(polys, d, e):
            polys, d, e = prob.unpack(sol.x)
    if not np.all(np.isfinite(d)) or not np.all(np.isfinite(e)):
        raise ConvergenceError("RFA: minimum-state fit produced non-finite coefficients")
    m = gaf.n_modes
    it = iter(polys)
    a1 = next(it) if include_a1 else np.zeros((m, m))
    a2 = next(it) if include_a2 else np.zeros((m, m))
    rfa = RFA(prob.a0, a1, a2, d, -np.diag(gam), e, gam, "minimum-state", gaf.semichord, gaf.mach)
    rfa.fit_error = fit_error(gaf.Q, rfa.evaluate(gaf.k), _weights(gaf.Q, weight_floor))
    return rfa
