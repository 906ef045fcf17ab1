"""The planform from a structure's outline (torchrom.aero.outline) against closed forms:
a trapezoid with a rectangular root bay (the kink found, straight stations merged), the
wingbox fractions extended to the full chord, and the refusals."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.aero.outline import planform
from torchrom.errors import InputError


def _stations(s, le, te, n_chord=4, depth=0.1):
    """Grid positions (span, chord, up) of a box: upper and lower grids at each station."""
    pts = []
    for si, a, b in zip(s, le, te):
        for c in np.linspace(a, b, n_chord):
            pts += [(si, c, depth / 2), (si, c, -depth / 2)]
    return np.array(pts)


def test_kinked_trapezoid_keeps_root_kink_and_tip():
    """Root bay 0..1.5 of chord 2.75 (LE 0), then LE and TE straight to the tip at 13.8
    (LE 6.475, TE 7.375): area 1.5 * 2.75 + 12.3 * (2.75 + 0.9) / 2 (exact for trapezoids)."""
    s = np.array([0.0, 0.75, 1.5, *np.linspace(1.5, 13.8, 9)[1:]])
    le = np.interp(s, [0, 1.5, 13.8], [0, 0, 6.475])
    te = np.interp(s, [0, 1.5, 13.8], [2.75, 2.75, 7.375])
    p = planform(_stations(s, le, te))
    assert np.allclose(p.s, [0.0, 1.5, 13.8])
    assert np.allclose(p.le, [0, 0, 6.475]) and np.allclose(p.te, [2.75, 2.75, 7.375])
    area = 1.5 * 2.75 + 12.3 * (2.75 + 0.9) / 2
    assert p.area == pytest.approx(area, rel=1e-12)
    assert p.mean_chord == pytest.approx(area / 13.8, rel=1e-12)
    assert np.allclose(p.n, 0.0)


def test_box_chord_extends_the_edges():
    """A box between spars at 20 % and 70 % of a 2 m chord (x = 0.4 .. 1.4): the planform is
    the full 0 .. 2 m chord."""
    p = planform(_stations([0.0, 5.0], [0.4, 0.4], [1.4, 1.4]), box_chord=(0.2, 0.7))
    assert np.allclose(p.le, 0.0) and np.allclose(p.te, 2.0)


@pytest.mark.parametrize("box", [(0.7, 0.2), (-0.1, 0.5), (0.2, 1.5)])
def test_bad_box_chord_is_refused(box):
    with pytest.raises(InputError, match="--box-chord"):
        planform(_stations([0.0, 5.0], [0, 0], [1, 1]), box_chord=box)


def test_a_beam_line_has_no_planform():
    line = np.array([[s, 0.0, 0.0] for s in np.linspace(0, 5, 6)])
    with pytest.raises(InputError, match="no chordwise extent"):
        planform(line)
    with pytest.raises(InputError, match="fewer than two span stations"):
        planform(line[:1])
