"""torchrom.fe.damping_cards: a deck's structural damping (PARAM G/W3, MAT1 GE/W4, TABDMP1 by
SDAMPING) and ``--damping-ratio`` reach the ROM (issue 46 item 3).

Each card on a three-CBAR cantilever with a tip mass, through ``torchrom identify`` (in-process;
3 linear modes, about 2 s): the ROM file's record (metadata ``structural_damping``) against the
card's closed form, and the ROM's own damping, α M + γ D̄1, measured as ζ = −Re s/|s| of the
state-space roots of its linear part, against ζ(ω) = α/(2ω) + γω/2. The material GE of two
materials is checked against a second method: φᵀ K_m φ = d(ω²)/dE_m·E_m by central differences
of two modal analyses (Hellmann–Feynman; step 1e-4, truncation ~1e-8). Then the record is what
``flutter ROM.npz AERO.npz`` and a sweep's baseline use, and bad input is refused in one line
by the real command line (a child process of :mod:`tests.cli_forkserver`).
"""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from torchrom.cli import main
from torchrom.fe import read_bdf
from torchrom.rom import NonlinearROM
from torchrom.rom.rayleigh import RayleighDamping, fit_rayleigh

from .cli_forkserver import ForkServer

DECK = """SOL 103
CEND
SPC = 1
METHOD = 10
{case}BEGIN BULK
GRID    1               0.0     0.0     0.0
GRID    2               1.0     0.0     0.0
GRID    3               2.0     0.0     0.0
GRID    4               3.0     0.0     0.0
CBAR    1       1       1       2       0.0     0.0     1.0
CBAR    2       {pid}       2       3       0.0     0.0     1.0
CBAR    3       {pid}       3       4       0.0     0.0     1.0
PBAR    1       1       0.01    1.-5    2.-5    3.-5
PBAR    2       2       0.01    1.-5    2.-5    3.-5
MAT1,1,{e1},,0.3,2700.,,,{ge1}
MAT1,2,{e2},,0.3,2700.,,,{ge2}
CONM2   10      4               1.0
SPC1    1       123456  1
EIGRL   10                      4
{bulk}ENDDATA
"""
E = 7.0e10


def _deck(path, bulk="", case="", ge1="", ge2="", pid=1, e1=E, e2=E):
    path.write_text(DECK.format(bulk=bulk, case=case, ge1=ge1, ge2=ge2, pid=pid,
                                e1=f"{e1:.10e}", e2=f"{e2:.10e}"))
    return path


def _identify(tmp_path, deck, *extra):
    rom = tmp_path / "rom.npz"
    assert main(["identify", str(deck), "--linear", "3", "--dual", "0", "--out", str(rom),
                 "-q", *extra]) == 0
    return NonlinearROM.load(rom)


def _record(rom) -> RayleighDamping:
    rec = RayleighDamping.from_metadata(rom.metadata)
    assert rec is not None
    return rec


def _rom_zeta(rom, rec) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies Hz, ζ) of the ROM's damped linear part, from its state-space roots."""
    n = rom.n
    M, K, D = (np.asarray(getattr(rom, k), dtype=float) for k in ("M", "K1", "D1"))
    C = rec.alpha * M + rec.gamma * D
    Minv = np.linalg.inv(M)
    s = np.linalg.eigvals(np.block([[np.zeros((n, n)), np.eye(n)], [-Minv @ K, -Minv @ C]]))
    s = s[s.imag > 0]
    s = s[np.argsort(np.abs(s))]
    return np.abs(s) / (2 * np.pi), -s.real / np.abs(s)


def _check_rom_damping(rom, rec, zeta_closed_form, rtol):
    """The ROM's record and its matrices give ``zeta_closed_form`` at its modes."""
    f = np.asarray(rom.frequencies_hz, dtype=float)
    np.testing.assert_allclose(rec.frequencies_hz, f, rtol=1e-12)
    f_roots, z_roots = _rom_zeta(rom, rec)
    # the damped roots' |s| is the undamped ω (ζ² changes Im s, not |s|)
    np.testing.assert_allclose(f_roots, f, rtol=1e-9)
    np.testing.assert_allclose(z_roots, rec.zeta(f), rtol=1e-9)  # matrices = closed form
    np.testing.assert_allclose(rec.zeta(f), zeta_closed_form(f), rtol=rtol)


