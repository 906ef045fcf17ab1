"""The generated shell/beam wing deck (tests/big_wing_deck.py), small: it reads, its cards mean
what the writer says, and SOL 145 runs end to end with the torch DLM (checked against PanelAero
on the deck's own boxes and modes)."""

import numpy as np
import pytest

from tests.big_wing_deck import card, k_values, write_deck
from torchrom.aero.dlm import compute_gaf
from torchrom.aero.nastran_flutter import load_deck, run_deck
from torchrom.fe import read_bdf

SMALL = dict(n_chord=5, n_span=11, n_box_chord=4, n_box_span=6, n_k=12, n_modes=5, rib_every=5)


@pytest.fixture(scope="module")
def small_deck(tmp_path_factory):
    path = tmp_path_factory.mktemp("bigwing") / "wing.bdf"
    return path, write_deck(path, **SMALL)


def test_card_writer_fields():
    # 8-character fields; 7e10 in Nastran's short exponent form
    assert card("GRID", 1, 0, 0.25, -1.0e-4, 12345.678, 7.0e10) == (
        "GRID    1       0       0.25    -0.0001 12345.687.+10\n")
    line = card("SET1", 1, *range(1, 11))
    assert line.splitlines()[1] == " " * 8 + "8       9       10"


def test_small_deck_reads_as_written(small_deck):
    path, info = small_deck
    fe = read_bdf(path)
    assert info["grids"] == 2 * 5 * 11 == len(fe.grid_ids)
    # the root grids are clamped: 6 DOFs less per root grid
    assert fe.n_dof == 6 * (info["grids"] - 2 * 5)
    deck = load_deck(path)
    assert deck.panels.n == info["boxes"] == 24
    assert deck.aero_panels.n == 48  # AERO SYMXZ = 1: mirrored
    assert sorted(k for _, k in deck.mkaero) == pytest.approx(np.sort(k_values(12)))
    assert [sp.kind for sp in deck.splines] == ["SPLINE1", "SPLINE2"]
    covered = np.concatenate([sp.box_index for sp in deck.splines])
    assert sorted(covered.tolist()) == list(range(24))


def test_small_deck_flutter_end_to_end(small_deck):
    path, _ = small_deck
    fe = read_bdf(path)
    res = run_deck(path, fe=fe, log=lambda *_: None)
    assert len(res.frequencies_hz) == SMALL["n_modes"]
    assert np.all(np.diff(res.frequencies_hz) >= 0) and res.frequencies_hz[0] > 0
    (case,) = res.results
    assert case.sweep.damping.shape == (20, SMALL["n_modes"])
    assert np.isfinite(case.sweep.damping).all()
    # the GAF the run used, torch vs PanelAero on the deck's boxes and modes (the tolerance of
    # tests/test_aero_dlm_kernel.py)
    deck = load_deck(path)
    modes = fe.modes(3)
    disp = np.asarray(fe.expand(modes.shapes)).reshape(3, -1, 6)
    motion = deck.box_motion(fe.grid_ids, disp)
    b = deck.reference.semichord
    ks = [0.0, 0.1, 1.0]
    q_t = compute_gaf(deck.aero_panels, motion, 0.5, ks, b, "parabolic").Q
    q_p = compute_gaf(deck.aero_panels, motion, 0.5, ks, b, "parabolic", engine="panelaero").Q
    assert np.abs(q_t - q_p).max() < 1e-10 * np.abs(q_p).max()
