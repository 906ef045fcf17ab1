"""Aerodynamic boxes: geometry, left-to-right storage, mirroring, CAERO1 cards (pyNastran)."""

import numpy as np
import pytest

from torchrom.aero.panels import (
    AeroPanels,
    goland_panels,
    goland_reference,
    lattice,
    read_caero1,
    read_model,
    rectangular_wing,
)
from torchrom.errors import InputError


def test_rectangular_box_geometry_is_exact():
    p = rectangular_wing(2.0, 3.0, 4, 6, x_le=1.0, full_span=False)
    assert p.n == 24
    np.testing.assert_allclose(p.areas, 0.5 * 0.5)
    np.testing.assert_allclose(p.chords, 0.5)
    np.testing.assert_allclose(p.normals, np.tile([0, 0, 1.0], (24, 1)))
    # first box: x 1..1.5, y 0..0.5 -> quarter chord x = 1.125, three-quarter x = 1.375
    np.testing.assert_allclose(p.doublet_points[0], [1.125, 0.25, 0])
    np.testing.assert_allclose(p.control_points[0], [1.375, 0.25, 0])
    np.testing.assert_allclose(p.vortex_left[0], [1.125, 0.0, 0])
    np.testing.assert_allclose(p.vortex_right[0], [1.125, 0.5, 0])
    # Nastran numbering: chordwise first
    np.testing.assert_allclose(p.centers[1, :2], [1.75, 0.25])
    assert p.areas.sum() == pytest.approx(6.0)


def test_mirror_keeps_left_to_right_and_maps_sources():
    half = rectangular_wing(1.0, 2.0, 2, 4, full_span=False)
    full = half.mirror()
    assert full.n == 2 * half.n
    assert np.all(full.normals[:, 2] > 0.999)  # every box still left to right
    assert np.all(full.vortex_right[:, 1] > full.vortex_left[:, 1])
    img = np.flatnonzero(full.mirrored)
    np.testing.assert_allclose(full.centers[img, 0], half.centers[full.source[img], 0])
    np.testing.assert_allclose(full.centers[img, 1], -half.centers[full.source[img], 1])
    assert full.centers[0, 1] == pytest.approx(-1.75)  # left tip first
    # symmetric and antisymmetric spreading of box values
    vals = np.arange(half.n, dtype=float) + 1
    np.testing.assert_allclose(full.box_motion(vals)[img], vals[full.source[img]])
    np.testing.assert_allclose(
        full.box_motion(vals, antisymmetric=True)[img], -vals[full.source[img]]
    )
    with pytest.raises(InputError, match="already"):
        full.mirror()


def test_right_to_left_lattice_is_stored_left_to_right():
    # a left wing defined root first (inboard at y = 0, outboard at y = -2)
    p = lattice([0, 0, 0], [1, 0, 0], [1, -2, 0], [0, -2, 0], [0, 1], [0, 0.5, 1])
    assert np.all(p.normals[:, 2] > 0.999)


def test_goland_planform():
    p = goland_panels(4, 10)
    assert p.n == 80
    assert p.areas.sum() == pytest.approx(240.0)
    assert p.corners[..., 0].min() == 0.0 and p.corners[..., 0].max() == 6.0
    assert goland_reference().semichord == 3.0


def test_bad_lattice_fractions():
    with pytest.raises(InputError, match="CAERO1 7: span divisions"):
        lattice([0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 1], [0, 0.7, 0.5, 1], caero_id=7)


def test_zero_area_box():
    with pytest.raises(InputError, match="zero or negative area"):
        AeroPanels(np.zeros((1, 4, 3)), [1], [1])


def test_caero1_from_deck_in_rotated_cp(shared):
    model = read_model(shared / "nastran" / "pt145.bdf")
    p = read_caero1(model, "pt145.bdf")
    assert p.n == 24 and p.box_ids[0] == 101 and p.box_ids[-1] == 124
    # root LE: (-1, -0.26795) in the -15 deg rotated CP -> x = -1.0353, y = 0 in basic
    np.testing.assert_allclose(p.corners[0, 0], [-1.0353, 0.0, 0.0], atol=1e-4)
    # chord 2.0706 along basic x; 15 deg sweep of the leading edge
    np.testing.assert_allclose(p.corners[0, 1, 0] - p.corners[0, 0, 0], 2.0706 / 4, rtol=1e-12)
    le = p.corners[p.box_ids == 121][0, 3]
    assert np.degrees(np.arctan2(le[0] + 1.0353, le[1])) == pytest.approx(15.0, abs=0.01)
    assert p.areas.sum() == pytest.approx(2.0706 * 5.52509, rel=1e-4)
