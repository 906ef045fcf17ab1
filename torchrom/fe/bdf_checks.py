"""Field checks of a Nastran deck before it becomes a mesh (hand-written; no library does them).

pyNastran parses the fields but accepts any number, NaN and ±inf included, and Nastran itself
only rejects some signs at run time. Here every numeric field of every card is checked to be
finite and below :data:`MAX_FIELD` in magnitude, and the fields whose sign or range the physics
fixes (areas, thicknesses, densities, masses ≥ 0; E > 0; −1 < ν ≤ 0.5; coordinates below
:data:`MAX_COORDINATE`) follow the table :data:`FIELD_RULES`, so that a bad value is reported on
its own card and field — never as a singular matrix, an "infs or NaNs" error or a misleading
complaint about another card.

Also here: the truncation check of a deck's text (a bulk data section without ``ENDDATA``, the way
Nastran reports a file cut off) and the one-line message of pyNastran's duplicate-ID error.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Iterable

from ..errors import InputError

#: Largest coordinate magnitude accepted: beyond it, element lengths of order 1 are lost to the
#: rounding of float64 (ε ≈ 1.1e-16) — a deck there is a typo (1.+20 for 1.+2), not a model.
MAX_COORDINATE = 1e15
#: Largest magnitude of any numeric field: products of two such values (E × A, ρ × t) stay far
#: from float64's overflow (1.8e308); a value beyond is an exponent typo, never a model
MAX_FIELD = 1e100


def _positive(x: float) -> bool:
    return x > 0


def _nonnegative(x: float) -> bool:
    return x >= 0


def _poisson(x: float) -> bool:
    return -1.0 < x <= 0.5


def _coordinate(x: float) -> bool:
    return abs(x) <= MAX_COORDINATE


POSITIVE = (_positive, "a positive number")
NONNEGATIVE = (_nonnegative, "a number >= 0")
POISSON = (_poisson, "a Poisson ratio in (-1, 0.5]")
COORDINATE = (_coordinate, f"a coordinate of magnitude <= {MAX_COORDINATE:g}")

#: card type -> [(attribute, Nastran field name, (rule, what is expected))]; a blank (None)
#: field is left to the reader (its default applies). Add a row to check a new field.
FIELD_RULES: dict[str, list[tuple[str, str, tuple[Callable[[float], bool], str]]]] = {
    "GRID": [("xyz", "X1-X3", COORDINATE)],
    "MAT1": [("e", "E", POSITIVE), ("g", "G", NONNEGATIVE), ("nu", "NU", POISSON),
             ("rho", "RHO", NONNEGATIVE)],
    "PROD": [("A", "A", POSITIVE), ("j", "J", NONNEGATIVE)],
    "CONROD": [("A", "A", POSITIVE), ("j", "J", NONNEGATIVE)],
    "PBAR": [("A", "A", NONNEGATIVE), ("i1", "I1", NONNEGATIVE), ("i2", "I2", NONNEGATIVE),
             ("j", "J", NONNEGATIVE)],
    "PSHELL": [("t", "T", POSITIVE), ("twelveIt3", "12I/T**3", NONNEGATIVE),
               ("tst", "TS/T", NONNEGATIVE)],
    "PSHEAR": [("t", "T", POSITIVE)],
    "CONM2": [("mass", "M", NONNEGATIVE)],
}
# CMASS1/CMASS2 masses are checked by the reader: negative between two DOFs (a coupling term of
# a mass matrix, as in MSC's BAH wing HA146C) is allowed, negative to ground is not.

#: cards whose blank optional fields pyNastran lists as NaN (PBEAM's stations): only an
#: infinite value is an error there
NAN_IS_BLANK = frozenset({"PBEAM"})

# the dictionaries of a pyNastran BDF holding cards with an ID (name used in messages)
_CONTAINERS = ("nodes", "coords", "elements", "properties", "materials", "masses",
               "rigid_elements", "methods", "params")
_LISTS = ("spcs", "spcadds", "loads")
# the aerodynamic cards (read by torchrom.aero): finiteness only
AERO_CONTAINERS = ("caeros", "paeros", "splines", "flfacts", "flutters", "aefacts", "sets")


def _cards(model, containers=_CONTAINERS, lists=_LISTS) -> Iterable:
    for name in containers:
        yield from getattr(model, name, {}).values()
    for name in lists:
        for cards in getattr(model, name, {}).values():
            yield from cards
    if containers is AERO_CONTAINERS:
        yield from getattr(model, "mkaeros", [])
        for single in ("aero", "aeros"):
            card = getattr(model, single, None)
            if card is not None:
                yield card


def _card_id(card) -> str:
    for attr in ("eid", "nid", "pid", "mid", "cid", "sid", "conid", "key"):
        value = getattr(card, attr, None)
        if value is not None and not callable(value):
            return f"{card.type} {value}"
    return card.type


def _numbers(value) -> list[float]:
    """The floats in a field value (a number, or a vector of them); [] for a blank/text."""
    if value is None or isinstance(value, (str, bool)):
        return []
    if isinstance(value, (int, float)):
        return [float(value)]
    try:
        return [float(v) for v in value]
    except (TypeError, ValueError):
        return []


def check_fields(model, fname: str, aero: bool = False) -> None:
    """InputError naming file, card, ID and field for the first non-finite field or rule
    violation (:data:`FIELD_RULES`) in the structural cards of a pyNastran model (``aero``:
    in its aerodynamic cards instead)."""
    cards = _cards(model, AERO_CONTAINERS, ()) if aero else _cards(model)
    for card in cards:
        try:
            fields = card.raw_fields()
        except Exception:  # noqa: BLE001 - a card pyNastran cannot list is checked by the reader
            continue
        blank_nan = card.type in NAN_IS_BLANK
        for k, value in enumerate(fields[1:], start=2):
            if isinstance(value, float) and not math.isfinite(value) and not (
                    blank_nan and math.isnan(value)):
                # small-field numbering on the first line; after it, continuation fields shift
                where = f"field #{k}" if k <= 9 else f"value #{k - 1} after the card name"
                raise InputError(f"{fname}: {_card_id(card)}: {where}: expected a finite "
                                 f"number, got {value}")
        for attr, field, (rule, expected) in FIELD_RULES.get(card.type, ()):
            for x in _numbers(getattr(card, attr, None)):
                if not math.isfinite(x) or not rule(x):
                    raise InputError(f"{fname}: {_card_id(card)}: field {field}: expected "
                                     f"{expected}, got {x:g}")
        # after the rules, which name the field (a coordinate's own bound is tighter)
        for k, value in enumerate(fields[1:], start=2):
            if isinstance(value, float) and abs(value) > MAX_FIELD:
                where = f"field #{k}" if k <= 9 else f"value #{k - 1} after the card name"
                raise InputError(f"{fname}: {_card_id(card)}: {where}: expected a magnitude "
                                 f"<= {MAX_FIELD:g} (an exponent typo?), got {value:g}")


def check_complete(text: str, fname: str) -> None:
    """InputError when a deck's bulk data has no ENDDATA (a file cut off; Nastran's fatal
    "ENDDATA card missing")."""
    for line in text.splitlines():
        if line.split("$")[0].strip().upper().startswith("ENDDATA"):
            return
    if not any(_DECK_LINE.match(line) for line in text.splitlines()):
        raise InputError(f"{fname}: not a Nastran deck: no GRID, SOL, CEND, BEGIN BULK or "
                         f"ENDDATA line (the first line is {_first_line(text)!r}); expected a "
                         f"bulk data deck, e.g. model.bdf")
    raise InputError(f"{fname}: no ENDDATA card: the deck is truncated or incomplete (the last "
                     f"line is {_last_line(text)!r})")


#: a line only a Nastran deck has: the executive, case control or bulk data landmarks, or a GRID
_DECK_LINE = re.compile(r"^\s*(SOL\b|CEND\b|BEGIN\s+BULK|ENDDATA|GRID[*,\s])", re.IGNORECASE)


def _first_line(text: str) -> str:
    lines = [ln.rstrip() for ln in text.splitlines() if ln.strip()]
    return lines[0][:40] if lines else ""


def _last_line(text: str) -> str:
    lines = [ln.rstrip() for ln in text.splitlines() if ln.strip()]
    return lines[-1][:40] if lines else ""


# pyNastran's duplicate-ID reports: "nid=2 / old_node= / GRID ..." (an assertion) and
# "self.elements IDs are not unique=[2] / old_element= / CBAR ..." (DuplicateIDsError)
_DUPLICATE = re.compile(r"^(?:\w+=(\d+)|.*IDs are not unique=\[([\d, ]+)\])\s*\n\s*old_\w+="
                        r"\s*\n\s*(\w+)", re.M)


def duplicate_message(fname: str, text: str) -> str | None:
    """The one-line message of pyNastran's duplicate-ID errors (the card and the ID named), or
    None when ``text`` is not one."""
    m = _DUPLICATE.search(text)
    if not m:
        return None
    ident = m.group(1) or m.group(2).split(",")[0].strip()
    card = m.group(3)
    return f"{fname}: {card} {ident}: duplicate ID (two {card} cards with ID {ident})"


def failed_card(exc: BaseException):
    """The pyNastran ``BDFCard`` that was being added when ``exc`` was raised (the deepest
    frame of its traceback holding one as ``card_obj`` or ``card``), or None: pyNastran's own
    messages often name neither the card nor its ID."""
    found = None
    tb = exc.__traceback__
    while tb is not None:
        local = tb.tb_frame.f_locals
        for name in ("card_obj", "card"):
            obj = local.get(name)
            if obj is not None and hasattr(obj, "field") and hasattr(obj, "nfields"):
                found = obj
        tb = tb.tb_next
    return found


def _card_number(card, i: int) -> float | None:
    try:
        x = float(card.field(i))
    except (TypeError, ValueError, IndexError):
        return None
    return x


#: the definition points of the coordinate-system cards by three points (fields of A, B, C)
_THREE_POINT_CARDS = ("CORD2R", "CORD2C", "CORD2S")
#: relative size of |AB × AC| below which three points define no plane (float64 rounding of
#: coordinates of order |AB| |AC|, with a margin)
_COLLINEAR_RTOL = 1e-12


def degenerate_geometry_message(card) -> str | None:
    """What is wrong with a geometry card whose points define nothing (a CORD2R/C/S with
    coincident or collinear points A, B, C), or None. pyNastran reports only ``norm(v)=0``."""
    import numpy as np

    name = str(card.field(0)).strip().upper()
    if name not in _THREE_POINT_CARDS:
        return None
    vals = [_card_number(card, i) for i in range(3, 12)]  # A1..C3
    if any(v is None for v in vals):
        vals = [0.0 if v is None else v for v in vals]  # blank fields default to 0.0
    a, b, c = (np.array(vals[k:k + 3]) for k in (0, 3, 6))
    ab, ac = b - a, c - a
    cid = card.field(1)
    where = f"{name} {cid}"
    if not np.linalg.norm(ab) > 0:
        return f"{where}: points A and B coincide ({list(a)}): A is the origin, B on the z axis"
    cross = np.linalg.norm(np.cross(ab, ac))
    if not cross > _COLLINEAR_RTOL * np.linalg.norm(ab) * max(np.linalg.norm(ac), 1e-300):
        return (f"{where}: points A, B, C are collinear (A = {list(a)}, B = {list(b)}, C = "
                f"{list(c)}): C must lie off the z axis AB to fix the x-z plane")
    return None


#: a pyNastran message whose placeholders were never formatted (``{len(card):d}``)
_PLACEHOLDER = re.compile(r"\{[^{}]*\}")


def _failed_coord(exc: BaseException):
    """The pyNastran coordinate system (``self`` of a CORD* method) whose setup raised
    ``exc`` while it was cross-referenced (a CORD1R/C/S is set up from its grids then)."""
    found = None
    tb = exc.__traceback__
    while tb is not None:
        obj = tb.tb_frame.f_locals.get("self")
        if type(obj).__name__.startswith("CORD") and hasattr(obj, "cid"):
            found = obj
        tb = tb.tb_next
    return found


def card_error_message(fname: str, exc: BaseException, first: str) -> str | None:
    """One line for a pyNastran error raised while a card was added (:func:`failed_card`) or a
    coordinate system was set up: the card, its ID and what is wrong, or None when no card is
    known."""
    card = failed_card(exc)
    coord = _failed_coord(exc) if card is None else None
    # a CORD2* fails its setup on a zero cross product ("norm(v)=0"), a CORD1* its
    # validation (three distinct grids) or its setup from the grids' positions
    if coord is not None and ("norm" in first or type(coord).__name__.startswith("CORD1")):
        name = type(coord).__name__
        grids = [getattr(coord, g, None) for g in ("g1", "g2", "g3")]
        points = (f"grids G1, G2, G3 ({', '.join(str(getattr(g, 'nid', g)) for g in grids)})"
                  if name.startswith("CORD1") else "points A, B, C")
        return (f"{fname}: {name} {coord.cid}: {points} are collinear or coincide: they "
                f"define no coordinate system (C must lie off the z axis AB)")
    if card is None:
        return None
    degenerate = degenerate_geometry_message(card)
    if degenerate is not None:
        return f"{fname}: {degenerate}"
    name = str(card.field(0)).strip().upper()
    where = f"{name} {card.field(1)}" if card.nfields > 1 and card.field(1) is not None else name
    if first.startswith(f"len({name} card)"):
        return (f"{fname}: {where}: too many fields ({card.nfields} with the continuation "
                f"lines; a stray continuation line?)")
    text = _PLACEHOLDER.sub("?", first).strip()
    return f"{fname}: {where}: {text}"
