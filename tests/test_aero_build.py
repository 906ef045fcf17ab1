"""FE modes -> box motion -> GAF/RFA (the Python API), with closed-form stand-in modes."""

import numpy as np
import pytest

from torchrom.aero.build import build_from_modes, modal_data, planform_box_motion
from torchrom.aero.dlm import BoxMotion, compute_gaf
from torchrom.aero.panels import goland_panels
from torchrom.aero.splines import SectionSpline

from ._aero_fakes import plate_fe


@pytest.fixture(scope="module")
def modes():
    return modal_data(plate_fe(), 2)


def _analytic_motion(panels):
    # the stand-in's mass-normalised shapes continued over the whole 6 ft chord (rigid sections)
    s1, s2 = np.sqrt(50.0), np.sqrt(190.0)
    return BoxMotion.from_function(
        panels,
        [
            (lambda x, y: (np.abs(y) / 20) ** 2 / s1, lambda x, y: 0 * x),
            (lambda x, y: -(x - 2) * np.abs(y) / 20 / s2, lambda x, y: -np.abs(y) / 20 / s2),
        ],
    )


def test_section_spline_box_motion_is_exact_for_rigid_sections(modes):
    panels = goland_panels(4, 10)
    motion = planform_box_motion(modes, panels)
    exact = _analytic_motion(panels)
    for name in ("h_load", "h_control", "slope_control"):
        np.testing.assert_allclose(getattr(motion, name), getattr(exact, name), atol=1e-12)
    # mirrored boxes move with their source (symmetric modes)
    img = np.flatnonzero(panels.mirrored)
    np.testing.assert_allclose(
        motion.h_load[:, img], motion.h_load[:, panels.n // 2 + panels.source[img]]
    )


def test_build_gaf_and_rfa(modes):
    panels = goland_panels(4, 10)
    k = [0.0, 0.02, 0.05, 0.1, 0.2, 0.4]
    data = build_from_modes(modes, 0.7, n_lags=2, k_list=k, panels=panels)
    ref = compute_gaf(panels, _analytic_motion(panels), 0.7, k, 3.0)
    np.testing.assert_allclose(data.gaf.Q, ref.Q, atol=1e-12 * np.abs(ref.Q).max())
    assert data.semichord == 3.0 and data.n_modes == 2 and data.rfa.n_states == 2
    np.testing.assert_allclose(data.rfa.A0, data.gaf.Q[0].real)
    assert data.rfa.fit_error["rms_relative"] < 0.05
    # twist about the 1/3-chord box line gives lift: steady Q_bend,twist < 0 (F = -q Q q)
    assert data.gaf.Q[0, 0, 1].real < 0
    assert data.metadata["spline"] == "section"


def test_section_spline_needs_two_stations():
    from torchrom.errors import InputError

    with pytest.raises(InputError, match="two or more span stations"):
        SectionSpline(np.array([[0.0, 1.0, 0.0], [2.0, 1.0, 0.0]]))


def test_python_api_build_and_flutter_altitude():
    """DESIGN API: tr.aero.build(fe, ...) and tr.aero.flutter_altitude(rom, aero, ...)."""
    import torchrom as tr
    from torchrom.aero.flutter import flutter_altitude_state_space
    from torchrom.rom import NonlinearROM

    fe = tr.fe.goland()
    aero = tr.aero.build(
        fe,
        mach=0.7,
        n_modes=2,
        n_lags=2,
        k_list=[0.0, 0.03, 0.06, 0.12],
        panels=goland_panels(2, 5),
    )
    assert aero.n_modes == 2 and aero.metadata["source"] == "goland"
    # the default (updated) wing's mode 1: 1.664 Hz, Table 2's 1.690 within 3 %
    np.testing.assert_allclose(aero.metadata["frequencies_hz"][0], 1.690, rtol=0.03)
    modes = modal_data(fe, 2)
    rom = NonlinearROM(np.eye(2), np.diag((2 * np.pi * modes.frequencies_hz) ** 2))
    res = tr.aero.flutter_altitude(rom, aero, alpha=0.2565, gamma=1.338e-4, alt_range=(0, 30000))
    ref = flutter_altitude_state_space(modes.structure(0.2565, 1.338e-4), aero.rfa, 0.7, (0, 30000))
    assert res.altitude == pytest.approx(ref.altitude, rel=1e-9)
