"""Flutter: p-k with mode tracking, KE, state-space eigenvalues, matched-point altitude, α(γ).

Written here (numpy/scipy). Equations of motion on the m aerodynamic modes (paper Eqs. 12, 49):

    M q̈ + C q̇ + K q = -q∞ Q(ik) q,   C = C0 + α M + γ D̄1,   q∞ = ½ ρ V²,   k = ω b / V.

* p-k (Nastran PK): for each mode, iterate k; at fixed k solve the real quadratic eigenproblem
  M s² + (C + q∞ (b/V) Q_I/k) s + (K + q∞ Q_R) = 0 and keep the root that continues the tracked
  mode (eigenvector correlation, then frequency); exact at zero damping. Damping g = 2 Re(s)/Im(s).
* KE (Nastran KE/K): at each k, (M - ½ρ(b/k)² Q(k)) x = λ K x with λ = (1 + i g)/ω², artificial
  structural damping g; viscous damping is not included (as in Nastran).
* State space (paper Eqs. 49–50): x = [q, q̇, ξ], with M̄ = M + q∞ (b/V)² A2, C̄ = C + q∞ (b/V) A1,
  K̄ = K + q∞ A0; M̄ q̈ = -K̄ q - C̄ q̇ - q∞ D ξ,  ξ̇ = E q̇ + (V/b) R ξ.
* Matched point (fixed Mach): V = M a(h), ρ = ρ(h) (USSA-76, ambiance); the flutter altitude is
  the highest altitude where the damping of a mode crosses zero, found by bracketing on an
  altitude grid and Brent's method.
* α(γ): the mass-proportional coefficient that puts the flutter point at a given altitude for a
  given γ (paper Fig. 9), by Brent's method on the growth rate at that altitude.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np
import scipy

from ..checks import physical, physical_values, real
from ..errors import ConvergenceError, InputError
from .atmosphere import flight_condition
from .dlm import GAF
from .rfa import RFA

#: smallest reduced frequency used by p-k (the Q_I/k term is evaluated there for real roots)
K_FLOOR = 1e-4
#: Damping g (= 2σ/ω) within ±G_ROUNDOFF counts as zero when flutter crossings are detected: a
#: mode that the aerodynamics do not touch (e.g. in-plane) has g of order 1e-15 of either sign
#: from round-off, which is not flutter. A real crossing passes well beyond it (Nastran prints g
#: to 1e-4..1e-5); a crossing whose damping stays below 1e-8 at the end of the sweep is missed.
G_ROUNDOFF = 1e-8
#: Default tolerance of the flutter answers (``--g-tolerance``): a crossing counts only where the
#: damping g changes sign by more than this (from below -G_TOLERANCE to above +G_TOLERANCE),
#: and a branch whose |g| stays within it over the whole range is "not loaded by the
#: aerodynamics". 1e-3 is 0.05 % of critical damping (ζ = g/2): a tenth of the smallest
#: structural damping of a built wing (g = 0.01..0.03), so any excursion inside it is removed
#: by the structure's own damping; it is above the wobble of a mode the aerodynamics hardly load
#: (±2.4e-4, the chordwise mode of a swept wingbox; ±3e-5, bah_plane's 14.5 Hz branch at
#: extrapolated k) and far below a flutter crossing's g, which passes through 0 with a slope of
#: order 1 per flutter speed (bah_plane: g = +0.05 at 5 % above its flutter speed).
G_TOLERANCE = 1e-3


def zero_crossings(g, tol: float = G_ROUNDOFF) -> list[int]:
    """Indices i where g crosses zero upwards between i and i+1, ignoring round-off.

    A crossing needs g < −tol before and g > +tol after (points within ±tol, and non-finite
    values, are skipped); it is placed at the last sign change g[i] < 0 ≤ g[i+1] in between.
    """
    g = np.asarray(g, dtype=float)
    out, last_neg = [], None
    for i, gi in enumerate(g):
        if not np.isfinite(gi):
            last_neg = None
            continue
        if gi < -tol:
            last_neg = i
        elif gi > tol and last_neg is not None:
            seg = g[last_neg : i + 1]
            flips = np.flatnonzero((seg[:-1] < 0) & (seg[1:] >= 0))
            out.append(last_neg + int(flips[-1]))
            last_neg = None
    return out


#: a crossing whose root stays unstable to the end of the range / one that re-stabilises
SUSTAINED, HUMP = "sustained", "hump"
def is_static_root(s: complex, velocity: float, semichord: float) -> bool:
    """A real (non-oscillating) root: Im s = 0, or a reduced frequency |Im s| b / V at the p-k
    floor :data:`K_FLOOR` (the iteration's k of a real root). Its crossing of zero is a
    divergence, not flutter."""
    return bool(s.imag == 0 or abs(s.imag) * semichord / velocity <= K_FLOOR)


def excursions(g, tol: float = G_ROUNDOFF) -> list[tuple[int, int | None]]:
    """Unstable excursions of a sampled damping: pairs (i, j) of an upward zero crossing
    between samples i and i+1 (:func:`zero_crossings`) and the next downward one between j and
    j+1 (None: g stays above zero to the last sample). A downward crossing with no upward one
    before it (a root unstable from the first sample) opens no excursion."""
    g = np.asarray(g, dtype=float)
    events = sorted([(i, 1) for i in zero_crossings(g, tol)]
                    + [(i, -1) for i in zero_crossings(-g, tol)])
    out, start = [], None
    for i, sign in events:
        if sign > 0 and start is None:
            start = i
        elif sign < 0 and start is not None:
            out.append((start, i))
            start = None
    if start is not None:
        out.append((start, None))
    return out


# -- structure ---------------------------------------------------------------------------------
def _as_numpy(a) -> np.ndarray:
    if hasattr(a, "detach"):
        a = a.detach().cpu().numpy()
    return np.array(a, dtype=float)


@dataclass
class ModalStructure:
    """Linear structure on the m aerodynamic modes: M q̈ + (C0 + α M + γ D1) q̇ + K q = F.

    ``D1`` is the damping matrix at γ = 1 (the paper's D̄1 = K1 for Kelvin–Voigt damping,
    Eq. 53–54; it defaults to K). Baseline Rayleigh damping of the paper: α = 0.2565 1/s,
    γ = 1.338e-4 s (Eq. 46).
    """

    M: np.ndarray
    K: np.ndarray
    D1: np.ndarray | None = None
    alpha: float = 0.0
    gamma: float = 0.0
    C0: np.ndarray | None = None
    names: list[str] | None = None

    def __post_init__(self):
        self.alpha = real("modal structure: alpha", self.alpha)
        self.gamma = physical("gamma", self.gamma, "modal structure:")
        self.M = _as_numpy(self.M)
        self.K = _as_numpy(self.K)
        m = self.M.shape[0]
        self.D1 = self.K.copy() if self.D1 is None else _as_numpy(self.D1)
        self.C0 = np.zeros((m, m)) if self.C0 is None else _as_numpy(self.C0)
        for name in ("M", "K", "D1", "C0"):
            a = getattr(self, name)
            if a.shape != (m, m) or not np.all(np.isfinite(a)):
                raise InputError(
                    f"modal structure: {name}: expected a finite ({m}, {m}) matrix, got {a.shape}"
                )
        if np.any(np.linalg.eigvalsh(0.5 * (self.M + self.M.T)) <= 0):
            raise InputError("modal structure: M: expected a positive definite mass matrix")

    @property
    def n_modes(self) -> int:
        return self.M.shape[0]

    @property
    def M_inv(self) -> np.ndarray:
        if getattr(self, "_m_inv", None) is None or self._m_inv_of is not self.M:
            self._m_inv, self._m_inv_of = _inverse(self.M), self.M
        return self._m_inv

    @property
    def C(self) -> np.ndarray:
        return self.C0 + self.alpha * self.M + self.gamma * self.D1

    def with_damping(self, alpha: float, gamma: float) -> ModalStructure:
        return replace(self, alpha=float(alpha), gamma=float(gamma))

    def natural_frequencies_hz(self) -> np.ndarray:
        lam = np.linalg.eigvals(np.linalg.solve(self.M, self.K))
        return np.sort(np.sqrt(np.abs(lam.real))) / (2 * np.pi)

    @classmethod
    def from_rom(cls, rom, n_modes: int, alpha: float = 0.0, gamma: float = 0.0) -> ModalStructure:
        """Linear part of a NonlinearROM restricted to its first ``n_modes`` basis functions."""
        m = int(n_modes)
        d1 = getattr(rom, "D1", None)
        return cls(
            M=_as_numpy(rom.M)[:m, :m],
            K=_as_numpy(rom.K1)[:m, :m],
            D1=None if d1 is None else _as_numpy(d1)[:m, :m],
            alpha=alpha,
            gamma=gamma,
        )

    @classmethod
    def from_modes(cls, frequencies_hz, generalized_masses=None, alpha=0.0, gamma=0.0):
        """Diagonal structure from natural frequencies (mass-normalised unless masses given)."""
        w = 2 * np.pi * np.asarray(frequencies_hz, dtype=float)
        mass = (
            np.ones_like(w) if generalized_masses is None else np.asarray(generalized_masses, float)
        )
        return cls(M=np.diag(mass), K=np.diag(mass * w**2), alpha=alpha, gamma=gamma)


# -- aerodynamics as Q(k) ------------------------------------------------------------------------
class AeroTable:
    """Q(k) on demand: interpolated from a GAF table, from a callable, or from an RFA."""

    def __init__(
        self, q_of_k: Callable[[float], np.ndarray], semichord: float, k_max: float = np.inf,
        k_min: float = 0.0,
    ):
        self._q = q_of_k
        self.semichord = float(semichord)
        self.k_max = k_max
        self.k_min = float(k_min)  # lowest tabulated k (0: Q is known down to k = 0)
        self.k_damp = self.k_min  # lowest positive tabulated k (where Q_I/k is last known)
        self.extrapolated = 0.0  # largest k requested beyond the table

    def __call__(self, k: float) -> np.ndarray:
        if k > self.k_max:
            self.extrapolated = max(self.extrapolated, k)
        return self._q(k)

    @classmethod
    def from_gaf(cls, gaf: GAF, interpolation: str = "cubic") -> AeroTable:
        k = gaf.k
        order = np.argsort(k)
        k, q = k[order], gaf.Q[order]
        if len(k) < 2:
            raise InputError("flutter: the GAF table needs at least two reduced frequencies")
        if interpolation == "cubic" and len(k) >= 4:
            spl = scipy.interpolate.CubicSpline(k, q, axis=0)

            def q_of_k(kk):
                return spl(kk)
        elif interpolation in ("linear", "cubic"):

            def q_of_k(kk):
                i = int(np.clip(np.searchsorted(k, kk) - 1, 0, len(k) - 2))
                t = (kk - k[i]) / (k[i + 1] - k[i])
                return (1 - t) * q[i] + t * q[i + 1]
        else:
            raise InputError(
                f"flutter: interpolation: expected 'cubic' or 'linear', got {interpolation!r}"
            )
        table = cls(q_of_k, gaf.semichord, k_max=float(k[-1]), k_min=float(k[0]))
        table.k_damp = float(k[k > 0][0]) if np.any(k > 0) else 0.0
        return table

    @classmethod
    def from_rfa(cls, rfa: RFA) -> AeroTable:
        return cls(lambda kk: rfa.evaluate([kk])[0], rfa.semichord)

    @classmethod
    def from_function(cls, fn: Callable[[float], np.ndarray], semichord: float) -> AeroTable:
        return cls(lambda kk: np.asarray(fn(kk)).reshape(np.shape(fn(kk))[-2:]), semichord)


# -- results ---------------------------------------------------------------------------------------
@dataclass
class FlutterPoint:
    """A zero-damping crossing: damping goes from negative to positive as speed/q∞ increases.

    ``kind``: :data:`SUSTAINED` (the root stays unstable to the end of the range) or
    :data:`HUMP` (it re-stabilises at ``stable_velocity``, ``stable_frequency_hz``).
    ``refined``: the speeds were solved between the sweep's points (False: interpolated
    linearly). ``rigid_body``: the root of a rigid-body mode (never a flutter point).
    ``divergence``: a real root crossing zero (:func:`is_static_root`; never a flutter point).
    """

    velocity: float
    frequency_hz: float
    density: float
    mode: int
    method: str
    k: float = float("nan")
    altitude: float | None = None
    mach: float | None = None
    kind: str = SUSTAINED
    stable_velocity: float | None = None
    stable_frequency_hz: float | None = None
    refined: bool = False
    rigid_body: bool = False
    #: a real root's crossing (zero frequency: static divergence), never flutter
    divergence: bool = False

    @property
    def dynamic_pressure(self) -> float:
        return 0.5 * self.density * self.velocity**2

    def as_dict(self) -> dict:
        return {
            "method": self.method,
            "mode": self.mode + 1,
            "velocity": self.velocity,
            "frequency_hz": self.frequency_hz,
            "density": self.density,
            "dynamic_pressure": self.dynamic_pressure,
            "reduced_frequency": self.k,
            "altitude": self.altitude,
            "mach": self.mach,
            "kind": self.kind,
            "stable_velocity": self.stable_velocity,
            "stable_frequency_hz": self.stable_frequency_hz,
            "refined": self.refined,
            "rigid_body": self.rigid_body,
            "divergence": self.divergence,
        }


@dataclass
class ModeSweep:
    """Tracked roots along a sweep (p-k or KE): arrays (n_points, n_modes).

    eigenvalues s = σ + iω (rad/s); damping g = 2σ/ω (Nastran); KE gives its artificial g.
    ``velocity`` is (n_points,) for p-k and (n_points, n_modes) for KE (V = ω b / k per root).
    """

    method: str
    velocity: np.ndarray
    density: np.ndarray
    eigenvalues: np.ndarray
    k: np.ndarray
    damping: np.ndarray
    altitude: np.ndarray | None = None
    mach: float | None = None
    semichord: float = 1.0
    vectors: np.ndarray | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def frequency_hz(self) -> np.ndarray:
        return np.abs(self.eigenvalues.imag) / (2 * np.pi)

    @property
    def velocity_by_mode(self) -> np.ndarray:
        v = np.asarray(self.velocity, dtype=float)
        return v if v.ndim == 2 else np.repeat(v[:, None], self.eigenvalues.shape[1], axis=1)

    def crossings(self, tol: float = G_TOLERANCE) -> list[FlutterPoint]:
        """Zero-damping crossings (from below -``tol`` to above +``tol``, :func:`excursions`),
        labelled sustained or hump, interpolated linearly between points; a crossing whose root
        is real on its unstable side (:func:`is_static_root`) is a divergence
        (``divergence=True``), not flutter."""
        out = []
        g = self.damping
        vel = self.velocity_by_mode
        for j in range(g.shape[1]):
            for i, back in excursions(g[:, j], tol):

                def lerp(a, i, j=j):
                    t = g[i, j] / (g[i, j] - g[i + 1, j])
                    return float(a[i] + t * (a[i + 1] - a[i]))

                out.append(
                    FlutterPoint(
                        velocity=lerp(vel[:, j], i),
                        frequency_hz=lerp(self.frequency_hz[:, j], i),
                        density=lerp(self.density, i),
                        mode=j,
                        method=self.method,
                        k=lerp(self.k[:, j], i),
                        altitude=None if self.altitude is None else lerp(self.altitude, i),
                        mach=self.mach,
                        kind=SUSTAINED if back is None else HUMP,
                        stable_velocity=None if back is None else lerp(vel[:, j], back),
                        stable_frequency_hz=(None if back is None
                                             else lerp(self.frequency_hz[:, j], back)),
                        divergence=is_static_root(self.eigenvalues[i + 1, j], vel[i + 1, j],
                                                  self.semichord),
                    )
                )
        return sorted(out, key=lambda p: (p.dynamic_pressure, p.velocity))

    def not_loaded(self, tol: float = G_TOLERANCE) -> list[int]:
        """Branches that oscillate at every point with a damping within ±``tol`` (an
        undefined g counts as beyond it): modes the aerodynamics do not load, whose g is
        noise around 0 and never a flutter crossing. A branch with a real root somewhere
        (:func:`is_static_root`; Nastran's g = 2 s b / (V ln 2) of a real root near s = 0 is
        small at any speed) is loaded: its root left the imaginary axis."""
        vel = self.velocity_by_mode
        with np.errstate(invalid="ignore", divide="ignore"):
            oscillating = np.abs(self.eigenvalues.imag) * self.semichord / vel > K_FLOOR
            inside = (np.abs(self.damping) <= tol) & oscillating
        return np.flatnonzero(inside.all(axis=0)).tolist()

    def table(self) -> list[dict]:
        """V-g / V-f records (one per point and mode), for printing and --json."""
        rows = []
        vel = self.velocity_by_mode
        for i in range(len(vel)):
            for j in range(self.eigenvalues.shape[1]):
                s = self.eigenvalues[i, j]
                rows.append(
                    {
                        "mode": j + 1,
                        "velocity": float(vel[i, j]),
                        "density": float(self.density[i]),
                        "altitude": None if self.altitude is None else float(self.altitude[i]),
                        "reduced_frequency": float(self.k[i, j]),
                        "damping_g": float(self.damping[i, j]),
                        "frequency_hz": float(self.frequency_hz[i, j]),
                        "eigenvalue_real": float(s.real),
                        "eigenvalue_imag": float(s.imag),
                    }
                )
        return rows


# -- p-k -------------------------------------------------------------------------------------------
def _mac(a: np.ndarray, b: np.ndarray) -> float:
    den = np.vdot(a, a).real * np.vdot(b, b).real
    return float(abs(np.vdot(a, b)) ** 2 / den) if den > 0 else 0.0


def _macs(vectors: np.ndarray, b: np.ndarray) -> np.ndarray:
    """:func:`_mac` of each column of ``vectors`` with ``b``."""
    den = np.einsum("ij,ij->j", vectors.conj(), vectors).real * np.vdot(b, b).real
    num = np.abs(b.conj() @ vectors) ** 2
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def _inverse(a: np.ndarray) -> np.ndarray:
    """Inverse of a small matrix by LU solve (numpy's threaded ``inv`` is pathologically slow
    for small matrices when the cores are shared)."""
    return scipy.linalg.solve(a, np.eye(len(a)), check_finite=False)


def _quadratic_eig(minv, C, K):
    """Roots of M s² + C s + K (``minv`` = M⁻¹) and their displacement eigenvectors."""
    m = minv.shape[0]
    a = np.zeros((2 * m, 2 * m))
    a[:m, m:] = np.eye(m)
    a[m:, :m] = -minv @ K
    a[m:, m:] = -minv @ C
    s, v = np.linalg.eig(a)
    return s, v[:m]


def _pk_mode(structure, aero, V, rho, s_guess, vec_guess, eps, max_iter, exclude=None):
    """Converge one p-k root near (s_guess, vec_guess); returns (s, vector, k, converged).
    ``exclude``: roots other branches hold; at each iteration the root nearest to each is not
    taken.

    Fixed-point iteration on k = Im(s) b / V, under-relaxed whenever the update changes sign
    (heavily damped roots otherwise cycle between two k values).
    """
    b = aero.semichord
    q = 0.5 * rho * V**2
    k = max(abs(s_guess.imag) * b / V, K_FLOOR)
    s_best, vec_best = s_guess, vec_guess
    relax, last_step = 1.0, 0.0
    for _ in range(max_iter):
        # Below the lowest positive tabulated k (a rigid-body or divergence root, k -> 0) the
        # aerodynamics are quasi-steady, Q(k) = Q_R(k_min) + i k Q_I(k_d)/k_d, with k_min the
        # lowest tabulated k (0 when the steady GAF is tabulated) and k_d the lowest positive
        # one, instead of extrapolated: Q_I/k tends to a finite limit (the aerodynamic damping)
        # but an extrapolation of Q_I to k << k_d leaves an offset that the division by k
        # blows up, and a Q_R interpolated between k = 0 and k_d grows like k, which gives every
        # rigid-body root a spurious fixed point k ~ q (b/V)² dQ_R/dk > 0. This is what a small
        # first MKAERO k (0.001 in bah_plane) is for.
        if k < aero.k_damp:
            qk, qd, kd = aero(aero.k_min), aero(aero.k_damp), aero.k_damp
        else:
            qk = qd = aero(k)
            kd = k
        kt = structure.K + q * qk.real
        ct = structure.C + q * (b / V) * qd.imag / kd
        s, vecs = _quadratic_eig(structure.M_inv, ct, kt)
        upper = np.flatnonzero(s.imag >= -1e-12 * np.abs(s).max())
        # a rigid-body start (s_guess = 0 exactly): the mode shape decides (the distance term,
        # scaled by the largest root, only breaks ties, favouring the root nearest zero)
        scale = max(abs(s_guess), 1e-12) if s_guess != 0 else max(np.abs(s).max(), 1e-12)
        score = _macs(vecs[:, upper], vec_guess) - 0.5 * np.abs(s[upper] - s_guess) / scale
        if exclude is not None and len(upper) > len(exclude):
            # roots held by other branches (:func:`_pk_solve_all`): never this one's
            score[np.argmin(np.abs(s[upper, None] - exclude[None, :]), axis=0)] = -np.inf
        pick = upper[int(np.argmax(score))]
        s_best, vec_best = s[pick], vecs[:, pick]
        k_new = max(abs(s_best.imag) * b / V, K_FLOOR)
        step = k_new - k
        if abs(step) <= eps * max(k_new, K_FLOOR):
            return s_best, vec_best, k_new, True
        if step * last_step < 0:
            relax = max(0.5 * relax, 1e-3)
        last_step = step
        k = max(k + relax * step, K_FLOOR)
    return s_best, vec_best, k, False


def _vacuum_roots(structure: ModalStructure):
    s, v = _quadratic_eig(structure.M_inv, structure.C, structure.K)
    keep = np.flatnonzero(s.imag > 0)
    if len(keep) < structure.n_modes and _is_modal(structure):
        # rigid-body modes (ω = 0): the companion matrix is defective there and its
        # eigenvectors for s = 0 need not be distinct; the modes themselves are the start
        w = np.sqrt(np.diag(structure.K) / np.diag(structure.M))
        return 1j * w, np.eye(structure.n_modes, dtype=complex)
    if len(keep) < structure.n_modes:  # overdamped or rigid modes: take the upper half by |s|
        keep = np.argsort(-s.imag)[: structure.n_modes]
    keep = keep[np.argsort(np.abs(s[keep]))][: structure.n_modes]
    return s[keep], v[:, keep]


def _is_modal(structure: ModalStructure) -> bool:
    """Undamped with diagonal M and K ≥ 0 (a modal basis, possibly with rigid-body modes)."""
    diag_only = all(np.array_equal(a, np.diag(np.diag(a))) for a in (structure.M, structure.K))
    return diag_only and not np.any(structure.C) and bool(np.all(np.diag(structure.K) >= 0))


def pk_damping(eigenvalues: np.ndarray, velocity, semichord: float,
               real_roots: str = "nastran") -> np.ndarray:
    """p-k damping: g = 2 Re(s)/|Im(s)| for an oscillating root. For a real root (k = 0):
    ``real_roots="nastran"``: g = 2 s b / (V ln 2), the decay (growth) rate per half-amplitude
    distance, which is what the f06 prints for its zero-frequency roots (checked on bah_plane's
    FLUTTER SUMMARY: s = 9.3382e-4 at V = 30, b = 2 gives g = 1.7963e-4); it keeps a divergence,
    a real root through s = 0, a zero crossing of g. ``"infinite"``: ±inf by the sign of s."""
    eig = np.asarray(eigenvalues)
    vel = np.broadcast_to(np.asarray(velocity, dtype=float).reshape(-1, 1), eig.shape)
    real = eig.imag == 0
    with np.errstate(divide="ignore", invalid="ignore"):
        g_real = (2 * eig.real * semichord / (vel * np.log(2.0)) if real_roots == "nastran"
                  else np.sign(eig.real) * np.inf)
        return np.where(real, g_real, 2 * eig.real / np.abs(eig.imag))


#: p-k path steps are halved (at most this many times) while a branch's mode shape changes by
#: more than half (MAC below TRACK_MAC) or two branches land on one root: coarse velocity lists
#: otherwise let a branch jump to a neighbour's root (bah_plane's Mach 0 deck with steps of
#: 250: two branches on one root from the second speed on)
TRACK_HALVINGS = 8
TRACK_MAC = 0.5


def _pk_solve_all(structure, aero, V, rho, s_prev, v_prev, eps, max_iter):
    """Every branch at (V, ρ) from its previous root; a branch that lands on a root another
    branch holds (:func:`_shared_roots`) lost its own: the one whose shape moved more is solved
    again with that root excluded."""
    m = len(s_prev)
    s_all = np.empty(m, complex)
    v_all = np.empty((m, m), complex)
    k_all = np.empty(m)
    ok_all = np.empty(m, bool)
    for j in range(m):
        s_all[j], v_all[:, j], k_all[j], ok_all[j] = _pk_mode(
            structure, aero, V, rho, s_prev[j], v_prev[:, j], eps, max_iter)
    for a, b in _shared_roots(s_all, v_all, eps):
        if not _same_root(s_all, v_all, a, b, eps):  # already moved by an earlier pair
            continue
        moved = [_mac(v_all[:, j], v_prev[:, j]) for j in (a, b)]
        redo = b if moved[0] >= moved[1] else a
        held = np.delete(s_all, redo)
        held = held[np.abs(held) > 1e-4 * np.abs(s_all).max()]  # roots at ~0 may be shared
        s_all[redo], v_all[:, redo], k_all[redo], ok_all[redo] = _pk_mode(
            structure, aero, V, rho, s_prev[redo], v_prev[:, redo], eps, max_iter,
            exclude=held)
    return s_all, v_all, k_all, np.flatnonzero(~ok_all).tolist()


#: two branches whose roots differ by less than this many times the p-k tolerance eps
#: (relative, with MAC > 0.99) are on one root: each root is converged to a relative change of
#: k of eps (1e-4 from a deck), so two convergences to one root differ by up to ~eps (3e-6
#: measured on BAH_Plane's 9.3 Hz root at V = 750; the earlier bound, 1e-6 of the largest root,
#: let that pair pass as two roots); distinct roots that close only meet at a coalescence
SAME_ROOT_EPS = 10.0


def _same_root(s, v, a, b, eps: float = 1e-4) -> bool:
    """Branches a and b on one root: the same eigenvalue (to :data:`SAME_ROOT_EPS` × eps,
    relative) and shape (MAC > 0.99), away from 0 (roots at ~0, rigid-body motions with no
    aerodynamic stiffness, may share a shape)."""
    scale = max(float(np.abs(s).max()), 1e-12)
    return bool(abs(s[a]) > 1e-4 * scale
                and abs(s[a] - s[b]) <= SAME_ROOT_EPS * eps * abs(s[a])
                and _mac(v[:, a], v[:, b]) > 0.99)


def _shared_roots(s, v, eps: float = 1e-4) -> list[tuple[int, int]]:
    """Pairs of branches on one root (:func:`_same_root`)."""
    m = len(s)
    return [(a, b) for a in range(m) for b in range(a + 1, m) if _same_root(s, v, a, b, eps)]


def _tracked(s_new, v_new, v_old, s_old, eps: float = 1e-4) -> bool:
    """Each branch keeps its shape (MAC ≥ TRACK_MAC with its previous vector) and no two
    branches converged to the same root, unless they held one root at the step's start
    already (a shorter step cannot part them then; it would only halve the step to the end
    of :data:`TRACK_HALVINGS`, 256 solves per step)."""
    m = len(s_new)
    if any(_mac(v_new[:, j], v_old[:, j]) < TRACK_MAC for j in range(m)):
        return False
    return all(_same_root(s_old, v_old, a, b, eps) for a, b in _shared_roots(s_new, v_new, eps))


def _pk_step(structure, aero, start, end, s_prev, v_prev, eps, max_iter, halvings=0):
    """All branches from the flight condition ``start`` (V, ρ) to ``end``, the step halved
    (V and ρ linearly) while the tracking fails (:func:`_tracked`)."""
    res = _pk_solve_all(structure, aero, *end, s_prev, v_prev, eps, max_iter)
    if (halvings >= TRACK_HALVINGS or start == end
            or _tracked(res[0], res[1], v_prev, s_prev, eps)):
        return res
    mid = tuple(0.5 * (a + b) for a, b in zip(start, end))
    s_mid, v_mid, _, _ = _pk_step(structure, aero, start, mid, s_prev, v_prev, eps, max_iter,
                                  halvings + 1)
    return _pk_step(structure, aero, mid, end, s_mid, v_mid, eps, max_iter, halvings + 1)


def pk_sweep(
    structure: ModalStructure,
    aero: AeroTable,
    velocities,
    densities,
    altitudes=None,
    mach=None,
    eps: float = 1e-6,
    max_iter: int = 100,
    ramp_steps: int = 6,
    real_root_damping: str = "infinite",
) -> ModeSweep:
    """p-k along a path of flight conditions (tracked from the in-vacuo modes).

    The path is entered by ramping the density from ~0 to its first value at the first speed so
    that every mode is followed continuously from its structural mode. The damping of a real
    root (zero frequency) is ±inf (``real_root_damping="infinite"``: only oscillatory roots
    flutter) or Nastran's finite value (``"nastran"``, :func:`pk_damping`).
    """
    if real_root_damping not in ("infinite", "nastran"):
        raise InputError(f"p-k: real_root_damping: expected 'infinite' or 'nastran', "
                         f"got {real_root_damping!r}")
    V = np.asarray(velocities, dtype=float).reshape(-1)
    rho = np.broadcast_to(np.asarray(densities, dtype=float), V.shape).copy()
    if np.any(V <= 0) or np.any(rho < 0):
        raise InputError("p-k: velocities must be positive and densities non-negative")
    m = structure.n_modes
    s_prev, v_prev = _vacuum_roots(structure)
    for f in np.linspace(0.0, 1.0, ramp_steps + 1)[1:-1] if ramp_steps > 1 else []:
        for j in range(m):
            s_prev[j], v_prev[:, j], _, _ = _pk_mode(
                structure, aero, V[0], f * rho[0], s_prev[j], v_prev[:, j], eps, max_iter
            )
    eig = np.empty((len(V), m), complex)
    kk = np.empty((len(V), m))
    vecs = np.empty((len(V), m, m), complex)
    notes = []
    for i in range(len(V)):
        start = (V[i - 1], rho[i - 1]) if i else (V[0], rho[0])
        s_all, v_all, k_all, failed = _pk_step(structure, aero, start, (V[i], rho[i]), s_prev,
                                               v_prev, eps, max_iter)
        notes += [f"p-k: mode {j + 1} not converged at V={V[i]:.6g}" for j in failed]
        eig[i], vecs[i], kk[i] = s_all, v_all, k_all
        s_prev, v_prev = eig[i].copy(), vecs[i].copy()
    g = pk_damping(eig, V, aero.semichord, real_root_damping)
    if aero.extrapolated:
        notes.append(
            f"p-k: reduced frequency up to {aero.extrapolated:.4g} beyond the GAF table "
            f"(k_max={aero.k_max:.4g})"
        )
    return ModeSweep(
        "PK",
        V,
        rho,
        eig,
        kk,
        g,
        None if altitudes is None else np.asarray(altitudes, float),
        mach,
        aero.semichord,
        vecs,
        notes,
    )


# -- KE --------------------------------------------------------------------------------------------
def ke_sweep(structure: ModalStructure, aero: AeroTable, k_list, density: float) -> ModeSweep:
    """Nastran KE method: tracked roots for each reduced frequency, high k (low V) first."""
    k = np.sort(np.asarray(k_list, dtype=float).reshape(-1))[::-1]
    if np.any(k <= 0):
        raise InputError("KE: reduced frequencies must be positive")
    b, m = aero.semichord, structure.n_modes
    eig = np.empty((len(k), m), complex)
    damping = np.empty((len(k), m))
    vel = np.empty((len(k), m))
    vecs = np.empty((len(k), m, m), complex)
    prev = None
    notes = []
    rigid = _is_modal(structure) and bool(np.any(np.diag(structure.K) == 0))
    if rigid:
        # K is singular (rigid-body modes): solve μ A x = K x, μ = 1/λ, instead of inverting K.
        # A rigid-body mode has μ = 0, i.e. no KE root (ω = 0: velocity 0, damping undefined).
        notes.append("KE: the rigid-body modes have no KE root (ω = 0, listed with velocity 0 "
                     "and undefined damping); use PK for the free-free flutter of an aircraft")
    else:
        kinv = _inverse(structure.K)
    for i, ki in enumerate(k):
        if rigid:
            mu, v = np.linalg.eig(_inverse(
                structure.M - 0.5 * density * (b / ki) ** 2 * aero(ki)) @ structure.K)
            zero = np.abs(mu) <= 1e-12 * np.abs(mu).max()
            with np.errstate(divide="ignore", invalid="ignore"):
                lam = np.where(zero, np.inf + 0j, 1.0 / np.where(zero, 1.0, mu))
        else:
            a = kinv @ (structure.M - 0.5 * density * (b / ki) ** 2 * aero(ki))
            lam, v = np.linalg.eig(a)
        if prev is None:
            order = np.argsort(-lam.real)  # λ ≈ 1/ω²: lowest frequency first
        else:
            cost = -np.array([[_mac(v[:, c], prev[:, r]) for c in range(m)] for r in range(m)])
            _, order = scipy.optimize.linear_sum_assignment(cost)
        lam, v = lam[order], v[:, order]
        prev = v
        with np.errstate(divide="ignore", invalid="ignore"):
            omega = np.where(lam.real > 0, 1.0 / np.sqrt(np.abs(lam.real)), np.nan)
        if np.any(lam.real <= 0):
            notes.append(f"KE: a root at k={ki:.4g} has no physical interpretation (Re λ <= 0)")
        with np.errstate(invalid="ignore"):
            damping[i] = np.where(np.isinf(lam.real), np.nan, lam.imag / lam.real)
        vel[i] = omega * b / ki
        # Represent the KE root like Nastran: s = ω (g/2 + i)
        eig[i] = omega * (0.5 * damping[i] + 1j)
        vecs[i] = v
    return ModeSweep(
        "KE",
        vel,
        np.full(len(k), density),
        eig,
        np.repeat(k[:, None], m, axis=1),
        damping,
        None,
        None,
        b,
        vecs,
        notes,
    )


# -- state space -----------------------------------------------------------------------------------
def state_space_matrix(
    structure: ModalStructure, rfa: RFA, velocity: float, density: float
) -> np.ndarray:
    """First-order system matrix for x = [q, q̇, ξ] (paper Eqs. 49–50, b = RFA semichord)."""
    if rfa.n_modes != structure.n_modes:
        raise InputError(
            f"state space: RFA has {rfa.n_modes} modes, the structure {structure.n_modes}"
        )
    V, b = float(velocity), rfa.semichord
    q = 0.5 * density * V**2
    m, na = structure.n_modes, rfa.n_states
    mbar = structure.M + q * (b / V) ** 2 * rfa.A2
    cbar = structure.C + q * (b / V) * rfa.A1
    kbar = structure.K + q * rfa.A0
    rows = scipy.linalg.solve(mbar, np.hstack([kbar, cbar, q * rfa.D]), check_finite=False)
    a = np.zeros((2 * m + na, 2 * m + na))
    a[:m, m : 2 * m] = np.eye(m)
    a[m : 2 * m, :] = -rows
    a[2 * m :, m : 2 * m] = rfa.E
    a[2 * m :, 2 * m :] = (V / b) * rfa.R
    return a


#: a state-space root whose structural shape q lies mostly in the rigid-body modes (their
#: M-weighted share of q above this) is a rigid-body root: the state-space form of the p-k rule
#: (:func:`rigid_body_branches`: the branch that starts from a 0 Hz mode)
RIGID_SHARE = 0.5


@dataclass
class OscillatoryRoots:
    """The oscillatory state-space roots at one speed and density, split: those of the flexible
    structure and the rigid-body roots (each with the 0-based in-vacuo mode, by frequency, that
    its shape moves most)."""

    elastic: np.ndarray
    rigid: np.ndarray
    rigid_mode: np.ndarray

    def rigid_critical(self) -> tuple[complex, int] | None:
        """The rigid-body root of largest damping g = 2 Re s / Im s and its mode (None: no
        oscillatory rigid-body root)."""
        if len(self.rigid) == 0:
            return None
        i = int(np.argmax(self.rigid.real / self.rigid.imag))
        return complex(self.rigid[i]), int(self.rigid_mode[i])

    def critical(self) -> complex:
        """The flexible structure's root with the largest real part (growth rate, 1/s)."""
        if len(self.elastic) == 0:
            raise ConvergenceError("state space: no oscillatory root found")
        return complex(self.elastic[np.argmax(self.elastic.real)])

    def flutter_root(self, tol: float = G_TOLERANCE) -> complex | None:
        """:meth:`critical` among the roots whose damping g = 2 Re s / Im s is beyond ``tol``
        (|g| > tol, the p-k's rule, :data:`G_TOLERANCE`): a mode the aerodynamics do not
        load, undamped, has Re s = ±1e-14 (bah_plane's 8.70 Hz mode at α = γ = 0), or a g
        that wobbles about 0 by less than tol, and is no flutter. None where every root is
        within tol."""
        g = 2 * self.elastic.real / self.elastic.imag
        beyond = self.elastic[np.abs(g) > tol]
        return complex(beyond[np.argmax(beyond.real)]) if len(beyond) else None

    def flutter_growth(self, tol: float = G_TOLERANCE) -> float:
        """Re of :meth:`flutter_root` (1/s; NaN where there is none)."""
        root = self.flutter_root(tol)
        return float("nan") if root is None else root.real


