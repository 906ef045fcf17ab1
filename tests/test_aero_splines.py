"""Splines: rigid plunge and pitch reproduced exactly at the boxes (issue 5 acceptance)."""

import numpy as np
import pytest

from torchrom.aero.panels import goland_panels
from torchrom.aero.splines import BeamSpline, PlateSpline
from torchrom.errors import InputError


def _rigid_field(xyz, translation, rotation):
    """6-DOF basic field of a small rigid motion: T = t + θ × r, R = θ."""
    u = np.zeros((len(xyz), 6))
    u[:, :3] = translation + np.cross(rotation, xyz)
    u[:, 3:] = rotation
    return u.ravel()


def _exact(points, translation, rotation):
    h = (translation + np.cross(rotation, points))[:, 2]
    slope = np.cross(rotation, [1.0, 0.0, 0.0])[2]  # ∂h/∂x of a rigid rotation
    return h, slope


# plunge, pitch about the 33 % chord line, and roll; small rotations in rad
MOTIONS = [
    (np.array([0.0, 0.0, 0.3]), np.zeros(3)),
    (np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.02, 0.0])),
    (np.array([0.01, 0.0, -0.1]), np.array([0.004, -0.03, 0.0])),
]


@pytest.fixture(scope="module")
def box_points():
    p = goland_panels(4, 10, full_span=False)
    return np.r_[p.doublet_points, p.control_points]


@pytest.mark.parametrize("translation, rotation", MOTIONS)
def test_plate_spline_reproduces_rigid_motion(box_points, translation, rotation):
    gx, gy = np.meshgrid([0.0, 2.0, 4.0], np.arange(0.0, 21.0, 2.0))
    top = np.c_[gx.ravel(), gy.ravel(), np.full(gx.size, 0.1667)]
    grids = np.r_[top, top - [0, 0, 0.3333]]  # coincident top/bottom points are merged
    spline = PlateSpline(grids)
    h_op, hx_op = spline.operators(box_points)
    u = _rigid_field(grids, translation, rotation)
    h, slope = _exact(box_points, translation, rotation)
    np.testing.assert_allclose(h_op @ u, h, atol=1e-12)
    np.testing.assert_allclose(hx_op @ u, slope, atol=1e-12)


@pytest.mark.parametrize("sweep_deg", [0.0, 15.0])
@pytest.mark.parametrize("translation, rotation", MOTIONS)
def test_beam_spline_reproduces_rigid_motion(box_points, sweep_deg, translation, rotation):
    c, s = np.cos(np.radians(sweep_deg)), np.sin(np.radians(sweep_deg))
    axes = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    origin = np.array([2.0, 0.0, 0.0])
    grids = origin + np.outer(np.linspace(0.0, 20.0, 11), axes[1])
    grids[::3] += 0.4 * axes[0]  # some grids off the axis (rigid arms)
    spline = BeamSpline(grids, origin=origin, axes=axes)
    h_op, hx_op = spline.operators(box_points)
    u = _rigid_field(grids, translation, rotation)
    h, slope = _exact(box_points, translation, rotation)
    np.testing.assert_allclose(h_op @ u, h, atol=1e-12)
    np.testing.assert_allclose(hx_op @ u, slope, atol=1e-12)


def test_beam_spline_interpolates_bending_between_grids():
    # w = y^3/1000 with its slope attached: a cubic Hermite spline is exact for a cubic
    y = np.linspace(0.0, 10.0, 6)
    grids = np.c_[np.zeros(6), y, np.zeros(6)]
    u = np.zeros((6, 6))
    u[:, 2] = y**3 / 1000
    u[:, 3] = 3 * y**2 / 1000  # rotation about x = dw/dy
    pts = np.c_[np.zeros(7), np.linspace(0.5, 9.5, 7), np.zeros(7)]
    h_op, _ = BeamSpline(grids).operators(pts)
    np.testing.assert_allclose(h_op @ u.ravel(), pts[:, 1] ** 3 / 1000, atol=1e-12)


def test_spline_input_errors():
    with pytest.raises(InputError, match="at least three"):
        PlateSpline(np.array([[0, 0, 0], [1, 0, 0], [2, 0, 0.0]]))
    with pytest.raises(InputError, match="at least two"):
        BeamSpline(np.array([[0, 0, 0.0]]))
