"""SOL 145 flutter of the Pazy wing with skin (AePW-3 GFEM + DLM) against MSC Nastran's f06.

Decks: tests/decks/aepw3_pazy_skin_flutter_tipmass1 (the folder Riso & Cesnik name TipMass1,
whose CONM2 is commented out: 0.3566 kg, the workbook's "Without tip mass") and _tipmass0 (the
10 g CONM2 aft of the trailing edge active: 0.3666 kg, "With tip mass"); see their SOURCE.md.
Measured with `torchrom flutter DECK --compare DECK/sol145.f06` (%, ours - Nastran):

=========  ====================  ======================  =====================
deck       crossing              torchrom                MSC Nastran 2017.1
=========  ====================  ======================  =====================
tipmass1   mode 3 hump           67.322 m/s, 34.750 Hz   67.30, 34.723 (+0.03, +0.08)
tipmass1   mode 2 sustained      95.534 m/s, 17.234 Hz   95.45, 17.208 (+0.09, +0.15)
tipmass1   mode 1 divergence     101.58 m/s, 0 Hz        100.97 (+0.60)
tipmass0   mode 2 sustained      86.586 m/s, 16.192 Hz   86.519, 16.161 (+0.08, +0.19)
tipmass0   mode 1 divergence     101.58 m/s, 0 Hz        100.97 (+0.60)
=========  ====================  ======================  =====================

The full runs (two to three minutes each on two busy cores: 10 modes of 39,564 DOF, DLM on
1296 boxes mirrored at 104 reduced frequencies, 121 speeds) are marked slow; the unmarked test
checks the modes and one speed's p-k roots (the parts a crossing is made of).
"""

from __future__ import annotations

import re
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from torchrom.f06 import read_flutter_summary, read_real_eigenvalues

DECKS = Path(__file__).parent / "decks"
TIPMASS1 = DECKS / "aepw3_pazy_skin_flutter_tipmass1"
TIPMASS0 = DECKS / "aepw3_pazy_skin_flutter_tipmass0"

# Modes 6 and 8 are the rib/spar torsion modes set by the CQUAD4 drilling stiffness at the
# rib/spar T-joints, as in the no-skin Pazy deck (SOURCE.md there): measured -1.76 % and -9.27 %
# (tipmass1), -1.62 % and -9.38 % (tipmass0); the others within 0.92 %. They lie above 145 Hz
# and are not part of any crossing below 121 m/s.
MODE_TOL_PCT = {6: 2.5, 8: 10.0}


def _modes_vs_f06(freqs: np.ndarray, f06: Path) -> np.ndarray:
    """(ours - Nastran) / Nastran in % for the modes the flutter analysis used (the f06's
    table of the actual modes used: LMODES 10 of the 20 EIGRL modes)."""
    ref = read_real_eigenvalues(f06)[-1].cycles
    assert len(ref) == len(freqs) == 10
    return 100 * (freqs - ref) / ref


