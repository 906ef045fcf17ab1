"""SOL 200 decks: the property and material values their design relations give.

Nastran's SOL 200 analyses the initial design: a property or material field tied to design
variables by DVPREL1/DVPREL2/DVMREL1/DVMREL2 takes the relation's value at the DESVAR initial
values (XINIT), whatever the property card says. torchrom reads the cards as written, so a SOL
200 deck whose relations disagree with its cards would be analysed at another design: it is
refused with a one-line reason naming the relation, the field and both values. pyNastran
evaluates the linear relations (DVPREL1/DVMREL1: C0 + Σ COEFF·XINIT) and applies them to a copy
of the card, which is then compared with the card. The equation relations (DVPREL2/DVMREL2,
DEQATN) are not evaluated (that would execute the deck's equation text): each is named in a note
saying that the card's value is used where Nastran's SOL 200 uses the equation's.
"""

from __future__ import annotations

import copy

import numpy as np

from ..errors import InputError

#: relative difference above which a field of the card and of the design differ
TOLERANCE = 1e-6


def _values(card) -> list:
    return list(card.raw_fields())


def _differs(a, b) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return not np.isclose(float(a), float(b), rtol=TOLERANCE, atol=0.0)
    return a != b


def check_initial_design(model, fname: str) -> list[str]:
    """Refuse a SOL 200 deck whose design relations change a card at the initial design;
    return notes for the relations pyNastran cannot evaluate."""
    if getattr(model, "sol", None) != 200:
        return []
    from pyNastran.bdf.cards.optimization import get_dvxrel1_coeffs

    xinit = {int(i): float(d.xinit) for i, d in model.desvars.items()}
    notes = []
    relations = [(r, model.properties, "pid") for r in model.dvprels.values()]
    relations += [(r, model.materials, "mid") for r in model.dvmrels.values()]
    for rel, cards, key in relations:
        target = cards.get(getattr(rel, key))
        if target is None:
            raise InputError(f"{fname}: {rel.type} {rel.oid}: {key.upper()} "
                             f"{getattr(rel, key)} not found")
        name = getattr(rel, "pname_fid", None) or getattr(rel, "mp_name", "?")
        what = f"{rel.type} {rel.oid} ({target.type} {getattr(rel, key)} {name})"
        if not rel.type.endswith("1"):
            notes.append(f"{what}: equation relation not evaluated; the card's value is used "
                         "(Nastran's SOL 200 analyses the equation's value at XINIT)")
            continue
        try:
            value = get_dvxrel1_coeffs(rel, model, xinit)
            designed = copy.deepcopy(target)
            if key == "pid":
                rel._update_by_dvprel(designed, value)
            else:
                rel._update_by_dvmrel(designed, value)
        except Exception as exc:  # pyNastran raises many kinds for what it cannot evaluate
            notes.append(f"{what}: not evaluated ({type(exc).__name__}); the card's value is "
                         "used (Nastran's SOL 200 analyses the relation's value at XINIT)")
            continue
        old, new = _values(target), _values(designed)
        changed = [i for i, (a, b) in enumerate(zip(old, new)) if _differs(a, b)]
        if changed or len(old) != len(new):
            i = changed[0] if changed else min(len(old), len(new))
            was = old[i] if i < len(old) else None
            raise InputError(
                f"{fname}: SOL 200: {rel.type} {rel.oid}: {target.type} "
                f"{getattr(rel, key)} {name} is {value:.6g} at the initial design (DESVAR "
                f"XINIT), the card has {was}: Nastran analyses the design's value; make the "
                "card agree with it")
    return notes
