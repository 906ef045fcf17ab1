"""Flutter about a deformed state (torchrom.trim.flutter).

Independent references: MSC Nastran SOL 145 on the skinned Pazy deck (its f06: flutter 67.30 m/s
at 34.72 Hz), which the tangent route must reproduce about the undeformed state (u = 0: the
modes of K, the GAFs projected from the spline DOFs instead of computed on the modes); and
hand-made root sets for the boundary bookkeeping.
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.aero.nastran_flutter import load_deck
from torchrom.fe import read_bdf
from torchrom.trim.flutter import StabilityPoint, boundaries, spline_gaf, stability_at
from torchrom.trim.operators import steady_operator

from .test_trim_equilibrium import PAZY_SKIN


def _point(V, g, f):
    return StabilityPoint(V, np.asarray(g, float), np.asarray(f, float), np.asarray(f, float))


def test_boundaries_follow_roots_by_frequency_and_ignore_neutral_ones():
    """An onset and an offset interpolated on the root that crosses, with the roots' order
    swapped between the speeds (followed by frequency); a root hovering at g = ±1e-7 (an
    unloaded mode) and a real root are no boundary."""
    pts = [_point(40.0, [-0.02, -1e-7, -0.5], [30.0, 100.0, 0.0]),
           _point(42.0, [2e-7, 0.02, -0.4], [100.0, 28.0, 0.0]),
           _point(44.0, [-1e-7, -0.01, 0.3], [100.0, 27.0, 0.0])]
    (on, off) = boundaries(pts)
    assert (on.kind, off.kind) == ("onset", "offset")
    assert on.velocity == pytest.approx(41.0) and on.frequency_hz == pytest.approx(29.0)
    assert off.velocity == pytest.approx(42.0 + 2.0 * 0.02 / 0.03)


def test_tangent_route_about_the_undeformed_wing_is_sol145():
    """u = 0 (no incidence): onset between 66 and 68 m/s at 67.34 m/s, 34.75 Hz with the
    deck's 105 reduced frequencies (measured); here on 12 of them around the flutter point's
    k ≈ 0.16 (cubic interpolation): within 0.5 % of the f06's 67.30 m/s and 1 % of 34.72 Hz."""
    fe = read_bdf(PAZY_SKIN)
    deck = load_deck(PAZY_SKIN, require_flutter=False)
    op = steady_operator(fe, deck)
    gaf = spline_gaf(deck, op, k_list=[0.01, 0.05, 0.1, 0.12, 0.14, 0.16, 0.18, 0.2, 0.25, 0.3,
                                       0.5, 1.0])
    u = np.zeros(fe.n_dof)
    pts = [stability_at(fe, op, gaf, u, V, 1.225, 10) for V in (66.0, 68.0)]
    (b,) = boundaries(pts)
    assert b.kind == "onset"
    assert b.velocity == pytest.approx(67.30, rel=5e-3)
    assert b.frequency_hz == pytest.approx(34.72, rel=1e-2)
