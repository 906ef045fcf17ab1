"""torchrom.rom.rayleigh: modal damping ratios ↔ the ROM's α (mass-) and γ (stiffness-
proportional) damping, ζ(ω) = α/(2ω) + γω/2.

References: the closed form itself (a Rayleigh curve put in is got back), the two-point formula
against numpy's linear solve, the relative least squares against numpy's unconstrained lstsq of
the same weighted system (NNLS and lstsq agree where both coefficients come out positive), and
the damping ratio of each root of the damped oscillator M q̈ + (αM + γK) q̇ + K q = 0 from its
state-space eigenvalues (ζ = −Re s / |s|).
"""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.rom import NonlinearROM
from torchrom.rom.rayleigh import (
    METADATA_KEY,
    RayleighDamping,
    damping_ratio,
    elastic_frequencies,
    fit_modal_ratios,
    fit_rayleigh,
    goland_damping,
    no_damping,
    parse_ratio_token,
    rayleigh_zeta,
    rom_modes,
    two_point,
)

F = np.array([1.7, 3.1, 9.3, 10.8, 16.2])  # Hz, the heavy Goland wing's first modes


def _roots_zeta(f_hz, alpha, gamma) -> np.ndarray:
    """ζ of each mode from the eigenvalues of the damped oscillators (second method)."""
    w2 = (2 * np.pi * np.asarray(f_hz)) ** 2
    n = len(w2)
    K, M = np.diag(w2), np.eye(n)
    C = alpha * M + gamma * K
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
    s = np.linalg.eigvals(A)
    s = s[s.imag > 0]
    s = s[np.argsort(np.abs(s))]
    return -s.real / np.abs(s)


def test_closed_form_is_the_oscillators_damping_ratio():
    """ζ(ω) = α/(2ω) + γω/2 equals −Re s/|s| of the damped modes to 1e-12 (both exact)."""
    alpha, gamma = 0.2565, 1.338e-4
    np.testing.assert_allclose(rayleigh_zeta(alpha, gamma, F), _roots_zeta(F, alpha, gamma),
                               rtol=1e-12)
    assert rayleigh_zeta(0.0, 0.0, [0.0])[0] == 0.0
    assert np.isinf(rayleigh_zeta(1.0, 0.0, [0.0])[0])


def test_a_rayleigh_curve_is_fitted_back_exactly():
    """Ratios on a Rayleigh curve give its α, γ back (rounding: 1e-10)."""
    alpha, gamma = 0.4, 2e-4
    a, g = fit_rayleigh(F, rayleigh_zeta(alpha, gamma, F))
    assert a == pytest.approx(alpha, rel=1e-10) and g == pytest.approx(gamma, rel=1e-10)
    # stiffness-proportional ratios and the γ-only fit: exact too
    a, g = fit_rayleigh(F, rayleigh_zeta(0.0, gamma, F), mass_proportional=False)
    assert a == 0.0 and g == pytest.approx(gamma, rel=1e-12)


def test_constant_ratio_fit_is_the_weighted_least_squares():
    """ζ = 0.02 at every mode: NNLS = numpy's lstsq of the relative system (both α, γ > 0
    here, so the bounds are inactive; 1e-9)."""
    zeta = np.full(F.shape, 0.02)
    a, g = fit_rayleigh(F, zeta)
    w = 2 * np.pi * F
    A = np.column_stack([1 / (2 * w), w / 2]) / zeta[:, None]
    (ra, rg), *_ = np.linalg.lstsq(A, np.ones_like(F), rcond=None)
    assert ra > 0 and rg > 0
    assert a == pytest.approx(ra, rel=1e-9) and g == pytest.approx(rg, rel=1e-9)


def test_one_frequency_gives_the_curve_whose_minimum_is_there():
    """One mode at ω: α = ζω, γ = ζ/ω, so ζ(ω) = ζ and dζ/dω = 0 there (closed form)."""
    a, g = fit_rayleigh([5.0], [0.03])
    w = 2 * np.pi * 5.0
    assert a == pytest.approx(0.03 * w) and g == pytest.approx(0.03 / w)
    assert rayleigh_zeta(a, g, [5.0])[0] == pytest.approx(0.03)
    assert rayleigh_zeta(a, g, [4.9])[0] > 0.03 and rayleigh_zeta(a, g, [5.1])[0] > 0.03


