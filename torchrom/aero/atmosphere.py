"""U.S. Standard Atmosphere 1976 at geometric altitude, in foot–slug–second or SI units.

Delegated: the atmosphere itself is the ``ambiance`` package (USSA-76, geometric altitude,
valid from -5,004 m to 81,020 m). Written here: unit conversion, range checks with one-line
errors, and the matched-point flight condition (V = M a(h), q = ½ ρ V²) used by the flutter
solvers (paper Sec. III.C: Mach 0.70, altitude in ft).

Units (DESIGN contract, never converted inside the numerics): any system of
:mod:`torchrom.units` (``"si"``, ``"ft-slug-s"``, ``"in-lbf-s"``, ``"mm-t-s"``; ``"ft"`` is
``"ft-slug-s"``). Altitude is in the system's altitude unit (ft or m), density, speed and
pressure in its own units (e.g. in-lbf-s: lbf s²/in⁴, in/s, lbf/in²), temperature in K:

=============  =========  ============  ==========  ============
units          altitude   density       velocity    pressure
=============  =========  ============  ==========  ============
``"ft"``       ft         slug/ft³      ft/s        lbf/ft² (psf)
``"si"``       m          kg/m³         m/s         Pa
``"in-lbf-s"`` ft         lbf s²/in⁴    in/s        lbf/in²
``"mm-t-s"``   m          t/mm³         mm/s        MPa
=============  =========  ============  ==========  ============

The altitude travels with its unit: ``altitude_unit`` (``"m"`` or ``"ft"``,
:data:`torchrom.units.ALTITUDE_UNITS`) names it when it is not the system's (an SI model
flown at altitudes given in ft, the Goland wing at altitudes in m); the state records it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..checks import ALTITUDE_RANGE_M
from ..errors import InputError
from ..units import ALTITUDE_UNITS, altitude_unit, unit_system

#: metres per foot (exact, international foot)
FT = 0.3048
#: kg/m³ per slug/ft³ (1 slug = 14.593902937 kg)
SLUG_PER_FT3 = 14.593902937206364 / FT**3
#: Pa per lbf/ft²
PSF = 4.4482216152605 / FT**2


@dataclass(frozen=True)
class AtmosphereState:
    """USSA-76 state at one or more geometric altitudes (arrays or floats, in ``units``)."""

    altitude: np.ndarray | float
    temperature: np.ndarray | float  # K
    pressure: np.ndarray | float
    density: np.ndarray | float
    speed_of_sound: np.ndarray | float
    units: str
    altitude_unit: str = "ft"


@dataclass(frozen=True)
class FlightCondition:
    """Matched-point flight condition at a fixed Mach number (V = M a(h), q = ½ ρ V²)."""

    altitude: np.ndarray | float
    mach: float
    velocity: np.ndarray | float
    density: np.ndarray | float
    dynamic_pressure: np.ndarray | float
    speed_of_sound: np.ndarray | float
    units: str
    altitude_unit: str = "ft"


def _factors(units: str, alt_unit: str | None = None) -> tuple[float, float, float, float]:
    """(m per altitude unit, m per length unit, kg/m³ per density unit, Pa per pressure
    unit) of ``units``, the altitude in ``alt_unit`` when given (else the system's)."""
    try:
        s = unit_system(units, "atmosphere: units")
    except InputError:
        raise InputError(
            f"atmosphere: units: expected one of ['ft', 'si', 'ft-slug-s', 'in-lbf-s', "
            f"'mm-t-s'], got {units!r}"
        ) from None
    alt_m = s.altitude_metre if alt_unit is None else ALTITUDE_UNITS[alt_unit]
    return alt_m, s.metre, s.density_si, s.pressure_si


def _unit_of_altitude(units: str, alt_unit: str | None) -> str:
    """The altitude unit: ``alt_unit`` checked, else the system's."""
    if alt_unit is not None:
        return altitude_unit(alt_unit, "atmosphere: altitude_unit")
    _factors(units)  # the one-line refusal of an unknown system
    return unit_system(units).altitude


def _altitude_m(altitude, units: str, alt_unit: str | None = None) -> tuple[np.ndarray, float]:
    alt_m, length, _, _ = _factors(units, alt_unit)
    h = np.asarray(altitude, dtype=float)
    if not np.all(np.isfinite(h)):
        raise InputError(f"atmosphere: altitude: expected finite values, got {altitude!r}")
    h_m = h * alt_m
    lo, hi = ALTITUDE_RANGE_M
    if np.any(h_m < lo) or np.any(h_m > hi):
        bad = h.flat[np.argmax((h_m < lo) | (h_m > hi))]
        name = _unit_of_altitude(units, alt_unit)
        raise InputError(
            f"atmosphere: altitude {bad:g} {name} is outside the "
            f"USSA-76 range {lo / alt_m:.0f} .. {hi / alt_m:.0f} {name}"
        )
    return h_m, length


def _scalar_or_array(x: np.ndarray, like) -> np.ndarray | float:
    return float(x) if np.ndim(like) == 0 else x


def atmosphere(altitude, units: str = "ft", altitude_unit: str | None = None
               ) -> AtmosphereState:
    """USSA-76 temperature, pressure, density and speed of sound at geometric ``altitude``
    (in ``altitude_unit``, default the system's altitude unit)."""
    from ambiance import Atmosphere

    alt_unit = _unit_of_altitude(units, altitude_unit)
    h_m, length = _altitude_m(altitude, units, alt_unit)
    _, _, dens_f, pres_f = _factors(units)
    atm = Atmosphere(np.atleast_1d(h_m))
    shape = np.shape(h_m)
    out = {
        "temperature": atm.temperature.reshape(shape),
        "pressure": atm.pressure.reshape(shape) / pres_f,
        "density": atm.density.reshape(shape) / dens_f,
        "speed_of_sound": atm.speed_of_sound.reshape(shape) / length,
    }
    return AtmosphereState(
        altitude=_scalar_or_array(np.asarray(altitude, dtype=float), altitude),
        units=units,
        altitude_unit=alt_unit,
        **{k: _scalar_or_array(v, altitude) for k, v in out.items()},
    )


def density(altitude, units: str = "ft", altitude_unit: str | None = None):
    """Air density in ``units`` (slug/ft³ for ``"ft"``, kg/m³ for ``"si"``, ...)."""
    return atmosphere(altitude, units, altitude_unit).density


def speed_of_sound(altitude, units: str = "ft", altitude_unit: str | None = None):
    """Speed of sound in ``units`` (ft/s for ``"ft"``, m/s for ``"si"``, ...)."""
    return atmosphere(altitude, units, altitude_unit).speed_of_sound


def flight_condition(mach: float, altitude, units: str = "ft",
                     altitude_unit: str | None = None) -> FlightCondition:
    """Matched-point condition at fixed Mach: V = M a(h), ρ(h), q = ½ ρ V² (``altitude`` in
    ``altitude_unit``, default the system's)."""
    if not (np.isfinite(mach) and mach > 0.0):
        raise InputError(f"flight condition: mach: expected a positive number, got {mach!r}")
    st = atmosphere(altitude, units, altitude_unit)
    v = mach * np.asarray(st.speed_of_sound)
    q = 0.5 * np.asarray(st.density) * v**2
    return FlightCondition(
        altitude=st.altitude,
        mach=float(mach),
        velocity=_scalar_or_array(v, altitude),
        density=st.density,
        dynamic_pressure=_scalar_or_array(q, altitude),
        speed_of_sound=st.speed_of_sound,
        units=units,
        altitude_unit=st.altitude_unit,
    )
