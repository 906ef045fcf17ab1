"""FE model → Nastran bulk data deck.

Delegated to pyNastran (card formatting, large-field output so that every float keeps its
digits). Every :class:`~torchrom.fe.model.FEModel` carries the pyNastran deck it was built from
(``fe.bdf``: read from a file or built in memory by :func:`torchrom.fe.goland`), including its
aerodynamic cards; the writer adds executive/case control if the deck had none (SOL 103 with the
model's SPC set and eigenvalue method) and writes it atomically. Reading the written deck back
gives identical matrices (tested).
"""

from __future__ import annotations

import contextlib
import io
import warnings
from pathlib import Path

from ..errors import InputError
from ..io import atomic_path, check_can_write


def write_bdf(fe, path, *, force: bool = False) -> Path:
    """Write ``fe``'s deck to ``path`` (refuses to overwrite unless ``force``)."""
    if getattr(fe, "bdf", None) is None:
        raise InputError(f"write_bdf: model {fe.name!r} has no Nastran deck to write")
    path = check_can_write(path, force, "deck")
    model = fe.bdf
    if not model.executive_control_lines or not any(
        ln.strip().upper().startswith("SOL") for ln in model.executive_control_lines
    ):
        model.executive_control_lines = ["SOL 103", "CEND"]
    if model.case_control_deck is None:
        from pyNastran.bdf.case_control_deck import CaseControlDeck

        lines = [f"SPC = {sid}" for sid in sorted(model.spcs)[:1] if len(model.spcs) == 1]
        lines += [f"METHOD = {sid}" for sid in sorted(model.methods)[:1]]
        model.case_control_deck = CaseControlDeck(lines + ["BEGIN BULK"], log=model.log)
    with atomic_path(path) as tmp, contextlib.redirect_stdout(io.StringIO()), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")
        model.write_bdf(str(tmp), size=16, is_double=False, enddata=True)
    return path