def test_param_g_with_w3_is_gamma_g_over_w3(tmp_path):
    """PARAM G 0.04, W3 50 rad/s: viscous (G/W3) K, so γ = G/W3 = 8e-4 s, α = 0, and
    ζ = G ω/(2 W3) at every mode (rounding: 1e-12)."""
    deck = _deck(tmp_path / "g.bdf", bulk="PARAM,G,0.04\nPARAM,W3,50.\n")
    rom = _identify(tmp_path, deck, "--json", str(tmp_path / "id.json"))
    rec = _record(rom)
    assert rec.source == "deck" and "PARAM G 0.04 at W3 = 50 rad/s" in rec.description
    assert json.loads((tmp_path / "id.json").read_text())["structural_damping"] == \
        rom.metadata["structural_damping"]
    assert rec.alpha == 0.0 and rec.gamma == pytest.approx(0.04 / 50.0, rel=1e-12)
    _check_rom_damping(rom, rec, lambda f: 0.04 * 2 * np.pi * f / (2 * 50.0), 1e-12)


def test_mat1_ge_with_w4_one_material_is_gamma_ge_over_w4(tmp_path):
    """MAT1 GE 0.02 on the one material of every element, W4 80 rad/s: Σ (GE/W4) K_e = (GE/W4)
    K, so γ = GE/W4 = 2.5e-4 s (K(1 + GE) − K: cancellation ~1e-14/GE, tolerance 1e-9)."""
    deck = _deck(tmp_path / "ge.bdf", bulk="PARAM,W4,80.\n", ge1="0.02", ge2="0.02")
    rom = _identify(tmp_path, deck)
    rec = _record(rom)
    assert "MAT1 1 GE 0.02" in rec.description and "W4 = 80 rad/s" in rec.description
    assert rec.alpha == 0.0 and rec.gamma == pytest.approx(0.02 / 80.0, rel=1e-9)
    _check_rom_damping(rom, rec, lambda f: 0.02 * 2 * np.pi * f / (2 * 80.0), 1e-9)


def test_mat1_ge_of_two_materials_by_a_second_method(tmp_path):
    """GE 0.05 on the root bar's material, 0.01 on the others', W4 60: each mode's
    ζ_i = Σ_m GE_m φ_iᵀ K_m φ_i / (2 ω_i W4), with φᵀ K_m φ from d(ω²)/dE_m (central
    differences, relative step 1e-4: 1e-6); the fitted γ is the weighted least squares of
    those ratios (rom.rayleigh, 1e-9)."""
    ge = {1: 0.05, 2: 0.01}
    deck = _deck(tmp_path / "ge2.bdf", bulk="PARAM,W4,60.\n", ge1="0.05", ge2="0.01", pid=2)
    rom = _identify(tmp_path, deck)
    rec = _record(rom)
    f = np.asarray(rom.frequencies_hz, dtype=float)
    quad = np.zeros_like(f)  # Σ_m GE_m φᵀ K_m φ
    h = 1e-4
    for mid, g in ge.items():
        w2 = []
        for sign in (1, -1):
            scaled = {f"e{mid}": E * (1 + sign * h)}
            fe = read_bdf(_deck(tmp_path / f"e{mid}{sign}.bdf", pid=2, **scaled))
            w2.append((2 * np.pi * fe.modes(3).frequencies_hz) ** 2)
        quad += g * (w2[0] - w2[1]) / (2 * h)  # E_m dω²/dE_m = φᵀ K_m φ
    zeta = quad / (2 * 2 * np.pi * f * 60.0)
    np.testing.assert_allclose(rec.zeta_target, zeta, rtol=1e-6)
    assert rec.alpha == 0.0
    assert rec.gamma == pytest.approx(fit_rayleigh(f, zeta, mass_proportional=False)[1],
                                      rel=1e-6)
    _check_rom_damping(rom, rec, lambda x: rec.zeta(x), 1e-12)


