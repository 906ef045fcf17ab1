"""Doublet-lattice GAFs through PanelAero: steady limit, k convention, 2-D limit, signs."""

import copy

import numpy as np
import pytest
from scipy.special import hankel2

from torchrom.aero.dlm import BoxMotion, compute_gaf, lift_curve_slope
from torchrom.aero.panels import rectangular_wing
from torchrom.errors import InputError


def _horseshoe_lift_slope(panels, far=1e6):
    """Independent vortex-lattice C_Lα (Biot–Savart horseshoes, Katz & Plotkin Ch. 12)."""
    gamma, a, b = _horseshoe_circulation(panels, far)
    return 2 * (gamma * np.linalg.norm(b - a, axis=1)).sum() / panels.areas.sum()  # full wing


def _horseshoe_circulation(panels, far=1e6):
    """The horseshoes' circulations Γ (unit freestream, α = 1 rad) and their bound vortices'
    ends a, b: each box's lift per unit q∞ is 2 Γ |b − a| (Kutta–Joukowski)."""

    def segment(p, a, b):
        r1, r2, r0 = p - a, p - b, b - a
        c = np.cross(r1, r2)
        c2 = (c**2).sum(-1)
        n1, n2 = np.linalg.norm(r1, axis=-1), np.linalg.norm(r2, axis=-1)
        with np.errstate(all="ignore"):
            f = (r0 * (r1 / n1[..., None] - r2 / n2[..., None])).sum(-1) / (4 * np.pi * c2)
            v = c * f[..., None]
        v[c2 < 1e-20] = 0.0
        return v

    a, b, p = panels.vortex_left, panels.vortex_right, panels.control_points[:, None, :]
    a_inf, b_inf = a + [far, 0, 0], b + [far, 0, 0]
    w = (
        segment(p, a_inf[None], a[None])
        + segment(p, a[None], b[None])
        + segment(p, b[None], b_inf[None])
    )[..., 2]
    gamma = np.linalg.solve(w, -np.ones(panels.n))  # unit freestream, α = 1 rad
    return gamma, a, b


@pytest.fixture(scope="module")
def wing():
    return rectangular_wing(1.0, 2.0, 6, 12)  # full span, aspect ratio 4


@pytest.mark.parametrize("kernel", ["quartic", "parabolic"])
def test_steady_lift_curve_slope_matches_vortex_lattice(wing, kernel):
    from panelaero import VLM

    cla = lift_curve_slope(wing, mach=0.0, k=1e-3, kernel=kernel).real
    q_vlm, _ = VLM.calc_Qjj(copy.deepcopy(wing.to_panelaero()), 0.0)
    cla_vlm = (q_vlm @ np.ones(wing.n) * wing.areas).sum() / wing.areas.sum()
    cla_bs = _horseshoe_lift_slope(wing)
    # acceptance: within 2 % of an independent method; observed ~1e-5 (the DLM's oscillatory
    # increment vanishes as k -> 0, and both lattices are the same discretisation)
    assert cla == pytest.approx(cla_vlm, rel=0.02)
    assert cla == pytest.approx(cla_bs, rel=0.02)
    assert cla == pytest.approx(cla_bs, rel=1e-3)
    # sanity: AR 4 rectangular wing, lifting-surface value about 3.6 per rad
    assert 3.4 < cla < 3.8


def test_reduced_frequency_is_converted_at_the_boundary(wing):
    """k = ω b / V (Nastran) -> PanelAero's ω / V = k / b, checked against PanelAero itself."""
    from panelaero import DLM

    b, k = 0.5, 0.4
    plunge = BoxMotion.from_function(wing, [(lambda x, y: np.ones_like(x), lambda x, y: 0 * x)])
    q = compute_gaf(wing, plunge, 0.3, [k], b).Q[0, 0, 0]
    qjj = DLM.calc_Qjj(copy.deepcopy(wing.to_panelaero()), 0.3, k / b, method="quartic")
    half = ~wing.mirrored  # loads on the modelled half wing only
    direct = -(wing.areas * (qjj @ (-1j * (k / b) * np.ones(wing.n))))[half].sum()
    assert q == pytest.approx(direct, rel=1e-10)
    # scale invariance: a wing twice as large at the same Nastran k (semichord doubled) has the
    # same pressures for the same h/b, so Q_hh (a length) doubles; a wrong k convention breaks it
    big = rectangular_wing(2.0, 4.0, 6, 12)
    plunge_big = BoxMotion.from_function(big, [(lambda x, y: np.ones_like(x), lambda x, y: 0 * x)])
    q_big = compute_gaf(big, plunge_big, 0.3, [k], 2 * b).Q[0, 0, 0]
    assert q_big == pytest.approx(2 * q, rel=1e-8)


