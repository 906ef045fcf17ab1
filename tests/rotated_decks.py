"""Rigidly rotated copies of a Nastran deck, for the metamorphic orientation tests.

A rotation R (3x3, basic) is written as a new CORD2R whose axes are R's columns; every card that
was in basic (GRID CP and CD, CORD2x RID, CAERO CP, AERO/AEROS ACSID, CONM2 CID 0, FORCE/MOMENT,
GRAV, SPLINE2/SPLINE4 CID) is put in it. ``coordinates="basic"`` then writes the grids' positions
in basic (rotated by hand) instead of in the new system. Displacement components stay in the
rotated system (CD), so every DOF, SPC and RBE keeps its meaning: the rotated wing is the same
structure, only its orientation in basic differs.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pyNastran.bdf.bdf import read_bdf

from .fe_decks import rotation  # noqa: F401  (Rodrigues; the tests build R with it)


def _place_in_rotated_system(model, cid: int, o: np.ndarray, R: np.ndarray) -> None:
    """Add CORD2R ``cid`` (origin o, axes R's columns) and define in it every coordinate
    system and grid position that was in basic."""
    model.add_cord2r(cid, o, o + R[:, 2], o + R[:, 0], rid=0)
    for c in list(model.coords.values()):
        if c.cid not in (0, cid) and c.type.startswith("CORD2") and not c.rid:
            c.rid = cid
    for node in model.nodes.values():
        if not node.cp:
            node.cp = cid


def rotate_deck(src: Path, out: Path, R: np.ndarray, origin=(0.0, 0.0, 0.0),
                coordinates: str = "rotated") -> Path:
    """Write ``src`` rotated by R about ``origin`` to ``out`` (includes flattened)."""
    model = read_bdf(str(src), xref=False, punch=False, debug=None)
    cid = max([0, *model.coords]) + 1
    o = np.asarray(origin, dtype=float)
    _place_in_rotated_system(model, cid, o, R)
    for node in model.nodes.values():
        if not node.cd:
            node.cd = cid
    for caero in model.caeros.values():
        if hasattr(caero, "cp") and not caero.cp:
            caero.cp = cid
    for card in (model.aero, model.aeros):
        if card is not None and not card.acsid:
            card.acsid = cid
    if model.aeros is not None and not model.aeros.rcsid:
        model.aeros.rcsid = cid
    for mass in model.masses.values():
        if mass.type == "CONM2" and mass.cid == 0:
            mass.cid = cid
    for loads in model.loads.values():
        for load in loads:
            if load.type in ("FORCE", "MOMENT", "GRAV") and not load.cid:
                load.cid = cid
    for spline in model.splines.values():
        if hasattr(spline, "cid") and spline.type in ("SPLINE2", "SPLINE4", "SPLINE5") \
                and not spline.cid:
            spline.cid = cid
    if coordinates == "basic":
        # positions from a cross-referenced copy (cross-referencing the written model and
        # undoing it loses cards, e.g. SPC1 sets)
        placed = read_bdf(str(src), xref=False, punch=False, debug=None)
        _place_in_rotated_system(placed, cid, o, R)
        placed.cross_reference()
        for nid, node in model.nodes.items():
            node.xyz = np.asarray(placed.nodes[nid].get_position(), dtype=float)
            node.cp = 0
    model.write_bdf(str(out), enddata=True, size=16, is_double=True)
    return out