@pytest.mark.parametrize("kind, half", [("CRIT", 1.0), ("G", 0.5)])
def test_tabdmp1_selected_by_sdamping(tmp_path, kind, half):
    """TABDMP1 (0 Hz: 0.01, 100 Hz: 0.03) by case control SDAMPING: each mode's ζ is the
    table at its frequency (CRIT: the value, G: g/2; linear between the points: closed form,
    1e-12), and α, γ the relative least squares of those ratios (numpy lstsq of the same
    weighted system, both positive: 1e-9)."""
    deck = _deck(tmp_path / "tab.bdf", case="SDAMPING = 7\n",
                 bulk=f"TABDMP1,7,{kind}\n,0.,0.01,100.,0.03,ENDT\n")
    rom = _identify(tmp_path, deck)
    rec = _record(rom)
    assert f"TABDMP1 7 ({kind}) by SDAMPING" in rec.description
    f = np.asarray(rom.frequencies_hz, dtype=float)
    zeta = half * (0.01 + 0.02 * f / 100.0)
    np.testing.assert_allclose(rec.zeta_target, zeta, rtol=1e-12)
    w = 2 * np.pi * f
    (a, g), *_ = np.linalg.lstsq(np.column_stack([1 / (2 * w), w / 2]) / zeta[:, None],
                                 np.ones_like(f), rcond=None)
    assert a > 0 and g > 0
    assert rec.alpha == pytest.approx(a, rel=1e-9) and rec.gamma == pytest.approx(g, rel=1e-9)
    _check_rom_damping(rom, rec, lambda x: rec.zeta(x), 1e-12)


def test_damping_ratio_single_and_two_frequencies(tmp_path):
    """--damping-ratio 0.02: α, γ of the relative least squares over the ROM's modes (numpy
    lstsq: 1e-9), and the option replaces the deck's cards; --damping-ratio 0.01@2 0.03@20:
    ζ(2 Hz) = 0.01 and ζ(20 Hz) = 0.03 exactly (1e-12)."""
    deck = _deck(tmp_path / "g.bdf", bulk="PARAM,G,0.04\nPARAM,W3,50.\n")
    rom = _identify(tmp_path, deck, "--damping-ratio", "0.02")
    rec = _record(rom)
    assert rec.source == "damping-ratio" and "PARAM G" not in rec.description
    f = np.asarray(rom.frequencies_hz, dtype=float)
    w = 2 * np.pi * f
    (a, g), *_ = np.linalg.lstsq(np.column_stack([1 / (2 * w), w / 2]) / 0.02,
                                 np.ones_like(f), rcond=None)
    assert rec.alpha == pytest.approx(a, rel=1e-9) and rec.gamma == pytest.approx(g, rel=1e-9)
    _check_rom_damping(rom, rec, lambda x: rec.zeta(x), 1e-12)

    rom = _identify(tmp_path, deck, "--damping-ratio", "0.01@2", "0.03@20", "--force")
    rec = _record(rom)
    np.testing.assert_allclose(rec.zeta([2.0, 20.0]), [0.01, 0.03], rtol=1e-12)
    _check_rom_damping(rom, rec, lambda x: rec.zeta(x), 1e-12)


def test_a_deck_without_damping_gets_none_and_says_so(tmp_path, capsys):
    deck = _deck(tmp_path / "plain.bdf", bulk="TABDMP1,9,CRIT\n,0.,0.01,100.,0.03,ENDT\n")
    rom = _identify(tmp_path, deck)
    rec = _record(rom)
    assert (rec.alpha, rec.gamma, rec.source) == (0.0, 0.0, "none")
    out = capsys.readouterr().out
    assert "structural damping: none" in out and "TABDMP1 9 selected by no SDAMPING" in out


