"""The unit system of a model: which consistent units its numbers are in, and how to tell.

A structural/aeroelastic model is in one of four consistent systems (:data:`SYSTEMS`):

=============  ======  ==============  =====  ===============  ===========  ========
name           length  mass            force  density          pressure     altitude
=============  ======  ==============  =====  ===============  ===========  ========
``si``         m       kg              N      kg/m^3           Pa           m
``ft-slug-s``  ft      slug            lbf    slug/ft^3        lbf/ft^2     ft
``in-lbf-s``   in      lbf s^2/in      lbf    lbf s^2/in^4     lbf/in^2     ft
``mm-t-s``     mm      t               N      t/mm^3           MPa          m
=============  ======  ==============  =====  ===============  ===========  ========

Speeds are in length/s, frequencies in Hz, times in s. Altitude (geometric, USSA-76) is in ft
for the two imperial systems and in m for the metric ones, as flight altitudes are quoted
(the length unit itself for si and ft-slug-s); the atmosphere itself is computed in SI and
converted (:mod:`torchrom.aero.atmosphere`).

The altitude unit of a run: one of :data:`ALTITUDE_UNITS` (``m``, ``ft``), the system's by
default or the one the user names (``--altitude-unit``, ``[model] altitude_unit``, or the
``altitude_<unit>`` key of a sweep); :meth:`UnitSystem.with_altitude` gives the system whose
labels and factors carry it, and every altitude printed, tabled or drawn in that run is in it.

How a deck's system is told (:func:`infer_units`), from the cards that carry a unit:

- AERO/AEROS RHOREF: the system whose sea-level density (1.225 kg/m^3 converted) lies within a
  factor :data:`DENSITY_FACTOR` of it; a RHOREF of exactly 1 is the density-ratio convention
  (densities given by FLFACT) and says nothing;
- GRAV: the system whose standard gravity (9.80665 m/s^2 converted) is within 2 % of the
  card's acceleration A |N|;
- PARAM WTMASS: 1/g in ft/s^2 (0.03108) or in in/s^2 (0.00259) within 2 % (masses given as
  weights in lbf): ft-slug-s or in-lbf-s.

Two cards that say different systems are refused in one line (declare ``--units``).

The FLUTTER cards' FLFACT lists are weaker evidence, used only to break a tie or to flag a
clear contradiction:

- velocities (PK, PKNL; |V|): a typical subsonic flutter sweep runs over
  :data:`FLUTTER_SPEEDS` (10..400 m/s), i.e. ft/s 33..1,312, in/s 394..15,748, mm/s
  10,000..400,000. These overlap, so the velocities (all FLUTTER cards' together) tell a
  system only when every one lies in its range and none in another's
  (:func:`speed_system`): 2,000..9,000 is in/s, but 30..450 (m/s or ft/s) says nothing;
- densities: where AERO RHOREF is 1 the FLFACT densities are densities themselves; all air
  densities of one system (:func:`is_air_density`) name it, but they may as well be a
  nondimensional model's (pyNastran's 2-mode deck: 0.018..1.55 with V 147..175).

Where a card above tells the system, velocities that tell another are refused in one line
naming the FLFACT and that card (declare ``--units`` or correct the card); velocities that
agree join its evidence. Where no card tells, FLFACT densities and velocities that tell the
same system decide; either alone tells nothing.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace

from .errors import InputError

#: standard gravity (m/s^2)
G0 = 9.80665
#: USSA-76 sea-level density (kg/m^3)
RHO_SL = 1.225
#: a RHOREF is taken as the density of a system when within this factor of its sea-level
#: density (0.1 .. 10 covers altitudes up to ~18 km; systems are >= 500x apart)
DENSITY_FACTOR = 10.0
#: relative tolerance of GRAV and WTMASS against a system's g and 1/g
GRAVITY_TOL = 0.02
#: what a ROM or aero file without a recorded system is assumed to be (the built-in Goland
#: wing's, in which the package's first ROMs were written)
LEGACY_SYSTEM = "ft-slug-s"


@dataclass(frozen=True)
class UnitSystem:
    """One consistent unit system (labels and SI factors, see the module table)."""

    name: str
    length: str
    mass: str
    force: str
    density: str
    pressure: str
    altitude: str
    metre: float  # metres per length unit
    kilogram: float  # kilograms per mass unit
    altitude_metre: float  # metres per altitude unit

    @property
    def speed(self) -> str:
        return f"{self.length}/s"

    @property
    def density_si(self) -> float:
        """kg/m^3 per density unit."""
        return self.kilogram / self.metre**3

    @property
    def pressure_si(self) -> float:
        """Pa per pressure unit (force/length^2 = mass/(length s^2))."""
        return self.kilogram / self.metre

    @property
    def sea_level_density(self) -> float:
        return RHO_SL / self.density_si

    @property
    def gravity(self) -> float:
        """Standard gravity in length/s^2."""
        return G0 / self.metre

    def with_altitude(self, unit: str | None, where: str = "--altitude-unit") -> UnitSystem:
        """This system with altitudes in ``unit`` (:data:`ALTITUDE_UNITS`; None: unchanged);
        InputError naming ``where`` for another unit."""
        if unit is None or unit == self.altitude:
            return self
        unit = altitude_unit(unit, where)
        return replace(self, altitude=unit, altitude_metre=ALTITUDE_UNITS[unit])

    def labels(self) -> dict[str, str]:
        """Units of the quantities a printed or JSON result carries."""
        return {"system": self.name, "length": self.length, "mass": self.mass,
                "force": self.force, "speed": self.speed, "velocity": self.speed,
                "density": self.density, "dynamic_pressure": self.pressure,
                "altitude": self.altitude, "frequency": "Hz", "time": "s"}


_FT, _IN, _LBF = 0.3048, 0.0254, 4.4482216152605
SYSTEMS = {
    s.name: s for s in (
        UnitSystem("si", "m", "kg", "N", "kg/m^3", "Pa", "m", 1.0, 1.0, 1.0),
        UnitSystem("ft-slug-s", "ft", "slug", "lbf", "slug/ft^3", "lbf/ft^2", "ft", _FT,
                   _LBF / _FT, _FT),
        UnitSystem("in-lbf-s", "in", "lbf s^2/in", "lbf", "lbf s^2/in^4", "lbf/in^2", "ft",
                   _IN, _LBF / _IN, _FT),
        UnitSystem("mm-t-s", "mm", "t", "N", "t/mm^3", "MPa", "m", 1e-3, 1e3, 1.0),
    )
}
#: older names of the atmosphere's two systems
ALIASES = {"ft": "ft-slug-s"}
#: the units a flight altitude may be given in: name -> metres per unit (exact, international
#: foot)
ALTITUDE_UNITS = {"m": 1.0, "ft": _FT}
#: the prefix of an altitude's table column and case parameter (``altitude_ft``,
#: ``altitude_m``): the column's name says its unit
ALTITUDE_PREFIX = "altitude_"


def altitude_unit(name, where: str = "--altitude-unit") -> str:
    """``name`` checked against :data:`ALTITUDE_UNITS` (InputError naming ``where``)."""
    if name not in ALTITUDE_UNITS:
        raise InputError(f"{where}: expected one of {', '.join(ALTITUDE_UNITS)}, got {name!r}")
    return str(name)


def altitude_column(unit: str) -> str:
    """The case parameter and table column of an altitude in ``unit``: ``altitude_<unit>``."""
    return ALTITUDE_PREFIX + altitude_unit(unit, "altitude column")


#: the altitude columns a table may have, column -> unit
ALTITUDE_COLUMNS = {ALTITUDE_PREFIX + u: u for u in ALTITUDE_UNITS}


def unit_system(name: str, where: str = "--units") -> UnitSystem:
    """The system called ``name`` (or an :data:`ALIASES` name); InputError naming ``where``."""
    key = ALIASES.get(name, name)
    if key not in SYSTEMS:
        raise InputError(f"{where}: expected one of {', '.join(SYSTEMS)}, got {name!r}")
    return SYSTEMS[key]


def _close(x: float, y: float, tol: float) -> bool:
    return abs(x / y - 1.0) <= tol


#: speeds of a typical subsonic flutter sweep (m/s: Mach 0.03..1.2 at sea level), converted
#: to each system's length/s by :func:`speed_system`
FLUTTER_SPEEDS = (10.0, 400.0)


def speed_system(speeds: Sequence[float]) -> UnitSystem | None:
    """The system whose typical flutter-sweep speeds (:data:`FLUTTER_SPEEDS` in its length/s)
    hold every nonzero |speed| while no other system's holds any of them; None otherwise
    (the ranges overlap: such speeds say nothing)."""
    v = [abs(float(x)) for x in speeds if x != 0]

    def held(system):
        lo, hi = (x / system.metre for x in FLUTTER_SPEEDS)
        return [lo <= x <= hi for x in v]

    inside = [s for s in SYSTEMS.values() if v and all(held(s))]
    touched = [s for s in SYSTEMS.values() if any(held(s))]
    return inside[0] if inside and len(touched) == 1 else None


def density_system(densities: Sequence[float]) -> UnitSystem | None:
    """The system in which every density is an air density (:func:`is_air_density`; their
    ranges are 500x apart, so at most one); None when none is or there are none."""
    found = [s for s in SYSTEMS.values()
             if densities and all(is_air_density(float(r), s) for r in densities)]
    return found[0] if found else None


def _flfact_label(lists: Mapping[str, Sequence[float]], what: str) -> str:
    """'FLFACT 3, FLFACT 6 velocities 30..5542.34' (magnitudes)."""
    v = [abs(float(x)) for values in lists.values() for x in values if x != 0]
    return f"{', '.join(lists)} {what} {min(v):g}..{max(v):g}"


def infer_units(rhoref: Sequence[float] = (), grav: Sequence[float] = (),
                wtmass: float | None = None, where: str = "deck", *,
                velocities: Mapping[str, Sequence[float]] | None = None,
                densities: Mapping[str, Sequence[float]] | None = None,
                ) -> tuple[UnitSystem | None, list[str]]:
    """(system, evidence) from a deck's unit-bearing numbers (module docstring's rule);
    (None, []) when none tells; InputError when two tell different systems, or when FLFACT
    velocities (card label -> values) clearly contradict the cards. ``densities``: FLFACT
    densities where they are absolute (AERO RHOREF 1), card label -> values."""
    votes: list[tuple[str, str]] = []
    for rho in rhoref:
        if rho > 0 and rho != 1.0:
            for s in SYSTEMS.values():
                if 1 / DENSITY_FACTOR <= rho / s.sea_level_density <= DENSITY_FACTOR:
                    votes.append((s.name, f"AERO RHOREF {rho:g}"))
    for g in grav:
        for s in SYSTEMS.values():
            if g > 0 and _close(g, s.gravity, GRAVITY_TOL):
                votes.append((s.name, f"GRAV {g:g}"))
    if wtmass is not None and wtmass != 1.0:
        for name in ("ft-slug-s", "in-lbf-s"):
            if _close(wtmass, 1 / SYSTEMS[name].gravity, GRAVITY_TOL):
                votes.append((name, f"PARAM WTMASS {wtmass:g}"))
    names = list(dict.fromkeys(n for n, _ in votes))
    if len(names) > 1:
        a = next(e for n, e in votes if n == names[0])
        b = next(e for n, e in votes if n == names[1])
        raise InputError(f"{where}: units: {a} says {names[0]} but {b} says {names[1]}; "
                         f"declare the deck's system with --units")
    by_speed = speed_system([x for values in (velocities or {}).values() for x in values])
    speed_label = _flfact_label(velocities, "velocities") if by_speed else ""
    if names:
        told, evidence = SYSTEMS[names[0]], [e for _, e in votes]
        if by_speed is None:
            return told, evidence
        if by_speed is told:
            return told, [*evidence, speed_label]
        raise InputError(f"{where}: units: {speed_label} are {by_speed.speed} "
                         f"({by_speed.name}) but {evidence[0]} says {told.name}; correct the "
                         f"FLFACT or declare the deck's system with --units")
    by_density = density_system([x for values in (densities or {}).values() for x in values])
    if by_speed is not None and by_density is by_speed:
        return by_speed, [_flfact_label(densities, "densities"), speed_label]
    return None, []


def resolve_units(declared: str | None, inferred: UnitSystem | None, evidence: Sequence[str],
                  where: str) -> UnitSystem | None:
    """The declared system (``--units``) checked against the deck's evidence, else the
    inferred one; InputError when they differ."""
    if declared is None:
        return inferred
    s = unit_system(declared)
    if inferred is not None and inferred.name != s.name:
        raise InputError(f"{where}: --units {s.name}: the deck's {evidence[0]} says "
                         f"{inferred.name}; drop --units or correct the card")
    return s


#: the key of a file's metadata that records its unit system (rom.npz, aero.npz)
METADATA_KEY = "unit_system"


def recorded_units(metadata: Mapping) -> UnitSystem | None:
    """The system a ROM's or aero file's metadata records: :data:`METADATA_KEY`, else the
    ``units`` entry (a ROM's ``source.units``) of files written before it (``{"length":
    "ft", "mass": "slug", ...}`` or ``"ft, slug, s"``), or an FE model's ``units`` itself,
    when it names a system's length and mass; None when unknown."""
    name = metadata.get(METADATA_KEY)
    if name:
        return unit_system(str(name), "metadata unit_system")
    source = metadata.get("source")
    units = (metadata.get("units") or (source.get("units") if isinstance(source, Mapping)
                                       else None)
             or (metadata if "length" in metadata else None))  # an FE model's units itself
    if isinstance(units, Mapping):
        if units.get(METADATA_KEY):
            return unit_system(str(units[METADATA_KEY]), "metadata units")
        pair = (units.get("length"), units.get("mass"))
    elif isinstance(units, str):
        parts = [p.strip() for p in units.split(",")]
        pair = tuple(parts[:2]) if len(parts) >= 2 else (None, None)
    else:
        return None
    return next((s for s in SYSTEMS.values() if (s.length, s.mass) == pair), None)


