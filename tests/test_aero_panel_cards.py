"""The include file of aerodynamic cards (torchrom.aero.panel_cards), read back by torchrom's
own Nastran reader (an independent path: pyNastran parses the written text, torchrom.aero
builds the boxes): the boxes cover the planform exactly, on the right side of the aerodynamic
system for a right and a left wing; the splines, MKAERO1, FLUTTER and LMODES are there."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.aero.nastran_flutter import load_deck
from torchrom.aero.outline import Planform
from torchrom.aero.panel_cards import PanelOptions, panel_model, write_panel_cards

STRUCTURE = """SOL 103
CEND
BEGIN BULK
GRID,1,,0.,0.,0.
GRID,2,,1.,0.,0.
GRID,3,,0.,{y},0.
GRID,4,,1.,{y},0.
CQUAD4,1,1,1,2,4,3
PSHELL,1,1,0.01
MAT1,1,7.e10,,0.3,2700.
SPC1,1,123456,1,2
ENDDATA
"""


@pytest.mark.parametrize("side", [1.0, -1.0])
def test_boxes_cover_the_planform_on_its_side(side, tmp_path):
    """A 1 x 4 rectangle (chord along basic x, span along side * basic y, up +z): 2 x 4 boxes
    whose corners span x = 0..1 and y = 0..4 side (the aerodynamic system is basic here)."""
    plan = Planform(s=np.array([0.0, 4.0]), le=np.zeros(2), te=np.ones(2), n=np.zeros(2))
    opts = PanelOptions(n_chord=2, n_span=4, machs=(0.3,), velocities=(10.0, 20.0),
                        rho_ref=1.225, first_id=100, lmodes=4, symxz=0)
    model = panel_model(plan, np.zeros(3), [1.0, 0, 0], [0, 0, 1.0], [0, side, 0], [1, 2, 3, 4],
                        opts)
    cards = tmp_path / "panels.bdf"
    write_panel_cards(cards, model, ["test"])
    text = cards.read_text()
    assert "BEGIN BULK" not in text and "ENDDATA" not in text
    deck = tmp_path / "wing.bdf"
    deck.write_text(STRUCTURE.format(y=4.0 * side))
    fl = load_deck(deck, includes=[cards])
    corners = fl.aero_panels.corners
    assert fl.aero_panels.n == 8
    assert corners[..., 0].min() == pytest.approx(0.0) and corners[..., 0].max() == \
        pytest.approx(1.0)
    y = corners[..., 1] * side
    assert y.min() == pytest.approx(0.0, abs=1e-12) and y.max() == pytest.approx(4.0)
    assert fl.reference.rho_ref == pytest.approx(1.225)
    assert fl.reference.semichord == pytest.approx(0.5)
    (case,) = fl.cases
    assert case.method == "PK" and np.allclose(case.values, [10.0, 20.0])
    assert sorted({m for m, _ in fl.mkaero}) == [0.3]
    assert "LMODES" in text
    # SYMXZ 1 (the default): the same boxes and their image in the root plane
    mirrored = tmp_path / "mirrored.bdf"
    write_panel_cards(mirrored, panel_model(plan, np.zeros(3), [1.0, 0, 0], [0, 0, 1.0],
                                            [0, side, 0], [1, 2, 3, 4], PanelOptions()), [])
    assert load_deck(deck, require_flutter=False, includes=[mirrored]).aero_panels.n == 2 * 8 * 24