def test_the_goland_deck_keeps_the_papers_damping_unless_it_states_its_own():
    """The heavy Goland deck (by its TITLE) without damping cards: the paper's Eq. 46 values
    (data/paper_reference.toml); with PARAM G/W3 added, the cards (γ = G/W3)."""
    from torchrom.fe import goland
    from torchrom.fe.damping_cards import read_deck_damping, rom_damping
    from torchrom.reference import paper_reference

    fe = goland()
    m = fe.modes(3)
    rec = rom_damping(fe, read_deck_damping(fe.bdf, "goland.bdf"), m.shapes,
                      m.frequencies_hz, free=False)
    ref = paper_reference()
    assert (rec.alpha, rec.gamma, rec.source) == (ref.alpha0_per_s, ref.beta0_s, "goland")
    fe.bdf.add_param("G", [0.03])
    fe.bdf.add_param("W3", [60.0])
    rec = rom_damping(fe, read_deck_damping(fe.bdf, "goland.bdf"), m.shapes,
                      m.frequencies_hz, free=False)
    assert rec.source == "deck" and rec.gamma == pytest.approx(0.03 / 60.0, rel=1e-12)


@pytest.fixture(scope="module")
def tab_files(tmp_path_factory):
    """The TABDMP1 deck's ROM and aerodynamics on its first two modes (Theodorsen's GAFs of
    tests/aeroelastic_fixtures: the flutter numbers are not the point, the damping is)."""
    from tests.aeroelastic_fixtures import section_aero

    d = tmp_path_factory.mktemp("tab")
    deck = _deck(d / "tab.bdf", case="SDAMPING = 7\n",
                 bulk="TABDMP1,7,CRIT\n,0.,0.01,100.,0.03,ENDT\n")
    rom = _identify(d, deck)
    section_aero(rom).save(d / "aero.npz")
    return d, rom


def test_the_record_is_what_flutter_and_sweeps_use(tab_files, tmp_path):
    """flutter ROM.npz AERO.npz uses the record (JSON alpha, gamma, damping); --gamma replaces
    γ only; --damping-ratio maps onto the ROM's modes as identify's did; a sweep's baseline
    without [aeroelastic] baseline_* is the record, with a line saying so."""
    from torchrom.study.models import ModelSpec, build_model

    d, rom = tab_files
    rec = _record(rom)
    base = ["flutter", str(d / "rom.npz"), str(d / "aero.npz"), "--density", "0.002",
            "--method", "pk", "--units", "ft-slug-s"]
    runs = {"record": [], "gamma": ["--gamma", "0"], "ratio": ["--damping-ratio", "0.02"]}
    got = {}
    for name, extra in runs.items():
        out = tmp_path / f"{name}.json"
        assert main([*base, *extra, "--json", str(out)]) == 0
        got[name] = json.loads(out.read_text())
    assert (got["record"]["alpha"], got["record"]["gamma"]) == (rec.alpha, rec.gamma)
    assert got["record"]["damping"]["source"] == "deck"
    assert (got["gamma"]["alpha"], got["gamma"]["gamma"]) == (rec.alpha, 0.0)
    assert got["gamma"]["damping"]["source"] == "options"
    f = np.asarray(rom.frequencies_hz, dtype=float)
    a, g = fit_rayleigh(f, np.full(f.shape, 0.02))
    assert got["ratio"]["alpha"] == pytest.approx(a, rel=1e-12)
    assert got["ratio"]["gamma"] == pytest.approx(g, rel=1e-12)

    model = build_model(ModelSpec(source=d / "sweep.toml", rom=d / "rom.npz",
                                  aero=d / "aero.npz", units="ft-slug-s"))
    assert (model.baseline_alpha, model.baseline_gamma) == (rec.alpha, rec.gamma)
    assert "rom.npz's structural damping: tab.bdf: TABDMP1 7" in model.damping_note
    stated = build_model(ModelSpec(source=d / "sweep.toml", rom=d / "rom.npz",
                                   aero=d / "aero.npz", units="ft-slug-s",
                                   aeroelastic={"baseline_alpha": 0.3, "baseline_gamma": 0.0}))
    assert (stated.baseline_alpha, stated.baseline_gamma, stated.damping_note) == (0.3, 0.0,
                                                                                   None)