def test_high_aspect_ratio_plunge_tends_to_theodorsen():
    """AR 40 wing in plunge vs 2-D Theodorsen per unit span: Q_hh/span = -2πk² + 4πik C(k)."""
    wing = rectangular_wing(2.0, 40.0, 4, 40)  # b = 1
    plunge = BoxMotion.from_function(wing, [(lambda x, y: np.ones_like(x), lambda x, y: 0 * x)])
    ks = np.array([0.1, 0.5])
    q = compute_gaf(wing, plunge, 0.0, ks, 1.0).Q[:, 0, 0] / 40.0  # half model: 40 span
    c = hankel2(1, ks) / (hankel2(1, ks) + 1j * hankel2(0, ks))
    q2d = -2 * np.pi * ks**2 + 4j * np.pi * ks * c
    # 3-D (finite span) effects at AR 40 lower the lift by a few per cent
    np.testing.assert_allclose(q, q2d, rtol=0.06)
    assert np.all(q.imag > 0)  # positive aerodynamic damping (paper sign F = -q Q q)


def test_mirrored_half_model_carries_half_the_full_wing_load():
    """A half wing with its image (symmetric modes) = one side of the same full wing."""
    from torchrom.aero.panels import lattice

    half_plus_image = rectangular_wing(1.0, 2.0, 4, 8)
    one_piece = lattice(
        [0, -2, 0], [1, -2, 0], [1, 2, 0], [0, 2, 0], np.linspace(0, 1, 5), np.linspace(0, 1, 17)
    )
    shapes = [
        (lambda x, y: np.ones_like(x), lambda x, y: 0 * x),
        (lambda x, y: -(x - 0.3) * np.abs(y), lambda x, y: -np.abs(y)),
    ]  # symmetric twist
    q_half = compute_gaf(
        half_plus_image, BoxMotion.from_function(half_plus_image, shapes), 0.5, [0.0, 0.3], 0.5
    ).Q
    q_full = compute_gaf(
        one_piece, BoxMotion.from_function(one_piece, shapes), 0.5, [0.0, 0.3], 0.5
    ).Q
    np.testing.assert_allclose(q_half, q_full / 2, rtol=1e-9, atol=1e-12)


def test_gaf_signs_and_steady_limit(wing):
    # rigid pitch about x = 0 (h = -x α): steady Q(0) is an aerodynamic stiffness, lift up
    motion = BoxMotion.from_function(
        wing,
        [
            (lambda x, y: np.ones_like(x), lambda x, y: 0 * x),
            (lambda x, y: -x, lambda x, y: -np.ones_like(x)),
        ],
    )
    g = compute_gaf(wing, motion, 0.0, [0.0, 0.2], 0.5)
    assert np.allclose(g.Q[0].imag, 0.0)
    assert g.Q[0, 0, 1].real < 0  # F_h = -q Q_hα α > 0: positive lift for nose-up pitch
    assert g.Q[0, 0, 0] == pytest.approx(0.0, abs=1e-12)  # no steady force from plunge
    assert g.subset(1).Q.shape == (2, 1, 1)


def test_bad_gaf_input(wing):
    m = BoxMotion.from_function(wing, [(lambda x, y: np.ones_like(x), lambda x, y: 0 * x)])
    with pytest.raises(InputError, match="subsonic"):
        compute_gaf(wing, m, 1.2, [0.1], 1.0)
    with pytest.raises(InputError, match="kernel"):
        compute_gaf(wing, m, 0.5, [0.1], 1.0, kernel="cubic")
    with pytest.raises(InputError, match="reduced frequencies"):
        compute_gaf(wing, m, 0.5, [-0.1], 1.0)