def test_pazy_skin_modes_and_one_speed_pk_roots_match_f06():
    """Reduced check (tipmass1): the 10 modes against the f06's, then the p-k roots at 67 m/s
    (the hump's onset) with the MKAERO k up to 0.2 — the deck's own table there (0.01, 0.05 ..
    0.2; IMETH L interpolates linearly between neighbours, so the roots with k < 0.2 are those of
    the full table). Modes 1-3 (k = 0.017, 0.124, 0.161): frequency within 1 % (measured +0.77,
    +0.08, +0.09 %: mode 1 at 3.635 Hz against 3.608 is the most damped root, g = -1.18),
    damping within 0.03 (measured g -1.1820 vs -1.2038, -0.2382 vs -0.2397, -0.00119 vs
    -0.00113); mode 3's near-zero g is the hump's onset and must have the f06's sign."""
    from torchrom.aero.nastran_flutter import load_deck, run_deck
    from torchrom.fe import read_bdf

    deck = load_deck(TIPMASS1 / "sol145.dat")
    assert (deck.n_eigen, deck.lmodes) == (20, 10)
    fe = read_bdf(TIPMASS1 / "sol145.dat")
    deck.cases = [replace(deck.cases[0], values=np.array([67.0]))]
    deck.mkaero = [(m, k) for m, k in deck.mkaero if k <= 0.2]
    res = run_deck(deck, fe=fe, log=lambda *_: None)
    diff = _modes_vs_f06(res.frequencies_hz, TIPMASS1 / "sol145.f06")
    print("pazy skin modes, diff %:", np.round(diff, 3).tolist())
    for n, d in enumerate(diff, start=1):
        assert abs(d) <= MODE_TOL_PCT.get(n, 1.0), (n, d)
    sw = res.results[0].sweep
    ours_f = np.abs(sw.eigenvalues[0].imag[:3]) / (2 * np.pi)
    ours_g = sw.damping[0][:3]
    tables = read_flutter_summary(TIPMASS1 / "sol145.f06")
    at = [t for t in tables if t.point in (1, 2, 3)]
    their_f = np.array([t.frequency[np.flatnonzero(t.velocity == 67.0)[0]] for t in at])
    their_g = np.array([t.damping[np.flatnonzero(t.velocity == 67.0)[0]] for t in at])
    print("67 m/s f:", ours_f, their_f, "g:", ours_g, their_g)
    np.testing.assert_allclose(ours_f, their_f, rtol=0.01)
    np.testing.assert_allclose(ours_g, their_g, rtol=0, atol=0.03)
    assert np.sign(ours_g[2]) == np.sign(their_g[2]) == -1


# deck folder, then each crossing (mode, kind, V Nastran, f Nastran) of its f06
FULL = [
    (TIPMASS1, [(3, "hump", 67.30, 34.723), (2, "sustained", 95.45, 17.208),
                (1, "sustained", 100.97, 0.0)]),
    (TIPMASS0, [(2, "sustained", 86.519, 16.161), (1, "sustained", 100.97, 0.0)]),
]


@pytest.mark.slow
@pytest.mark.parametrize("folder, crossings", FULL, ids=["tipmass1", "tipmass0"])
def test_pazy_skin_flutter_matches_f06(folder, crossings):
    """The whole SOL 145 deck through `torchrom flutter --compare`: every crossing of the f06
    paired with one of ours of the same kind, speed and frequency within 2 % (the issue's
    target; measured at most +0.60 % in speed, the divergence, and +0.19 % in frequency), and
    no crossing of ours without Nastran's."""
    from torchrom.aero.nastran_flutter import compare_f06, run_deck

    res = run_deck(folder / "sol145.dat", log=lambda *_: None)
    _, records = compare_f06(res, folder / "sol145.f06")
    print(records)
    assert all(r["velocity"] is not None and r["nastran_velocity"] is not None
               for r in records)
    got = {(r["mode"], r["kind"]): r for r in records}
    assert len(got) == len(records) == len(crossings)
    for mode, kind, v, f in crossings:
        r = got[(mode, kind)]
        assert r["nastran_kind"] == kind
        assert r["nastran_velocity"] == pytest.approx(v, rel=1e-4)
        assert abs(r["velocity_diff_pct"]) <= 2.0
        if f:
            assert abs(r["frequency_diff_pct"]) <= 2.0
        else:
            assert r["frequency_hz"] == 0.0 and r["nastran_frequency_hz"] == 0.0


#: the ROM chain's reduced frequencies: the deck's MKAERO values up to k = 1 (its flutter points
#: lie at k = 0.12-0.16); fitted over the whole list to k = 50 the RFA, and p-k below 1 m/s
#: (k beyond 50), give spurious roots
ROM_K = ["0.01", "0.05", "0.1", "0.15", "0.2", "0.3", "0.5", "0.75", "1.0"]


@pytest.mark.slow
@pytest.mark.parametrize("folder, first", [(TIPMASS1, (67.30, 34.723)),
                                           (TIPMASS0, (86.519, 16.161))],
                         ids=["tipmass1", "tipmass0"])
