"""Flutter speed at a fixed density: the answer for incompressible (Mach 0) aerodynamics.

At a fixed Mach number the flutter point is an altitude (matched point, V = M a(h)); at Mach 0
(GAFs computed for incompressible flow) no Mach ties the speed to the altitude (V = 0 a(h) = 0),
so the flutter point is instead the speed at which a root's damping crosses zero at the
density of a given altitude (USSA-76, :mod:`torchrom.aero.atmosphere`):

* p-k: a sweep over :func:`speed_range` (:func:`torchrom.aero.flutter.pk_sweep`), its crossings
  labelled and solved between the speeds (:func:`torchrom.aero.crossings.pk_crossings`); the
  first flutter crossing (lowest onset speed) is the flutter point;
* state space: the growth rate of the critical root (:func:`torchrom.aero.flutter.critical_root`)
  on the same speeds, its first upward zero refined by Brent's method.

A free structure's rigid-body roots are never the flutter point: both methods list the speed
where one's damping crosses zero apart (``rigid_body_crossings``; p-k by its branches from the
0 Hz modes, the state space by the roots' shapes, :func:`torchrom.aero.flutter.oscillatory_roots`).

Both count a crossing only where the damping changes sign by more than ``g_tolerance``
(:data:`~torchrom.aero.flutter.G_TOLERANCE`; :mod:`torchrom.aero.crossings`): the p-k lists the
branches whose |g| stays within it as not loaded by the aerodynamics, the state space leaves
roots within it out of the critical root. A real root crossing zero is a divergence, reported
with its speed (``divergence_velocity``), never the flutter point: p-k by its real roots'
Nastran damping g = 2 s b / (V ln 2), the state space where K + q A0 is singular
(:func:`static_divergence`; a restrained structure only).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy

from .atmosphere import atmosphere
from .crossings import pk_crossings
from .flutter import (
    G_TOLERANCE,
    AeroTable,
    ModalStructure,
    ModeSweep,
    oscillatory_roots,
    pk_sweep,
    refine_crossing,
    rigid_body_crossings_state_space,
    rigid_body_modes,
    stable_before,
)
from .rfa import RFA

#: speeds of the sweep that brackets the flutter speed
N_SPEEDS = 61


@dataclass
class FlutterSpeed:
    """The flutter speed at one altitude's density (None: no crossing in the speed range)."""

    method: str
    altitude: float
    density: float
    velocity: float | None
    frequency_hz: float | None
    mode: int | None = None
    kind: str | None = None
    stable_velocity: float | None = None
    units: str = "ft"
    #: Mach number of the aerodynamics (0: incompressible; a tunnel at the GAF Mach otherwise)
    mach: float = 0.0
    #: (0-based mode, speed) where a rigid-body root's damping crosses zero: not flutter
    rigid_body_crossings: list[tuple[int, float]] = field(default_factory=list)
    #: the damping tolerance of the crossings (g within ±it counts as 0)
    g_tolerance: float = G_TOLERANCE
    #: the lowest speed where a real root of the flexible structure crosses zero (None: none
    #: in the speed range), and its 0-based branch (p-k; None for the state space)
    divergence_velocity: float | None = None
    divergence_mode: int | None = None
    #: 0-based p-k branches whose |g| stays within g_tolerance at every speed
    not_loaded: list[int] = field(default_factory=list)
    #: the speeds searched (lowest, highest)
    speed_range: tuple[float, float] | None = None
    #: (0-based mode, speed, k) of p-k crossings whose root's reduced frequency lies beyond
    #: the GAF table's largest k: extrapolated aerodynamics, not a flutter point
    extrapolated_crossings: list[tuple[int, float, float]] = field(default_factory=list)

    def as_dict(self) -> dict:
        return {
            "method": self.method, "mach": self.mach,
            "altitude": None if np.isnan(self.altitude) else self.altitude,
            "density": self.density, "velocity": self.velocity,
            "frequency_hz": self.frequency_hz,
            "dynamic_pressure": None if self.velocity is None
            else 0.5 * self.density * self.velocity**2,
            "mode": None if self.mode is None else self.mode + 1, "kind": self.kind,
            "stable_velocity": self.stable_velocity, "units": self.units,
            "rigid_body_crossings": [{"mode": j + 1, "velocity": v}
                                     for j, v in self.rigid_body_crossings],
            "g_tolerance": self.g_tolerance,
            "divergence_velocity": self.divergence_velocity,
            "divergence_mode": None if self.divergence_mode is None
            else self.divergence_mode + 1,
            "not_loaded_modes": [j + 1 for j in self.not_loaded],
            "speed_range": None if self.speed_range is None else list(self.speed_range),
            "extrapolated_crossings": [{"mode": j + 1, "velocity": v, "reduced_frequency": k}
                                       for j, v, k in self.extrapolated_crossings],
        }


