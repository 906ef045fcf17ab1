"""The unit system of the public decks (torchrom.fe.deck_units) against what their SOURCE.md
and cards say: BAH aircraft SI (m, kg: AERO RHOREF 1.225 kg/m^3), pt145 and HA146C in-lbf-s
(RHOREF 1.145e-7 and 1.1468e-7 lbf s^2/in^4; HA146C's PARAM WTMASS 0.0025907 = 1/386.0 agrees),
the 2-mode flutter deck none (RHOREF 1.0, a density-ratio convention)."""

import re
from pathlib import Path

import pytest

from torchrom.errors import InputError
from torchrom.fe import read_bdf
from torchrom.fe.deck_units import declare_units, describe_units

DECKS = Path(__file__).parent / "decks"


@pytest.mark.parametrize("deck, system, source", [
    ("pynastran_bah_plane/bah_plane.bdf", "si", "AERO RHOREF 1.225"),
    ("pynastran_pt145/pt145.bdf", "in-lbf-s", "AERO RHOREF 1.145e-07"),
    ("pynastran_bah_ha146c/ha146c.bdf", "in-lbf-s",
     "AERO RHOREF 1.1468e-07, PARAM WTMASS 0.0025907"),
    ("pynastran_2_mode_flutter/0012_flutter.bdf", None, None),
])
def test_public_decks(deck, system, source):
    fe = read_bdf(DECKS / deck, unsupported="warn")
    assert fe.units.get("unit_system") == system
    assert fe.units.get("unit_source") == source
    if system is None:
        assert "not told by the deck" in describe_units(fe)
        declare_units(fe, "ft-slug-s", deck)
        assert fe.units["unit_system"] == "ft-slug-s" and fe.units["length"] == "ft"
    else:
        assert describe_units(fe) == f"units: {system} ({source})"
        declare_units(fe, system, deck)  # agreeing with the cards: kept as told
        assert fe.units["unit_source"] == source
        with pytest.raises(InputError, match=re.escape(f"the deck's {source} says {system}")):
            declare_units(fe, "mm-t-s", deck)