def in_vacuo_modes(structure: ModalStructure) -> tuple[np.ndarray, np.ndarray]:
    """Undamped modes of (K, M): frequencies (Hz, ascending) and M-orthonormal shapes (m × m)
    (the symmetric parts of M and K)."""
    w2, phi = scipy.linalg.eigh(0.5 * (structure.K + structure.K.T),
                                0.5 * (structure.M + structure.M.T))
    return np.sqrt(np.abs(w2)) / (2 * np.pi), phi


def modal_energy(structure: ModalStructure, phi: np.ndarray, q: np.ndarray) -> np.ndarray:
    """|η|² with η = Φᵀ M q: the M-weighted share of each in-vacuo mode (rows, the columns of
    ``phi`` from :func:`in_vacuo_modes`) in each root's structural shape (the columns of
    ``q``, m × n, or a stack of them, … × m × n)."""
    return np.abs(phi.T @ (structure.M @ q)) ** 2


def oscillatory_roots(structure: ModalStructure, rfa: RFA, velocity: float, density: float,
                      min_frequency_hz: float = 1e-3) -> OscillatoryRoots:
    """The state-space roots with Im s > 2π ``min_frequency_hz``, the rigid-body ones apart
    (:data:`RIGID_SHARE` of q = Φ η in the in-vacuo modes Φ: Σ_rigid |η|² / Σ |η|², with
    η = Φᵀ M q). A restrained structure (no mode below :data:`RIGID_FRACTION`) has none and
    needs no eigenvectors."""
    a = state_space_matrix(structure, rfa, velocity, density)
    f, phi = in_vacuo_modes(structure)
    rigid = rigid_body_modes(f)
    none = np.zeros(0, dtype=int)
    if not rigid.any():
        s = np.linalg.eigvals(a)
        return OscillatoryRoots(s[s.imag > 2 * np.pi * min_frequency_hz], s[:0], none)
    s, x = np.linalg.eig(a)
    keep = s.imag > 2 * np.pi * min_frequency_hz
    s, q = s[keep], x[: structure.n_modes, keep]
    eta = modal_energy(structure, phi, q)
    is_rigid = eta[rigid].sum(axis=0) / eta.sum(axis=0) > RIGID_SHARE
    mode = np.flatnonzero(rigid)[np.argmax(eta[rigid][:, is_rigid], axis=0)] if is_rigid.any() \
        else none
    return OscillatoryRoots(s[~is_rigid], s[is_rigid], mode)