def test_two_point_solves_the_two_equations():
    """Z1@F1, Z2@F2: α, γ against numpy's solve of the 2x2 system, and the curve through both
    points (1e-12)."""
    z1, f1, z2, f2 = 0.01, 2.0, 0.03, 20.0
    a, g = two_point(z1, f1, z2, f2)
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    ref = np.linalg.solve([[1 / (2 * w1), w1 / 2], [1 / (2 * w2), w2 / 2]], [z1, z2])
    np.testing.assert_allclose([a, g], ref, rtol=1e-12)
    np.testing.assert_allclose(rayleigh_zeta(a, g, [f1, f2]), [z1, z2], rtol=1e-12)
    with pytest.raises(InputError, match="γ < 0"):
        two_point(0.05, 1.0, 0.001, 10.0)  # falls faster than 1/f
    with pytest.raises(InputError, match="α < 0"):
        two_point(0.001, 1.0, 0.05, 10.0)  # rises faster than f


@pytest.mark.parametrize("token, expected", [("0.02", (0.02, None)), ("0.02@5", (0.02, 5.0)),
                                             (" 0@1e3 ", (0.0, 1000.0))])
def test_ratio_tokens(token, expected):
    assert parse_ratio_token(token) == expected


@pytest.mark.parametrize("token, words", [
    ("-0.01", "0 <= ZETA < 1"), ("1.5", "0 <= ZETA < 1"), ("nan", "0 <= ZETA < 1"),
    ("x", "ZETA@FREQ_HZ"), ("0.02@", "ZETA@FREQ_HZ"), ("0.02@0", "frequency > 0"),
    ("0.02@-3", "frequency > 0"), ("0.02@inf", "frequency > 0"), ("0.02@x", "ZETA@FREQ_HZ")])
def test_bad_ratio_tokens(token, words):
    with pytest.raises(ValueError, match=words.replace("(", r"\(")):
        parse_ratio_token(token)


@pytest.mark.parametrize("tokens, words", [
    (["0.02@5"], "expected ZETA"), (["0.02", "0.03"], "expected ZETA"),
    (["0.02@5", "0.03"], "expected ZETA"), (["0.02@5", "0.03@5"], "must differ"),
    (["0.05@1", "0.001@10"], "no Rayleigh curve")])
def test_bad_ratio_combinations(tokens, words):
    with pytest.raises(InputError, match=f"--damping-ratio .*{words}"):
        damping_ratio(tokens)


def test_damping_ratio_maps_onto_the_modes():
    """Single ratio: the fit over the modes, α = 0 for a free structure; two points: exact,
    the frequencies sorted."""
    rec = damping_ratio(["0.02"]).rayleigh(F)
    assert (rec.alpha, rec.gamma) == pytest.approx(fit_rayleigh(F, np.full(F.shape, 0.02)))
    assert rec.source == "damping-ratio" and "--damping-ratio 0.02" in rec.description
    free = damping_ratio(["0.02"]).rayleigh(F, free=True)
    assert free.alpha == 0.0 and "free structure" in free.description
    two = damping_ratio(["0.03@20", "0.01@2"]).rayleigh(F)
    assert (two.alpha, two.gamma) == pytest.approx(two_point(0.01, 2.0, 0.03, 20.0), rel=1e-12)
    with pytest.raises(InputError, match="no elastic mode"):
        damping_ratio(["0.02"]).rayleigh([])


def test_record_round_trip_and_lines():
    rec = fit_modal_ratios("TABDMP1 7", F, np.linspace(0.01, 0.03, F.size), free=False)
    back = RayleighDamping.from_metadata({METADATA_KEY: rec.as_metadata()})
    assert (back.alpha, back.gamma, back.source) == (rec.alpha, rec.gamma, "deck")
    np.testing.assert_allclose(rec.as_metadata()["zeta_fit"], rec.zeta(F))
    assert RayleighDamping.from_metadata({}) is None
    with pytest.raises(InputError, match="structural_damping"):
        RayleighDamping.from_metadata({METADATA_KEY: {"alpha": -1.0, "gamma": 0.0}})
    assert (no_damping("nothing").alpha, no_damping("nothing").gamma) == (0.0, 0.0)
    assert "none (nothing)" in no_damping("nothing").description
    g = goland_damping()
    assert (g.alpha, g.gamma) == (0.2565, 1.338e-4)  # data/paper_reference.toml, Eq. 46


def test_elastic_modes_of_a_rom():
    """Linear modes past the rigid-body ones (basis metadata n_rigid, else 0 Hz modes); dual
    modes never."""
    assert elastic_frequencies([0.0, 0.0, 2.0, np.nan, 5.0], ["linear"] * 3 + ["dual", "linear"],
                               n_rigid=2).tolist() == [2.0, 5.0]
    rom = NonlinearROM(np.eye(3), np.diag([0.0, 4.0, 9.0]), mode_kinds=["linear"] * 3,
                       frequencies_hz=[0.0, 2.0, 3.0])
    f, free = rom_modes(rom)
    assert f.tolist() == [2.0, 3.0] and free
