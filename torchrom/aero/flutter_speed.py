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
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .atmosphere import atmosphere
from .crossings import pk_crossings
from .flutter import (
    AeroTable,
    ModalStructure,
    ModeSweep,
    oscillatory_roots,
    pk_sweep,
    refine_crossing,
    rigid_body_crossings_state_space,
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


def flutter_speed_pk(structure: ModalStructure, aero: AeroTable, altitude: float,
                     units: str = "ft", n_speeds: int = N_SPEEDS) -> tuple[FlutterSpeed,
                                                                          ModeSweep]:
    """The p-k flutter speed at the density of ``altitude`` (and the sweep)."""
    rho = float(atmosphere(altitude, units).density)
    res, sweep = flutter_speed_pk_at_density(structure, aero, rho, n_speeds=n_speeds)
    res.altitude, res.units = float(altitude), units
    return res, sweep


def flutter_speed_pk_at_density(structure: ModalStructure, aero: AeroTable, density: float,
                                mach: float = 0.0, n_speeds: int = N_SPEEDS
                                ) -> tuple[FlutterSpeed, ModeSweep]:
    """The p-k flutter speed at air density ``density`` and Mach ``mach`` (that of the GAFs:
    SOL 145's PK at one Mach and density, or a wind tunnel), with the sweep: the first
    flutter crossing (lowest onset speed) of :func:`~torchrom.aero.crossings.pk_crossings`
    over :func:`speed_range`. ``altitude`` of the result is NaN."""
    rho = float(density)
    v = np.geomspace(*speed_range(structure, aero), n_speeds)
    sweep = pk_sweep(structure, aero, v, rho, mach=mach, eps=1e-7)
    found = pk_crossings(structure, aero, sweep)
    apart = [(p.mode, p.velocity) for p in found.rigid_body]
    if not found.flutter:
        return FlutterSpeed("p-k", float("nan"), rho, None, None, mach=mach,
                            rigid_body_crossings=apart), sweep
    p = min(found.flutter, key=lambda p: p.velocity)
    return FlutterSpeed("p-k", float("nan"), rho, p.velocity, p.frequency_hz, p.mode, p.kind,
                        p.stable_velocity, mach=mach, rigid_body_crossings=apart), sweep


def flutter_speed_state_space(structure: ModalStructure, rfa: RFA, aero: AeroTable,
                              altitude: float, units: str = "ft",
                              n_speeds: int = N_SPEEDS) -> FlutterSpeed:
    """The state-space flutter speed at the density of ``altitude`` (first upward zero of the
    critical root's growth rate over :func:`speed_range`)."""
    rho = float(atmosphere(altitude, units).density)
    res = flutter_speed_at_density(structure, rfa, aero, rho, n_speeds)
    res.altitude, res.units = float(altitude), units
    return res


def flutter_speed_at_density(structure: ModalStructure, rfa: RFA, aero: AeroTable,
                             density: float, n_speeds: int = N_SPEEDS,
                             speeds: tuple[float, float] | None = None,
                             mach: float = 0.0) -> FlutterSpeed:
    """The state-space flutter speed at the air density ``density`` (a wind tunnel; the
    RFA's units, e.g. slug/ft³ and ft/s): the first upward zero of the critical root's growth
    rate (roots whose damping is round-off left out: :meth:`OscillatoryRoots.flutter_root`)
    over ``speeds`` (default :func:`speed_range`), refined by Brent's method to 1e-10
    relative. ``altitude`` of the result is NaN (no altitude is implied); ``mach`` (that of
    the aerodynamics) is recorded in it."""
    rho = float(density)
    v = np.geomspace(*(speeds or speed_range(structure, aero)), n_speeds)

    roots = [oscillatory_roots(structure, rfa, x, rho) for x in v]
    apart = rigid_body_crossings_state_space(roots, v)
    sig = np.array([r.flutter_growth() for r in roots])
    up = np.flatnonzero((sig[:-1] < 0) & (sig[1:] >= 0))
    if len(up) == 0:
        return FlutterSpeed("state-space", float("nan"), rho, None, None, mach=mach,
                            rigid_body_crossings=apart)
    i = up[0]
    vf, root = refine_crossing(lambda x: oscillatory_roots(structure, rfa, x, rho), v[i],
                               v[i + 1], roots[i + 1].flutter_root(), 1e-10 * v[i + 1])
    return FlutterSpeed("state-space", float("nan"), rho, vf, root.imag / (2 * np.pi),
                        mach=mach, rigid_body_crossings=apart)