def critical_root(
    structure: ModalStructure,
    rfa: RFA,
    velocity: float,
    density: float,
    min_frequency_hz: float = 1e-3,
) -> complex:
    """The oscillatory state-space root of the flexible structure with the largest real part
    (growth rate, 1/s); a free structure's rigid-body roots are never it
    (:func:`oscillatory_roots`)."""
    return oscillatory_roots(structure, rfa, velocity, density, min_frequency_hz).critical()


def refine_crossing(roots_at: Callable[[float], OscillatoryRoots], lo: float, hi: float,
                    target: complex, xtol: float) -> tuple[float, complex]:
    """(x, root) where the flexible-structure root that continues ``target`` (the unstable
    root at one end of [lo, hi]; at each x the elastic root nearest it) crosses Re s = 0:
    Brent's method to ``xtol``. Following that one root keeps the other roots, e.g. an
    undamped one at Re s = ±1e-14, out of the refinement and of the reported frequency."""
    def branch(x):
        e = roots_at(x).elastic
        return complex(e[np.argmin(np.abs(e - target))])

    a, b = branch(lo), branch(hi)
    if a.real * b.real > 0:
        # the crossing sits on an end of the bracket to rounding (e.g. an α chosen to put the
        # flutter altitude on a grid altitude): the root there is ±1e-15, either sign
        return (lo, a) if abs(a.real) <= abs(b.real) else (hi, b)
    x = float(scipy.optimize.brentq(lambda x: branch(x).real, lo, hi, xtol=xtol))
    return x, branch(x)