def test_pazy_skin_rom_flutter_matches_f06(folder, first, tmp_path):
    """The ROM chain on the SOL 145 deck, through the real CLI: `identify` (the deck's 10
    modes; tangent stiffness, whose linear part is all flutter uses), `aero` on the deck's
    boxes at Mach 0.001, `flutter` at 1.225 kg/m³ by p-k and by the state space; the first
    crossing within 2 % of the f06's in speed and frequency (the issue's target). Measured:
    tipmass1 68.18 m/s, 34.60 Hz (+1.31 %, −0.35 %); tipmass0 see the guide. About 5 minutes
    a deck."""
    import json

    deck = folder / "sol145.dat"

    def cli(*argv):
        run = subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv), "-q"],
                             capture_output=True, text=True, cwd=tmp_path)
        assert run.returncode == 0, run.stderr

    cli("identify", deck, "--linear", "10", "--dual", "0", "--out", "rom.npz")
    cli("aero", deck, "--mach", "0.001", "--modes", "10", "--k", *ROM_K, "--out", "aero.npz")
    cli("flutter", "rom.npz", "aero.npz", "--density", "1.225", "--method", "both",
        "--alpha", "0", "--gamma", "0", "--json", "flutter.json")
    rows = json.loads((tmp_path / "flutter.json").read_text())["flutter"]
    assert {r["method"] for r in rows} == {"p-k", "state-space"}
    v, f = first
    for r in rows:
        assert r["velocity"] == pytest.approx(v, rel=0.02), r
        assert r["frequency_hz"] == pytest.approx(f, rel=0.02), r


@pytest.mark.slow
def test_pazy_skin_divergence_offset_is_the_lowest_mkaero_k():
    """Why the divergence (a real root, k = 0) is +0.60 % off while the oscillatory crossings
    are within 0.1 %: it is set by the steady aerodynamic stiffness, and the deck's MKAERO
    table starts at k = 0.01. Below its lowest k torchrom holds Q_R(k_min)
    (torchrom.aero.flutter, quasi-steady), which gives 101.58 m/s. The static divergence
    det(K + q Q_R) = 0 of the same 10 modes (tipmass1, f06: 100.97 m/s), measured: with the
    DLM's steady Q (k = 0) 101.067 (+0.10 %), with Q_R(0.01) 101.576 (+0.60 %: the p-k
    crossing's speed, to 1e-4), with Q_R extrapolated linearly from 0.01 and 0.05 to 0
    99.138 (-1.81 %). Nastran's number lies nearest the steady one; which value its PK uses
    below the lowest tabulated k is not known here (the deck gives none at k = 0)."""
    import scipy.linalg

    from torchrom.aero.dlm import compute_gaf
    from torchrom.aero.nastran_flutter import NASTRAN_KERNEL, _modes, load_deck
    from torchrom.fe import read_bdf

    deck = load_deck(TIPMASS1 / "sol145.dat")
    fe = read_bdf(TIPMASS1 / "sol145.dat")
    f, shapes = _modes(deck, fe, [])
    disp = np.asarray(fe.expand(shapes)).reshape(shapes.shape[1], -1, 6)
    gaf = compute_gaf(deck.aero_panels, deck.box_motion(fe.grid_ids, disp), 0.001,
                      [0.0, 0.01, 0.05], deck.reference.semichord, NASTRAN_KERNEL)
    K = np.diag((2 * np.pi * f) ** 2)
    rho = deck.cases[0].densities[0]

    def divergence(q_r):
        lam = scipy.linalg.eigvals(K, -q_r)
        real = lam.real[(np.abs(lam.imag) <= 1e-9 * np.abs(lam).max()) & (lam.real > 0)]
        return float(np.sqrt(2 * real.min() / rho))

    steady = divergence(gaf.Q[0].real)
    held = divergence(gaf.Q[1].real)
    print("divergence: steady", steady, "Q_R(0.01)", held)
    assert steady == pytest.approx(100.97, rel=0.002)
    assert held == pytest.approx(101.58, rel=2e-4)


STRIP_DECK = """SOL 145
CEND
METHOD = 1
FMETHOD = 2
BEGIN BULK
GRID,1,,0.,0.,0.
GRID,2,,0.,1.,0.
EIGRL,1,,,2
AERO,,1.0,0.1,1.225,1
PAERO4,9999,0,0,0,0
CAERO4,1001,9999,,4
,0.,0.,0.,0.1,0.,1.,0.,0.1
SPLINE2,1000,1001,1001,1004,100,0.,1.
SET1,100,1,2
FLUTTER,2,PK,21,22,23
FLFACT,21,1.
FLFACT,22,0.001
FLFACT,23,10.,20.
MKAERO1,0.001
,0.1,0.5
ENDDATA
"""


