"""The unit system of a Nastran deck: read from its unit-bearing cards, or declared.

The rule is :func:`torchrom.units.infer_units` (AERO/AEROS RHOREF, GRAV, PARAM WTMASS, and
the FLUTTER cards' FLFACT velocities and densities as weaker evidence); this module reads those
numbers from a pyNastran deck and records the result in an FE model's
``units`` (``{"unit_system": name, "length": ..., "unit_source": what told it}``), which
identify and aero store in ``rom.npz``/``aero.npz``.
"""

from __future__ import annotations

import math

from ..units import UnitSystem, infer_units, recorded_units, resolve_units


def deck_unit_numbers(model) -> tuple[list[float], list[float], float | None]:
    """(RHOREF of AERO/AEROS, GRAV accelerations A |N|, PARAM WTMASS) of a pyNastran deck."""
    rhoref = [float(card.rho_ref) for card in (model.aero, model.aeros)
              if card is not None and getattr(card, "rho_ref", None) is not None]
    grav = []
    for cards in model.loads.values():
        for card in cards:
            if card.type == "GRAV":
                grav.append(abs(float(card.scale)) * math.sqrt(sum(float(x)**2
                                                                  for x in card.N)))
    p = model.params.get("WTMASS")
    wtmass = float(p.values[0]) if p is not None and p.values else None
    return rhoref, grav, wtmass


def deck_flutter_factors(model) -> tuple[dict[str, list[float]], dict[str, list[float]]]:
    """(velocities, densities) of a pyNastran deck's FLUTTER cards, FLFACT label -> values:
    the velocities of PK/PKNL cards (K and KE list reduced frequencies instead), and the
    densities only where they are densities themselves (AERO RHOREF 1, Nastran's default:
    FLFACT gives rho/RHOREF). A FLFACT the deck lacks is left to the flutter reader's
    refusal."""
    aero = model.aero
    rhoref = float(aero.rho_ref) if aero is not None and aero.rho_ref is not None else 1.0
    velocities, densities = {}, {}

    def factors(ref):
        card = model.flfacts.get(ref if isinstance(ref, int) else ref.sid)
        return None if card is None else (f"FLFACT {card.sid}", [float(x) for x in
                                                                  card.factors])

    for flutter in model.flutters.values():
        if str(flutter.method).upper() in ("PK", "PKNL"):
            found = factors(flutter.reduced_freq_velocity)
            if found:
                velocities[found[0]] = found[1]
        found = factors(flutter.density)
        if found and rhoref == 1.0:
            densities[found[0]] = found[1]
    return velocities, densities


def units_record(system: UnitSystem, source: str) -> dict[str, str]:
    """An FE model's ``units`` for ``system`` (labels, and what told the system)."""
    return {"unit_system": system.name, "length": system.length, "mass": system.mass,
            "force": system.force, "time": "s", "unit_source": source}


def deck_units(model, fname: str) -> dict[str, str] | None:
    """The ``units`` record of a deck whose cards tell its system (None when none does;
    ``{"unit_conflict": why}`` when two cards disagree: refused by :func:`declare_units`
    unless --units decides, so that commands without units, e.g. modes, still read it)."""
    from ..errors import InputError

    try:
        velocities, densities = deck_flutter_factors(model)
        system, evidence = infer_units(*deck_unit_numbers(model), where=fname,
                                       velocities=velocities, densities=densities)
    except InputError as exc:
        return {"unit_conflict": str(exc)}
    return None if system is None else units_record(system, ", ".join(evidence))


def declare_units(fe, declared: str | None, where: str) -> None:
    """Apply ``--units`` to an FE model read from a deck: checked against what its cards
    tell (InputError naming the card when they differ), recorded in ``fe.units``; a deck
    whose cards disagree is refused unless --units decides."""
    from ..errors import InputError

    units = fe.units or {}
    conflict = units.get("unit_conflict")
    if declared is None:
        if conflict:
            raise InputError(conflict)
        return
    if conflict:
        fe.units = units_record(resolve_units(declared, None, [], where),
                                "--units (the deck's cards disagree)")
        return
    told = units.get("unit_system")
    inferred = None if told is None else resolve_units(told, None, [], where)
    system = resolve_units(declared, inferred, [units.get("unit_source", "")], where)
    if told is None:
        fe.units = units_record(system, "--units")


def describe_units(fe) -> str:
    """One line: the FE model's unit system and what told it, or that none is known."""
    units = fe.units or {}
    if units.get("unit_system"):
        return f"units: {units['unit_system']} ({units.get('unit_source', '')})"
    system = recorded_units(units)
    if system is not None:  # a model that names its units (the Goland deck's ft, slug)
        return f"units: {system.name} ({units['length']}, {units['mass']}, s)"
    return ("units: not told by the deck (no AERO RHOREF, GRAV or PARAM WTMASS of a known "
            "system, nor FLFACT densities and velocities that agree); declare them with "
            "--units for flutter at altitudes")