def stable_before(roots: list[OscillatoryRoots], i: int, target: complex
                  ) -> tuple[int, complex]:
    """(j, root at sample j + 1): j < i the last sample before ``i`` of a sweep of ``roots``
    where the root that continues ``target`` (the root at sample ``i``; downwards, the elastic
    root nearest the one at the next sample) is stable (Re s < 0). A root within the damping
    tolerance, left out of the growth rate at sample i - 1 but already positive there, crossed
    zero before it: the crossing is bracketed by samples j and j + 1."""
    j, root = i - 1, target
    while j > 0:
        e = roots[j].elastic
        before = complex(e[np.argmin(np.abs(e - root))])
        if before.real < 0:
            break
        j, root = j - 1, before
    return j, root


def rigid_body_crossings_state_space(roots: list[OscillatoryRoots], x) -> list[tuple[int, float]]:
    """(mode, x sample) where the damping g = 2 Re s / Im s of the least stable rigid-body
    root first crosses zero along a sweep of ``roots`` at the samples ``x`` (altitude or speed;
    the sample before the crossing, as the p-k's :attr:`MatchedPointResult.rigid_body_crossings`;
    :func:`zero_crossings`): a free aircraft's rigid-body root, reported apart, not flutter."""
    crit = [r.rigid_critical() for r in roots]
    g = np.array([np.nan if c is None else 2 * c[0].real / c[0].imag for c in crit])
    idx = zero_crossings(g)  # g is finite at both samples of a crossing
    return [(crit[idx[0] + 1][1], float(np.asarray(x)[idx[0]]))] if idx else []