def file_units(files: Mapping[str, Mapping], declared: str | None = None
               ) -> tuple[UnitSystem, str]:
    """(system, note) of files used together (name -> metadata): the one they record, which
    must agree (and agree with ``declared``, the --units given for files that record none);
    :data:`LEGACY_SYSTEM` when none records one and none is declared, said in ``note``."""
    found = {name: recorded_units(meta) for name, meta in files.items()}
    known = {name: s for name, s in found.items() if s is not None}
    names = list(dict.fromkeys(s.name for s in known.values()))
    if len(names) > 1:
        a, b = ((f, s.name) for f, s in known.items() if s.name in names[:2])
        raise InputError(f"{a[0]} is in {a[1]} but {b[0]} in {b[1]}: files of different unit "
                         f"systems; rebuild one of them with --units {a[1]}")
    if declared is not None:
        s = unit_system(declared)
        if names and names[0] != s.name:
            f = next(iter(known))
            raise InputError(f"--units {s.name}: {f} records {names[0]}; drop --units (it is "
                             f"for files that record no unit system)")
        return s, "" if names else f"units: {s.name} (declared with --units)"
    if names:
        missing = [f for f in files if f not in known]
        note = (f"units: {names[0]} (recorded in {', '.join(known)}; assumed for "
                f"{', '.join(missing)}, which records none)" if missing else "")
        return SYSTEMS[names[0]], note
    return (SYSTEMS[LEGACY_SYSTEM],
            f"units: {', '.join(files)} record no unit system: assumed {LEGACY_SYSTEM} (the "
            f"built-in Goland wing's); declare another with --units")



#: densities a wind tunnel or flight may have, relative to sea level (0.01: USSA-76 at ~31 km;
#: the sea-level densities of two systems differ by 515x (ft-slug-s, si) or more)
AIR_DENSITY_RANGE = (0.01, 2.0)


def is_air_density(rho: float, system: UnitSystem) -> bool:
    """Whether ``rho`` is an air density in ``system``'s units (within
    :data:`AIR_DENSITY_RANGE` of its sea-level density): a density given in another system
    is 500 times or more off."""
    lo, hi = AIR_DENSITY_RANGE
    return lo <= rho / system.sea_level_density <= hi
