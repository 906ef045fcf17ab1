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


#: every public deck with FLUTTER cards, and the decks of other systems: its system and
#: evidence are those the cards above tell, whatever its FLFACT velocities (|V|) are
PUBLIC_SYSTEMS = [
    # 30..450 and 4774..5542 together: m/s, ft/s and in/s (FLUTTER 501's list alone would be
    # in/s, the contradiction refused below; its FLUTTER 502 speaks for m/s)
    ("pynastran_bah_plane/bah_plane.bdf", "si", "AERO RHOREF 1.225"),
    ("pynastran_bah_plane_mach0/BAH_Plane.bdf", "si", "AERO RHOREF 1.225"),  # 250..4750
    ("pynastran_bah_gust/BAH_Plane_cont_gust_LINE5000000_10FREQs.bdf", "si",
     "AERO RHOREF 1.225"),  # 30..450
    ("aepw3_pazy_skin_flutter_tipmass0/sol145.dat", "si", "AERO RHOREF 1.225"),  # 1..121
    ("aepw3_pazy_skin_flutter_tipmass1/sol145.dat", "si", "AERO RHOREF 1.225"),
    ("pynastran_pt145/pt145.bdf", "in-lbf-s", "AERO RHOREF 1.145e-07"),  # KE: no velocities
    ("pynastran_ha144d/ha144da.bdf", "ft-slug-s", "PARAM WTMASS 0.031081"),
    ("pynastran_fmondsp/fmondsp.dat", "si", "AERO RHOREF 1.21"),
    ("pynastran_goland_sol200/goland_final_test.bdf", None, None),
    # RHOREF 1: FLFACT densities 0.018..1.55 (SI air or nondimensional), V 147..175 (m/s or
    # ft/s): the tie stays unbroken
    ("pynastran_2_mode_flutter/0012_flutter.bdf", None, None),
]


@pytest.mark.parametrize("deck, system, source", PUBLIC_SYSTEMS)
def test_flfact_velocities_change_no_public_deck(deck, system, source):
    from torchrom.aero.panels import read_model
    from torchrom.fe.deck_units import deck_units

    record = deck_units(read_model(DECKS / deck), deck) or {}
    assert (record.get("unit_system"), record.get("unit_source")) == (system, source)


def _bah_without_flutter_502(folder: Path) -> Path:
    """bah_plane.bdf (with its includes) without FLUTTER 502: its only flutter card is then
    FLUTTER 501, whose FLFACT 3 lists 4774.3..5542.34, in/s beside AERO RHOREF 1.225 kg/m^3."""
    import shutil

    source = DECKS / "pynastran_bah_plane"
    for f in source.iterdir():
        if f.suffix != ".f06":
            shutil.copy(f, folder / f.name)
    deck = folder / "bah_plane.bdf"
    text = deck.read_text()
    assert "FLUTTER, 502, PK, 4, 5, 6, ,\n" in text
    deck.write_text(text.replace("FLUTTER, 502, PK, 4, 5, 6, ,\n", ""))
    return deck


def test_flfact_velocities_against_rhoref_need_units(tmp_path):
    """The doctored BAH deck reads (modes need no units) with the contradiction recorded;
    --units si settles it, as for cards that disagree."""
    deck = _bah_without_flutter_502(tmp_path)
    fe = read_bdf(deck, unsupported="warn")
    assert fe.units.get("unit_system") is None
    with pytest.raises(InputError, match=r"FLFACT 3 velocities 4774.3..5542.34 are in/s "
                                         r"\(in-lbf-s\) but AERO RHOREF 1.225 says si"):
        declare_units(fe, None, deck.name)
    declare_units(fe, "si", deck.name)
    assert fe.units["unit_system"] == "si"