def state_space_sweep(structure, rfa, velocities, densities, altitudes=None, mach=None) -> dict:
    """Eigenvalues along a path (for root loci): dict with velocity, density, eigenvalues."""
    V = np.asarray(velocities, dtype=float).reshape(-1)
    rho = np.broadcast_to(np.asarray(densities, dtype=float), V.shape)
    eig = np.array(
        [np.linalg.eigvals(state_space_matrix(structure, rfa, v, r)) for v, r in zip(V, rho)]
    )
    return {
        "velocity": V,
        "density": np.asarray(rho),
        "altitude": altitudes,
        "mach": mach,
        "eigenvalues": eig,
    }


# -- matched-point flutter at fixed Mach -----------------------------------------------------------
@dataclass
class MatchedPointResult:
    """Flutter point at fixed Mach by one method, with the sweep that bracketed it."""

    method: str
    mach: float
    altitude: float | None
    frequency_hz: float | None
    velocity: float | None
    density: float | None
    mode: int | None
    sweep: ModeSweep | dict | None = None
    units: str = "ft"
    #: the unit of ``altitude`` (and of the sweep's altitudes): "m" or "ft"
    altitude_unit: str = "ft"
    #: the rigid-body branches (p-k) or modes (state space, :func:`oscillatory_roots`; 0-based)
    #: whose damping crosses zero in the sweep, with the altitude sample where it first does
    #: (a free aircraft's rigid roots: not flutter)
    rigid_body_crossings: list[tuple[int, float]] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {
            "rigid_body_crossings": [{"mode": j + 1, "altitude": a}
                                     for j, a in self.rigid_body_crossings],
            "method": self.method,
            "mach": self.mach,
            "altitude": self.altitude,
            "frequency_hz": self.frequency_hz,
            "velocity": self.velocity,
            "density": self.density,
            "dynamic_pressure": None
            if self.velocity is None
            else 0.5 * self.density * self.velocity**2,
            "mode": None if self.mode is None else self.mode + 1,
            "units": self.units,
            "altitude_unit": self.altitude_unit,
        }