def speed_range(structure: ModalStructure, aero: AeroTable) -> tuple[float, float]:
    """Speeds at which the structure's frequencies have reduced frequencies inside the GAF
    table: V = ω b / k from the lowest elastic ω at the largest k to the highest ω at the lowest
    positive k (p-k interpolates Q(k) there instead of extrapolating)."""
    w = 2 * np.pi * structure.natural_frequencies_hz()
    w = w[w > 1e-3 * w.max()]
    k_lo = aero.k_damp if aero.k_damp > 0 else 1e-3
    k_hi = aero.k_max if np.isfinite(aero.k_max) else 2.0
    return float(w.min() * aero.semichord / k_hi), float(w.max() * aero.semichord / k_lo)


def state_space_speed_range(structure: ModalStructure, rfa: RFA, aero: AeroTable
                            ) -> tuple[float, float]:
    """:func:`speed_range`, raised to the speed ω_n b / k_fit where every elastic mode's
    reduced frequency is within the RFA's fit (``rfa.fit_error["k_fit"]``, recorded where
    ``aero`` fitted the RFA on the reduced frequencies that matter,
    :mod:`torchrom.aero.reduced_frequencies`): below it the RFA is extrapolated (bah_plane at
    Mach 0, fitted on k <= 1 of a table to k = 10: a spurious state-space root at 50 m/s)."""
    lo, hi = speed_range(structure, aero)
    k_fit = rfa.fit_error.get("k_fit") if isinstance(rfa.fit_error, dict) else None
    if k_fit:
        w = 2 * np.pi * structure.natural_frequencies_hz()
        lo = min(max(lo, float(w.max()) * rfa.semichord / float(k_fit)), hi)
    return lo, hi


def flutter_speed_pk(structure: ModalStructure, aero: AeroTable, altitude: float,
                     units: str = "ft", n_speeds: int = N_SPEEDS,
                     g_tolerance: float = G_TOLERANCE) -> tuple[FlutterSpeed, ModeSweep]:
    """The p-k flutter speed at the density of ``altitude`` (and the sweep)."""
    rho = float(atmosphere(altitude, units).density)
    res, sweep = flutter_speed_pk_at_density(structure, aero, rho, n_speeds=n_speeds,
                                             g_tolerance=g_tolerance)
    res.altitude, res.units = float(altitude), units
    return res, sweep


def flutter_speed_pk_at_density(structure: ModalStructure, aero: AeroTable, density: float,
                                mach: float = 0.0, n_speeds: int = N_SPEEDS,
                                g_tolerance: float = G_TOLERANCE,
                                speeds: tuple[float, float] | None = None,
                                ) -> tuple[FlutterSpeed, ModeSweep]:
    """The p-k flutter speed at air density ``density`` and Mach ``mach`` (that of the GAFs:
    SOL 145's PK at one Mach and density, or a wind tunnel), with the sweep: the first
    flutter crossing (lowest onset speed) of :func:`~torchrom.aero.crossings.pk_crossings`
    at ``g_tolerance`` over ``speeds`` (default :func:`speed_range`); the first divergence
    and the branches not loaded by the aerodynamics beside it. A crossing whose root's reduced
    frequency lies beyond the GAF table's largest k is no flutter point: its Q is extrapolated
    (pt145's 236 Hz mode at 45.7 in/s, k = 34 on a table to k = 10: a "hump" of the cubic
    spline's extrapolation); it is listed in ``extrapolated_crossings``. ``altitude`` of the
    result is NaN."""
    rho = float(density)
    span = tuple(float(x) for x in (speeds or speed_range(structure, aero)))
    v = np.geomspace(*span, n_speeds)
    # real roots keep Nastran's finite damping: a divergence is then a crossing, labelled so
    sweep = pk_sweep(structure, aero, v, rho, mach=mach, eps=1e-7, real_root_damping="nastran")
    found = pk_crossings(structure, aero, sweep, tol=g_tolerance)
    res = FlutterSpeed("p-k", float("nan"), rho, None, None, mach=mach,
                       rigid_body_crossings=[(p.mode, p.velocity) for p in found.rigid_body],
                       g_tolerance=float(g_tolerance), not_loaded=found.not_loaded,
                       speed_range=span)
    if found.divergence:
        d = min(found.divergence, key=lambda p: p.velocity)
        res.divergence_velocity, res.divergence_mode = d.velocity, d.mode
    inside = [p for p in found.flutter if not p.k > aero.k_max * (1 + 1e-9)]
    res.extrapolated_crossings = [(p.mode, p.velocity, p.k) for p in found.flutter
                                  if p not in inside]
    if inside:
        p = min(inside, key=lambda p: p.velocity)
        res.velocity, res.frequency_hz, res.mode = p.velocity, p.frequency_hz, p.mode
        res.kind, res.stable_velocity = p.kind, p.stable_velocity
    return res, sweep