def test_strip_theory_deck_refused_in_one_line(tmp_path):
    """A CAERO4/PAERO4 (strip theory) deck, as the Pazy 2D-aero folders use: one line naming
    the card and what to use instead, non-zero exit, no traceback."""
    deck = tmp_path / "strip.bdf"
    deck.write_text(STRIP_DECK)
    run = subprocess.run([sys.executable, "-m", "torchrom", "flutter", str(deck)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode != 0
    err = run.stderr.strip().splitlines()
    assert len(err) == 1 and "Traceback" not in run.stderr, run.stderr
    assert "CAERO4 (strip theory aerodynamics) is not supported" in err[0]
    assert "CAERO1" in err[0]


@pytest.mark.slow
def test_pazy_skin_lco_sweep_is_certified_and_matches_time_marching(tmp_path):
    """Deck → ROM → LCO vs speed on the skinned wing (issue 35), through the real CLI and the
    shipped configuration (configs/pazy_skin_lco.toml): `identify --stiffness condensed
    --nonlinear-modes 3 --linear-skin 10011` (the cubic terms condensed on the wing without
    its foil skin), `aero`, `sweep` by harmonic balance at 70-85 m/s. Every row an LCO,
    certified and stable, its tip amplitude growing with speed at the flutter mode's 34-36 Hz;
    and the same ROM marched in time (Newmark, 0.2 ms: an independent method, certified by
    shooting) at 80 m/s lands on the same orbit within 0.3 % (measured 0.08 %; the marching's
    own orbit_error + dt_error is 0.1 %). About 10 minutes (609 s on a loaded machine)."""
    import pandas as pd

    deck = TIPMASS1 / "sol145.dat"
    config = Path(__file__).parents[1] / "configs/pazy_skin_lco.toml"

    def cli(*argv):
        run = subprocess.run([sys.executable, "-m", "torchrom", *map(str, argv), "-q"],
                             capture_output=True, text=True, cwd=tmp_path)
        assert run.returncode == 0, run.stderr

    cli("identify", deck, "--linear", "10", "--stiffness", "condensed", "--nonlinear-modes", "3",
        "--linear-skin", "10011", "--out", "rom.npz")
    cli("aero", deck, "--mach", "0.001", "--modes", "10", "--k", *ROM_K, "--out", "aero.npz")
    text = config.read_text()
    (tmp_path / "lco.toml").write_text(text)
    cli("sweep", "lco.toml", "--out", "hb")
    hb = pd.read_parquet(tmp_path / "hb/results.parquet").sort_values("speed")
    assert len(hb) == 7 and (hb["status"] == "lco").all()
    assert hb["certified"].all() and hb["stable"].all()
    assert np.all(np.diff(hb["amplitude"].to_numpy()) > 0)
    assert hb["frequency_hz"].between(34.0, 36.0).all()
    marching = text.replace('method = "hb"', 'method = "newmark"').replace(
        "speed = { start = 70.0, stop = 85.0, num = 7 }", "speed = 80.0")
    marching += "\n[integrator]\ndt = 2e-4\nt_end = 10.0\niterations = 2\nrefresh_every = 1\n"
    # the marching takes no harmonic-balance settings: the [hb] table (two lines) goes
    marching = re.sub(r"\[hb\]\n[^\n]*\n", "", marching)
    (tmp_path / "march.toml").write_text(marching)
    cli("sweep", "march.toml", "--out", "nm")
    nm = pd.read_parquet(tmp_path / "nm/results.parquet")
    assert nm["status"].tolist() == ["lco"] and bool(nm["certified"].iloc[0])
    ref = float(hb.loc[hb["speed"] == 80.0, "amplitude"].iloc[0])
    assert float(nm["amplitude"].iloc[0]) == pytest.approx(ref, rel=3e-3)