def _altitude_grid(alt_range, n) -> np.ndarray:
    lo, hi = (float(a) for a in alt_range)
    if not hi > lo:
        raise InputError(f"flutter: altitude range: expected LO < HI, got {alt_range}")
    return np.linspace(hi, lo, n)  # high altitude (low q∞) first


def flutter_altitude_state_space(
    structure, rfa, mach, alt_range, n_grid=41, units="ft", xtol=1e-3, *,
    altitude_unit: str | None = None, g_tolerance: float = G_TOLERANCE,
) -> MatchedPointResult:
    """Highest altitude in ``alt_range`` where the critical state-space root crosses Re s = 0
    (a free aircraft's rigid-body roots and roots whose damping is within ``g_tolerance`` of 0
    left out: :meth:`OscillatoryRoots.flutter_root`; the rigid-body roots' crossings listed
    apart).
    Altitudes in ``altitude_unit`` (default the system's; ``xtol`` in it)."""
    h = _altitude_grid(alt_range, n_grid)
    fc = flight_condition(mach, h, units, altitude_unit)
    hu = fc.altitude_unit

    def roots_at(alt):
        c = flight_condition(mach, alt, units, hu)
        return oscillatory_roots(structure, rfa, c.velocity, c.density)

    roots = [oscillatory_roots(structure, rfa, v, r) for v, r in zip(fc.velocity, fc.density)]
    sig = np.array([r.flutter_growth(g_tolerance) for r in roots])
    # a free aircraft's rigid-body roots are reported apart, never as the flutter point
    apart = rigid_body_crossings_state_space(roots, h)
    sweep = state_space_sweep(structure, rfa, fc.velocity, fc.density, h, mach)
    sweep["growth_rate"] = sig
    unstable = sig >= 0  # NaN (every root within the tolerance): not unstable
    idx = np.flatnonzero(~unstable[:-1] & unstable[1:])
    if len(idx) == 0:
        return MatchedPointResult("state-space", mach, None, None, None, None, None, sweep, units,
                                  hu, apart)
    i, target = stable_before(roots, idx[0] + 1, roots[idx[0] + 1].flutter_root(g_tolerance))
    alt, root = refine_crossing(roots_at, h[i + 1], h[i], target, xtol)
    return replace(_matched("state-space", mach, alt, root, None, sweep, units, hu),
                   rigid_body_crossings=apart)


