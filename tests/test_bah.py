"""The BAH aircraft (tests/decks/pynastran_bah_plane: free-free, SI, m-kg-N) end to end
through the real command line, as docs/guide/bah.md does it (issue 35 items 1 and 6):
modes -> identify -> aero -> ROM flutter, every number in SI and labelled so.

Target: the ROM's flutter speed and frequency within 2 % of the deck's own SOL 145-style
answer (``torchrom flutter`` on the deck with the ROM's 8 modes, no residual vectors: 393.43 m/s,
3.1784 Hz, measured in tests/test_public_decks.py::test_rom_flutter_bah_plane_free_free_against
_the_deck) and of the f06's (MSC Nastran, FLUTTER 502 POINT 4: 394.04 m/s, 3.1784 Hz), inside
the f06's bracket of speeds 390-420 m/s. Measured: 394.30 m/s, 3.1779 Hz (+0.22 % and -0.02 %
against the deck, +0.07 % and -0.02 % against the f06).
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from .test_public_decks import _bah_plane_both_subcases

#: the f06's FLUTTER 502 crossing (POINT 4) and the speeds that bracket it
F06_SPEED, F06_FREQUENCY_HZ, F06_BRACKET = 394.04, 3.1784, (390.0, 420.0)
#: the deck's own answer with the ROM's basis (module docstring)
DECK_SPEED, DECK_FREQUENCY_HZ = 393.43, 3.1784
#: the deck's MKAERO1 reduced frequencies up to 1 (the flutter point is at k = 0.10 with the
#: semichord 2 m; the deck's list goes on to k = 10)
RFA_K = ("0.001", "0.05", "0.1", "0.2", "0.5", "1.0")


def _torchrom(folder, *argv) -> str:
    run = subprocess.run([sys.executable, "-m", "torchrom", *argv], cwd=folder,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    assert "Traceback" not in run.stderr
    return run.stdout


def test_bah_rom_flutter_in_si_matches_the_deck(tmp_path):
    """identify (8 linear modes, 2 of them rigid at 0 Hz; no dual modes: flutter needs the
    linear part only) -> aero (the deck's boxes, splines and MKAERO k at Mach 0.2, Nastran's
    parabolic kernel) -> flutter at the deck's density, 1.225 kg/m^3 (RHOREF x FLFACT 1.0),
    p-k. The units are read from AERO RHOREF and printed with every number. ~40 s."""
    deck = _bah_plane_both_subcases(tmp_path)
    out = _torchrom(tmp_path, "identify", deck.name, "--linear", "8", "--dual", "0",
                    "--out", "rom.npz")
    assert "units: si (AERO RHOREF 1.225)" in out
    _torchrom(tmp_path, "aero", deck.name, "--mach", "0.2", "--modes", "8", "--kernel",
              "parabolic", "--out", "aero.npz", "--json", "aero.json")
    aero = json.loads((tmp_path / "aero.json").read_text())
    assert aero["unit_system"] == "si" and aero["units"]["semichord"] == "m"
    assert aero["frequencies_hz"][:2] == [0.0, 0.0]  # free-free: rigid-body modes kept
    out = _torchrom(tmp_path, "flutter", "rom.npz", "aero.npz", "--density", "1.225",
                    "--method", "pk", "--alpha", "0", "--gamma", "0", "--json", "f.json")
    for label in ("density kg/m^3", "V m/s", "q Pa", "units si"):
        assert label in out, (label, out)
    res = json.loads((tmp_path / "f.json").read_text())
    assert res["units"]["speed"] == "m/s" and res["units"]["dynamic_pressure"] == "Pa"
    (pk,) = res["flutter"]
    print(f"BAH ROM p-k: {pk['velocity']:.2f} m/s, {pk['frequency_hz']:.4f} Hz, {pk['kind']}")
    assert pk["velocity"] == pytest.approx(DECK_SPEED, rel=0.02)
    assert pk["frequency_hz"] == pytest.approx(DECK_FREQUENCY_HZ, rel=0.02)
    assert pk["velocity"] == pytest.approx(F06_SPEED, rel=0.02)
    assert pk["frequency_hz"] == pytest.approx(F06_FREQUENCY_HZ, rel=0.02)
    assert F06_BRACKET[0] < pk["velocity"] < F06_BRACKET[1]
    assert pk["mode"] == 4  # the 3.75 Hz mode, as the f06's POINT 4


def test_bah_state_space_flutter_with_the_rfa_fitted_up_to_k_1(tmp_path):
    """The state-space (RFA) flutter, which the LCO sweep's model is, against the p-k on the
    same tabulated GAFs. Fitted over the deck's whole MKAERO list (k to 10) the 13-lag
    minimum-state RFA misses the GAFs by 13.5 % rms (52 % worst entry) and the state space
    flutters at 230.5 m/s; fitted up to k = 1 (``aero --k``; the flutter point is at k = 0.10)
    it fits to 0.078 % rms (0.26 % worst) and flutters at 393.91 m/s, 3.1778 Hz: -0.11 % and
    0.00 % from the p-k's 394.35 m/s, 3.1778 Hz (target 2 %). alpha = 1e-3 1/s (zeta 9e-6 at
    8.7 Hz; it moves the p-k by +0.02 %) keeps the in-plane mode, which the flat boxes do not
    load, off the criterion's round-off zero damping. ~60 s."""
    deck = _bah_plane_both_subcases(tmp_path)
    _torchrom(tmp_path, "identify", deck.name, "--linear", "8", "--dual", "0", "--out", "rom.npz")
    _torchrom(tmp_path, "aero", deck.name, "--mach", "0.2", "--modes", "8", "--kernel",
              "parabolic", "--k", *RFA_K, "--out", "aero.npz", "--json", "aero.json")
    fit = json.loads((tmp_path / "aero.json").read_text())["fit_error"]
    assert fit["rms_relative"] < 0.01  # measured 7.8e-4 (13.5 % over the whole list to k = 10)
    _torchrom(tmp_path, "flutter", "rom.npz", "aero.npz", "--density", "1.225", "--method",
              "both", "--alpha", "1e-3", "--gamma", "0", "--json", "f.json")
    pk, ss = json.loads((tmp_path / "f.json").read_text())["flutter"]
    assert (pk["method"], ss["method"]) == ("p-k", "state-space")
    print(f"BAH p-k {pk['velocity']:.2f} m/s {pk['frequency_hz']:.4f} Hz, state space "
          f"{ss['velocity']:.2f} m/s {ss['frequency_hz']:.4f} Hz")
    assert pk["velocity"] == pytest.approx(DECK_SPEED, rel=0.02)
    assert ss["velocity"] == pytest.approx(pk["velocity"], rel=0.02)
    assert ss["frequency_hz"] == pytest.approx(pk["frequency_hz"], rel=0.02)
    assert F06_BRACKET[0] < ss["velocity"] < F06_BRACKET[1]
