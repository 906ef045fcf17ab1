"""Modal damping of a flutter subcase (case control SDAMP → TABDMP1, PARAM KDAMP).

References: the TABDMP1 definition (linear between points, linear extrapolation from the end
points, the mean at a discontinuity), and the exact root of a damped mode without air:
s = ω (−ζ ± i √(1 − ζ²)), whose p-k damping 2 Re(s) / |Im(s)| is −2ζ / √(1 − ζ²).
"""

from __future__ import annotations

import shutil
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from torchrom.aero.nastran_flutter import load_deck, run_deck
from torchrom.errors import InputError
from torchrom.fe.modal_damping import ModalDamping

TWO_MODE = Path(__file__).parent / "decks" / "pynastran_2_mode_flutter"


def test_table_interpolation_extrapolation_and_kinds():
    t = ModalDamping(1, "G", np.array([1.0, 2.0, 2.0, 4.0]), np.array([0.02, 0.04, 0.08, 0.06]))
    np.testing.assert_allclose(t.at([1.5, 2.0, 3.0]), [0.03, 0.06, 0.07])
    np.testing.assert_allclose(t.at([0.0, 6.0]), [0.0, 0.04])  # extrapolated from the ends
    np.testing.assert_allclose(t.zeta([1.5]), [0.015])  # G: ζ = g / 2
    np.testing.assert_allclose(t.viscous([1.5]), [2 * 0.015 * 2 * np.pi * 1.5])
    crit = ModalDamping(2, "CRIT", np.array([0.0, 10.0]), np.array([0.05, 0.05]))
    np.testing.assert_allclose(crit.zeta([3.0]), [0.05])
    q = ModalDamping(3, "Q", np.array([0.0, 10.0]), np.array([20.0, 20.0]))
    np.testing.assert_allclose(q.zeta([3.0]), [1.0 / 40.0])  # ζ = 1 / (2Q)


def _two_mode_with(tmp_path, case_lines: str, bulk: str) -> Path:
    for f in TWO_MODE.glob("*.inc"):
        shutil.copy(f, tmp_path / f.name)
    text = (TWO_MODE / "0012_flutter.bdf").read_text()
    text = text.replace("   FMETHOD = 50\n", "   FMETHOD = 50\n" + case_lines)
    text = text.replace("MDLPRM,HDF5,1\n", "MDLPRM,HDF5,1\n" + bulk)
    path = tmp_path / "damped.bdf"
    path.write_text(text)
    return path


def test_sdamp_is_the_damping_of_each_mode_without_air(tmp_path):
    """SDAMP = 7 (TABDMP1 CRIT, ζ = 0.02 at 0 Hz to 0.06 at 20 Hz) on the two-mode plate at a
    vanishing density: each root's p-k damping is −2ζ/√(1−ζ²) with ζ at its own frequency (2.7
    and 10.6 Hz), to 1e-6 (the air left at density × 1e-10)."""
    path = _two_mode_with(tmp_path, "   SDAMP = 7\n", "TABDMP1,7,CRIT\n,0.,0.02,20.,0.06,ENDT\n")
    deck = load_deck(path)
    case = deck.cases[0]
    assert case.damping is not None and case.damping.kind == "CRIT"
    deck.cases = [replace(case, densities=case.densities[:3] * 1e-10, values=case.values[:3],
                          density_ratios=case.density_ratios[:3], machs=case.machs[:3])]
    res = run_deck(deck, log=lambda *_: None)
    assert any("SDAMP = 7" in n for n in res.notes)
    zeta = 0.02 + 0.04 * res.frequencies_hz / 20.0
    sweep = res.results[0].sweep
    np.testing.assert_allclose(sweep.damping[0], -2 * zeta / np.sqrt(1 - zeta**2), rtol=1e-6)


@pytest.mark.parametrize("case_lines, bulk, message", [
    ("   SDAMP = 8\n", "", r"SDAMP = 8: TABDMP1 8 not found"),
    ("   SDAMP = 7\n", "TABDMP1,7\n,0.,0.02,20.,0.06,ENDT\nPARAM,KDAMP,-1\n",
     r"PARAM KDAMP = -1: modal damping as complex stiffness is not supported"),
])
def test_sdamp_refusals(tmp_path, case_lines, bulk, message):
    with pytest.raises(InputError, match=message):
        load_deck(_two_mode_with(tmp_path, case_lines, bulk))


def test_sdamp_with_ke_is_refused(tmp_path):
    path = _two_mode_with(tmp_path, "   SDAMP = 7\n", "TABDMP1,7\n,0.,0.02,20.,0.06,ENDT\n")
    inc = tmp_path / "aero_cards.inc"
    inc.write_text(inc.read_text().replace("FLUTTER       50    PKNL", "FLUTTER       50      KE"))
    with pytest.raises(InputError, match=r"FLUTTER 50: case control SDAMP = 7: .*PK and PKNL"):
        load_deck(path)