def flutter_altitude_pk(
    structure, aero: AeroTable, mach, alt_range, n_grid=41, units="ft", xtol=1e-3, eps=1e-7,
    *, altitude_unit: str | None = None, g_tolerance: float = G_TOLERANCE,
) -> MatchedPointResult:
    """Highest altitude in ``alt_range`` where a tracked p-k mode's damping crosses zero, from
    below -``g_tolerance`` to above it (:func:`zero_crossings`; altitudes in
    ``altitude_unit``, default the system's; ``xtol`` in it)."""
    h = _altitude_grid(alt_range, n_grid)
    fc = flight_condition(mach, h, units, altitude_unit)
    hu = fc.altitude_unit
    sweep = pk_sweep(structure, aero, fc.velocity, fc.density, altitudes=h, mach=mach, eps=eps)
    # Non-oscillatory roots (divergence) have g = ±inf and are not flutter crossings.
    g = np.where(np.isfinite(sweep.damping), sweep.damping, np.nan)
    # a free aircraft's rigid-body roots are reported apart, never as the flutter point (the
    # rule of the deck flutter, :data:`RIGID_FRACTION`)
    rigid = rigid_body_branches(structure)
    first, apart = None, []
    for j in range(structure.n_modes):
        idx = zero_crossings(g[:, j], g_tolerance)
        if len(idx) and rigid[j]:
            apart.append((j, float(h[idx[0]])))
        elif len(idx) and (first is None or idx[0] < first[0]):
            first = (idx[0], j)
    if first is None:
        return MatchedPointResult("p-k", mach, None, None, None, None, None, sweep, units,
                                  hu, apart)
    i, j = first

    def solve(alt):
        c = flight_condition(mach, alt, units, hu)
        s, _, _, ok = _pk_mode(
            structure,
            aero,
            c.velocity,
            c.density,
            sweep.eigenvalues[i, j],
            sweep.vectors[i, :, j],
            eps,
            200,
        )
        if not ok:
            raise ConvergenceError(f"p-k: mode {j + 1} did not converge at altitude {alt:.6g}")
        return s

    alt = scipy.optimize.brentq(lambda a: solve(a).real, h[i + 1], h[i], xtol=xtol)
    return replace(_matched("p-k", mach, alt, solve(alt), j, sweep, units, hu),
                   rigid_body_crossings=apart)


def _matched(method, mach, alt, root, mode, sweep, units, altitude_unit) -> MatchedPointResult:
    c = flight_condition(mach, alt, units, altitude_unit)
    return MatchedPointResult(
        method,
        mach,
        float(alt),
        root.imag / (2 * np.pi),
        float(c.velocity),
        float(c.density),
        mode,
        sweep,
        units,
        c.altitude_unit,
    )


def growing_response_frequency(structure, rfa, mach, altitudes, units="ft", *,
                               altitude_unit: str | None = None) -> np.ndarray:
    """Frequency (Hz) of the fastest-growing state-space root at each altitude (paper Table 3;
    altitudes in ``altitude_unit``, default the system's)."""
    out = []
    for alt in np.atleast_1d(altitudes):
        c = flight_condition(mach, float(alt), units, altitude_unit)
        out.append(critical_root(structure, rfa, c.velocity, c.density).imag / (2 * np.pi))
    return np.array(out)


