"""Nastran's static aeroelastic cards for a restrained wing: TRIM (Mach, dynamic pressure and
the fixed trim variables) with AESTAT ANGLEA (the angle of attack, rad), and the case
control's TRIM selection (MSC QRG: TRIM, AESTAT). Only ANGLEA is a variable torchrom can fix:
the rigid root incidence of a clamped wing; a free aircraft's trim (URDD*, PITCH, control
surfaces) is refused in one line.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from ..errors import InputError


@dataclass(frozen=True)
class TrimCase:
    """One TRIM card: ``sid``, ``mach``, ``dynamic_pressure`` (the deck's units) and the root
    angle of attack ``aoa_rad`` (ANGLEA)."""

    sid: int
    mach: float
    dynamic_pressure: float
    aoa_rad: float


def _selected(model) -> list[int]:
    """TRIM set IDs the case control selects (above the subcases or in them)."""
    cc = getattr(model, "case_control_deck", None)
    ids = []
    if cc is not None:
        for sub in cc.subcases.values():
            if "TRIM" in sub.params:
                ids.append(int(sub.params["TRIM"][0]))
    return sorted(set(ids))


def read_trims(model, path: Path | str) -> list[TrimCase]:
    """The TRIM cases of a pyNastran ``model`` that its case control selects (all of its TRIM
    cards when none is selected); [] when it has none."""
    ids = _selected(model) or sorted(model.trims)
    out = []
    aestat = {card.label.upper() for card in model.aestats.values()}
    for sid in ids:
        card = model.trims.get(sid)
        if card is None:
            raise InputError(f"{path}: TRIM = {sid} in the case control: no TRIM card {sid}")
        values = {str(label).upper(): float(ux) for label, ux in zip(card.labels, card.uxs)}
        other = sorted(set(values) - {"ANGLEA"})
        if other:
            raise InputError(f"{path}: TRIM {sid}: label {other[0]}: only ANGLEA (the root "
                             "angle of attack of a restrained wing) can be fixed here")
        if "ANGLEA" not in values:
            raise InputError(f"{path}: TRIM {sid}: expected ANGLEA with its value (rad)")
        if "ANGLEA" not in aestat:
            raise InputError(f"{path}: TRIM {sid}: ANGLEA: no AESTAT card defines it")
        if not card.q > 0:
            raise InputError(f"{path}: TRIM {sid}: Q: expected a positive dynamic pressure, "
                             f"got {card.q}")
        out.append(TrimCase(int(sid), float(card.mach), float(card.q), values["ANGLEA"]))
    return out