@pytest.fixture(scope="module")
def server(tmp_path_factory):
    d = tmp_path_factory.mktemp("damping-cli")
    srv = ForkServer({**os.environ, "TORCHROM_CACHE": str(d / "cache")})
    yield srv
    srv.close()


#: bad input -> (deck bulk, case control, argv after the deck, words of the one-line refusal)
REFUSALS = {
    "negative ratio": ("", "", ["--damping-ratio", "-0.02"], ("--damping-ratio", "0 <= ZETA")),
    "ratio of 1": ("", "", ["--damping-ratio", "1"], ("--damping-ratio", "0 <= ZETA < 1")),
    "Z@F without F": ("", "", ["--damping-ratio", "0.02@"], ("--damping-ratio", "ZETA@FREQ_HZ")),
    "Z@F zero F": ("", "", ["--damping-ratio", "0.02@0"], ("--damping-ratio", "frequency > 0")),
    "one Z@F": ("", "", ["--damping-ratio", "0.02@5"], ("--damping-ratio 0.02@5", "ZETA1@F1")),
    "Z@F same F": ("", "", ["--damping-ratio", "0.02@5", "0.03@5"], ("must differ",)),
    "Z@F no curve": ("", "", ["--damping-ratio", "0.05@1", "0.001@10"],
                     ("no Rayleigh curve", "γ < 0")),
    "G without W3": ("PARAM,G,0.04\n", "", [], ("g.bdf: PARAM G 0.04 needs PARAM W3",
                                                "add PARAM W3", "--damping-ratio")),
    "G with W3 0": ("PARAM,G,0.04\nPARAM,W3,0.\n", "", [], ("PARAM W3 > 0", "got 0")),
    "negative G": ("PARAM,G,-0.04\nPARAM,W3,10.\n", "", [], ("PARAM G: expected",)),
    "GE without W4": ("", "", [], ("MAT1 1 GE 0.02 needs PARAM W4",)),
    "SDAMPING without table": ("", "SDAMPING = 5\n", [], ("SDAMP = 5", "TABDMP1 5 not found")),
    "SDAMPING tables differ": ("TABDMP1,5\n,0.,0.02,ENDT\nTABDMP1,6\n,0.,0.02,ENDT\n",
                               "SUBCASE 1\nSDAMPING = 5\nSUBCASE 2\nSDAMPING = 6\n", [],
                               ("SDAMPING selects different tables", "--damping-ratio")),
}


@pytest.mark.parametrize("name", sorted(REFUSALS))
def test_bad_damping_input_is_refused_in_one_line(name, server, tmp_path):
    bulk, case, argv, words = REFUSALS[name]
    ge = "0.02" if name == "GE without W4" else ""
    deck = _deck(tmp_path / "g.bdf", bulk=bulk, case=case, ge1=ge)
    rom = tmp_path / "rom.npz"
    rc, out, err = server.run(["identify", deck, "--linear", "2", "--dual", "0", "--out", rom,
                               *argv], tmp_path)
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert "Traceback" not in err and rc == 2, (rc, err)
    assert len(lines) == 1 and lines[0].startswith("torchrom identify: error: "), err
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not rom.exists()


def test_flutter_refuses_damping_ratio_beside_alpha_and_on_a_deck(server, tab_files, tmp_path):
    d, _ = tab_files
    cases = [(["flutter", d / "rom.npz", d / "aero.npz", "--damping-ratio", "0.02", "--alpha",
               "0"], "--damping-ratio: not with --alpha"),
             (["flutter", d / "tab.bdf", "--damping-ratio", "0.02"],
              "--damping-ratio: for ROM.npz AERO.npz or goland")]
    for argv, words in cases:
        rc, out, err = server.run(argv, tmp_path)
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert rc == 2 and len(lines) == 1 and words in lines[0], err