def untouched_modes(structure: ModalStructure, a: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Which in-vacuo modes (the columns of ``phi``) the aerodynamics of the state matrix
    ``a`` (:func:`state_space_matrix` of ``structure``) do not touch: those that carry (more
    than :data:`RIGID_SHARE` of the shape) an oscillatory root of ``a`` equal to a root of the
    structure alone (M s² + C s + K) to :data:`G_ROUNDOFF` relative. Such a root's damping is
    the structure's only; at no structural damping it is the round-off that
    :meth:`OscillatoryRoots.flutter_root` and the p-k leave out."""
    m = structure.n_modes
    vacuum, _ = _quadratic_eig(structure.M_inv, structure.C, structure.K)
    s, x = np.linalg.eig(a)
    keep = s.imag > 0
    s, q = s[keep], x[:m, keep]
    same = np.abs(s[:, None] - vacuum[None, :]).min(axis=1) <= G_ROUNDOFF * np.abs(s)
    out = np.zeros(m, dtype=bool)
    for eta in modal_energy(structure, phi, q[:, same]).T:
        j = int(np.argmax(eta))
        out[j] |= bool(eta[j] > RIGID_SHARE * eta.sum())
    return out


def _growth_of_damping(structure, rfa, velocity: float, density: float):
    """growth(α, γ) for arrays α, γ: the largest real part (1/s) of the state-space roots
    (:func:`state_space_matrix`) that can be flutter, at structural damping α M + γ D1 (+ C0).

    Left out, as the flutter search leaves them out: rigid-body roots (more than
    :data:`RIGID_SHARE` of their shape, M-weighted, in the 0 Hz modes; :func:`oscillatory_roots`)
    and the roots of modes the aerodynamics do not touch (:func:`untouched_modes` at α = γ = 0,
    whose round-off damping the p-k ignores; with α, γ their growth is −α/2 − γω²/2, the
    structure's own, and would otherwise set α where the flutter needs α < 0). The matrix is
    affine in (α, γ) — only C = C0 + αM + γD̄1 depends on them, through M̄⁻¹C — so a stack of
    (α, γ) is one stacked eigenvalue solve of a₀ + α a_α + γ a_γ."""

    def matrix(a, gam):
        return state_space_matrix(structure.with_damping(a, gam), rfa, velocity, density)

    a0 = matrix(0.0, 0.0)
    a_alpha, a_gamma = matrix(1.0, 0.0) - a0, matrix(0.0, 1.0) - a0
    min_imag = 2 * np.pi * 1e-3
    f, phi = in_vacuo_modes(structure)
    apart = rigid_body_modes(f) | untouched_modes(structure.with_damping(0.0, 0.0), a0, phi)
    m = structure.n_modes

    def growth(alpha, gam):
        alpha, gam = np.atleast_1d(alpha), np.atleast_1d(gam)
        a = a0 + alpha[:, None, None] * a_alpha + gam[:, None, None] * a_gamma
        if not apart.any():  # no eigenvectors needed
            s = np.linalg.eigvals(a)
            return np.where(s.imag > min_imag, s.real, -np.inf).max(axis=1)
        s, x = np.linalg.eig(a)
        eta = modal_energy(structure, phi, x[:, :m, :])
        flexible = eta[:, apart, :].sum(axis=1) / eta.sum(axis=1) <= RIGID_SHARE
        return np.where((s.imag > min_imag) & flexible, s.real, -np.inf).max(axis=1)

    return growth


def alpha_for_gamma(
    structure, rfa, gamma, mach, altitude, units="ft", bracket=(-5.0, 5.0), xtol=1e-10, *,
    altitude_unit: str | None = None,
) -> float:
    """α such that the flutter point at ``altitude`` (fixed Mach) holds for this γ (paper Fig. 9).

    Solves growth_rate(α; γ, h) = 0 with Brent's method; the bracket is widened if needed.
    The growth rate is that of the roots that can be flutter (:func:`_growth_of_damping`:
    rigid-body roots and modes the aerodynamics do not touch left out). ``altitude`` in
    ``altitude_unit`` (default the system's).
    """
    c = flight_condition(mach, float(altitude), units, altitude_unit)
    rates = _growth_of_damping(structure, rfa, c.velocity, c.density)

    def growth(a):
        return float(rates(a, gamma)[0])

    lo, hi = bracket
    for _ in range(20):
        glo, ghi = growth(lo), growth(hi)
        if glo > 0 > ghi:
            return float(scipy.optimize.brentq(growth, lo, hi, xtol=xtol))
        width = hi - lo
        lo, hi = (lo - width, hi) if glo <= 0 else (lo, hi + width)
    raise ConvergenceError(
        f"alpha(gamma): no sign change of the growth rate for gamma={gamma:g} "
        f"in alpha = {lo:g} .. {hi:g}"
    )


def alpha_for_gammas(
    structure, rfa, gammas, mach, altitude, units="ft", bracket=(-5.0, 5.0), xtol=1e-10,
    max_iterations: int = 100, *, altitude_unit: str | None = None,
) -> np.ndarray:
    """:func:`alpha_for_gamma` for many γ at once (a sampling study's cases): the same root
    of the same growth rate (:func:`_growth_of_damping`: rigid-body roots and modes the
    aerodynamics do not touch left out), found for all γ together, each iteration one stacked
    eigenvalue solve; the root of each growth rate is bracketed and refined by the Illinois
    rule (a regula falsi that halves the retained end's value when the same end is kept twice:
    superlinear, never leaves the bracket) to |Δα| ≤ ``xtol`` (1/s). A γ whose iteration does
    not settle falls back to :func:`alpha_for_gamma`."""
    g = np.asarray(gammas, dtype=float).reshape(-1)
    physical_values("gamma", g, "matched alpha:")
    if g.size == 0:
        return np.zeros(0)
    c = flight_condition(mach, float(altitude), units, altitude_unit)
    growth = _growth_of_damping(structure, rfa, c.velocity, c.density)
    lo, hi = np.full(g.size, float(bracket[0])), np.full(g.size, float(bracket[1]))
    glo, ghi = growth(lo, g), growth(hi, g)
    for _ in range(20):
        bad = ~((glo > 0) & (ghi < 0))
        if not bad.any():
            break
        width = hi[bad] - lo[bad]
        low_side = glo[bad] <= 0
        lo[bad] = np.where(low_side, lo[bad] - width, lo[bad])
        hi[bad] = np.where(low_side, hi[bad], hi[bad] + width)
        glo[bad], ghi[bad] = growth(lo[bad], g[bad]), growth(hi[bad], g[bad])
    bracketed = (glo > 0) & (ghi < 0)
    if not bracketed.all():
        bad = g[~bracketed][0]
        raise ConvergenceError(
            f"alpha(gamma): no sign change of the growth rate for gamma={bad:g}")
    alpha = np.full(g.size, np.nan)
    todo = np.arange(g.size)
    side = np.zeros(g.size, dtype=int)  # which end was kept last (−1 lo, +1 hi)
    for _ in range(max_iterations):
        x = hi[todo] - ghi[todo] * (hi[todo] - lo[todo]) / (ghi[todo] - glo[todo])
        gx = growth(x, g[todo])
        done = (np.abs(gx) == 0) | (np.minimum(x - lo[todo], hi[todo] - x) <= xtol)
        pos = gx > 0
        i = todo
        # the new point replaces the end with the same sign; the other end, kept, is halved
        # when it was kept the time before too (Illinois)
        keep_hi = pos
        ghi[i] = np.where(keep_hi & (side[i] == 1), 0.5 * ghi[i], ghi[i])
        glo[i] = np.where(~keep_hi & (side[i] == -1), 0.5 * glo[i], glo[i])
        lo[i], glo[i] = np.where(pos, x, lo[i]), np.where(pos, gx, glo[i])
        hi[i], ghi[i] = np.where(pos, hi[i], x), np.where(pos, ghi[i], gx)
        side[i] = np.where(pos, 1, -1)
        alpha[i[done]] = x[done]
        todo = i[~done]
        if todo.size == 0:
            break
    for j in todo:  # not settled: the scalar root finder
        alpha[j] = alpha_for_gamma(structure, rfa, g[j], mach, altitude, units, bracket, xtol,
                                   altitude_unit=altitude_unit)
    return alpha


def damping_ratio(s: complex) -> float:
    """Viscous damping ratio ζ = -Re(s)/|s|."""
    return -s.real / abs(s) if abs(s) > 0 else math.nan


def pk_matched_sweep(
    structure, aero: AeroTable, mach, altitudes, units="ft", start_altitude=None, eps: float = 1e-7,
    *, altitude_unit: str | None = None,
) -> ModeSweep:
    """p-k along a matched-point path through ``altitudes`` (sorted high to low internally).

    ``start_altitude`` (optional, above the others) is where tracking starts from the in-vacuo
    modes; the returned sweep holds only the requested altitudes, high to low. Altitudes in
    ``altitude_unit`` (default the system's).
    """
    h = np.sort(np.atleast_1d(np.asarray(altitudes, dtype=float)))[::-1]
    path = h if start_altitude is None else np.r_[float(start_altitude), h]
    fc = flight_condition(mach, path, units, altitude_unit)
    sweep = pk_sweep(structure, aero, fc.velocity, fc.density, altitudes=path, mach=mach, eps=eps)
    if start_altitude is None:
        return sweep
    keep = slice(1, None)
    return replace(
        sweep,
        velocity=sweep.velocity[keep],
        density=sweep.density[keep],
        eigenvalues=sweep.eigenvalues[keep],
        k=sweep.k[keep],
        damping=sweep.damping[keep],
        altitude=sweep.altitude[keep],
        vectors=sweep.vectors[keep],
    )


def growing_response_frequency_pk(
    structure, aero: AeroTable, mach, altitudes, units="ft", start_altitude=None, *,
    altitude_unit: str | None = None,
) -> np.ndarray:
    """Frequency (Hz) of the least-damped p-k mode at each altitude (in the given order;
    altitudes in ``altitude_unit``, default the system's)."""
    alts = np.atleast_1d(np.asarray(altitudes, dtype=float))
    sweep = pk_matched_sweep(structure, aero, mach, alts, units, start_altitude,
                             altitude_unit=altitude_unit)
    order = np.argsort(-alts, kind="stable")  # the sweep runs high to low
    out = np.empty(len(alts))
    g = np.where(np.isfinite(sweep.damping), sweep.damping, -np.inf)  # oscillatory roots only
    out[order] = sweep.frequency_hz[np.arange(len(alts)), np.argmax(g, axis=1)]
    return out


#: a mode whose frequency is below this fraction of the lowest elastic one is a rigid-body
#: mode; the lowest elastic frequency is the lowest at least this fraction of the highest
#: (bah_plane: the rigid plunge and pitch at 0 Hz, the lowest elastic mode 2.454 Hz)
RIGID_FRACTION = 1e-3


def rigid_body_modes(frequencies_hz) -> np.ndarray:
    """Which modes are rigid-body modes (bool per mode, :data:`RIGID_FRACTION`)."""
    f = np.abs(np.asarray(frequencies_hz, dtype=float))
    if f.size == 0 or f.max() == 0:
        return np.ones(f.shape, dtype=bool)
    lowest_elastic = f[f >= RIGID_FRACTION * f.max()].min()
    return f < RIGID_FRACTION * lowest_elastic


def rigid_body_branches(structure: ModalStructure) -> np.ndarray:
    """:func:`rigid_body_modes` of the in-vacuo roots, in the order p-k tracks its branches."""
    s, _ = _vacuum_roots(structure)
    return rigid_body_modes(np.abs(s.imag) / (2 * np.pi))