def flutter_speed_state_space(structure: ModalStructure, rfa: RFA, aero: AeroTable,
                              altitude: float, units: str = "ft",
                              n_speeds: int = N_SPEEDS,
                              g_tolerance: float = G_TOLERANCE) -> FlutterSpeed:
    """The state-space flutter speed at the density of ``altitude`` (first upward zero of the
    critical root's growth rate over :func:`speed_range`)."""
    rho = float(atmosphere(altitude, units).density)
    res = flutter_speed_at_density(structure, rfa, aero, rho, n_speeds,
                                   g_tolerance=g_tolerance)
    res.altitude, res.units = float(altitude), units
    return res


def flutter_speed_at_density(structure: ModalStructure, rfa: RFA, aero: AeroTable,
                             density: float, n_speeds: int = N_SPEEDS,
                             speeds: tuple[float, float] | None = None,
                             mach: float = 0.0,
                             g_tolerance: float = G_TOLERANCE) -> FlutterSpeed:
    """The state-space flutter speed at the air density ``density`` (a wind tunnel; the
    RFA's units, e.g. slug/ft³ and ft/s): the first upward zero of the critical root's growth
    rate (roots whose damping is within ``g_tolerance`` of 0 left out:
    :meth:`OscillatoryRoots.flutter_root`) over ``speeds``, refined by Brent's method to 1e-10
    relative (from the last sample below it where that root is stable:
    :func:`~torchrom.aero.flutter.stable_before`); the divergence speed beside it
    (:func:`static_divergence`). ``speeds`` default: :func:`state_space_speed_range`.
    ``altitude`` of the result is NaN (no altitude is implied); ``mach`` (that of the
    aerodynamics) is recorded in it."""
    rho = float(density)
    span = tuple(float(x) for x in (speeds or state_space_speed_range(structure, rfa, aero)))
    v = np.geomspace(*span, n_speeds)

    def roots_at(x):
        return oscillatory_roots(structure, rfa, x, rho)

    roots = [roots_at(x) for x in v]
    res = FlutterSpeed("state-space", float("nan"), rho, None, None, mach=mach,
                       rigid_body_crossings=rigid_body_crossings_state_space(roots, v),
                       g_tolerance=float(g_tolerance), speed_range=span)
    res.divergence_velocity = static_divergence(structure, rfa, rho, span)
    # unstable: a root beyond the tolerance grows (NaN, every root within it: not unstable)
    unstable = np.array([r.flutter_growth(g_tolerance) >= 0 for r in roots])
    up = np.flatnonzero(~unstable[:-1] & unstable[1:])
    if len(up) == 0:
        return res
    i, target = stable_before(roots, up[0] + 1, roots[up[0] + 1].flutter_root(g_tolerance))
    vf, root = refine_crossing(roots_at, v[i], v[i + 1], target, 1e-10 * v[i + 1])
    res.velocity, res.frequency_hz = vf, root.imag / (2 * np.pi)
    return res


def static_divergence(structure: ModalStructure, rfa: RFA, density: float, speeds
                      ) -> float | None:
    """The lowest speed in ``speeds`` where a real state-space root passes through s = 0 (None:
    none there, or a free structure). s = 0 is a root of the state space (paper Eqs. 49-50)
    exactly where the static stiffness K + q A0 is singular (q̇ = 0 and ξ = 0 there; A0 = Q(0)):
    q_D is the smallest positive real eigenvalue of the pencil (K, -A0), V_D = √(2 q_D / ρ).
    A free structure's pencil is singular at every q (its rigid plunge: K and A0 both null on
    it), and the crossing of its rigid-body real root depends on the p terms too (the free
    climb, docs/guide/bah.md): no divergence is given for it."""
    if rigid_body_modes(structure.natural_frequencies_hz()).any():
        return None
    with np.errstate(invalid="ignore", divide="ignore"):
        lam = scipy.linalg.eigvals(structure.K, -rfa.A0)
    real = lam[np.isfinite(lam) & (np.abs(lam.imag) <= 1e-9 * np.abs(lam)) & (lam.real > 0)]
    v = np.sqrt(2 * real.real / density)
    v = v[(v >= speeds[0]) & (v <= speeds[1])]
    return float(v.min()) if v.size else None
