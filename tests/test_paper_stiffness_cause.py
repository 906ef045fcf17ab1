"""The stiffness-cause measures (torchrom.paper.stiffness_cause) against closed forms on the
quintic-damping oscillator, whose second mode is a 'dual' mode slaved to q1² through K2
(torchrom.rom.analytic.quintic_damping_oscillator: q2 = −ε q1² quasi-statically)."""

from __future__ import annotations

import math

import pytest
import torch

from torchrom.paper.stiffness_cause import (
    SAMPLES,
    SWITCHES,
    energy_terms,
    following_ratio,
    quasi_static_duals,
)
from torchrom.rom.analytic import quintic_damping_oscillator

C1, D3, D5, EPS, ZETA, F2 = 0.3, 2.0, 1.5, 0.05, 0.5, 20.0


@pytest.fixture(scope="module")
def rom():
    return quintic_damping_oscillator(frequency_hz=2.0, c1=C1, d3=D3, d5=D5, slave_hz=F2,
                                      slave_damping=ZETA, slave_coupling=EPS)


def _harmonic(a: float, w: float):
    """q1 = a cos ωt over one period (SAMPLES points), the dual coordinate zero."""
    t = torch.arange(SAMPLES, dtype=torch.float64) * (2 * math.pi / w) / SAMPLES
    q = torch.stack([a * torch.cos(w * t), torch.zeros_like(t)], 1)
    qd = torch.stack([-a * w * torch.sin(w * t), torch.zeros_like(t)], 1)
    return q, qd


def test_energy_terms_match_the_cycle_means(rom):
    """q1 = a cos ωt, q2 = 0: ⟨α q̇1²⟩ = α a²ω²/2, ⟨γ c1 q̇1²⟩ = γ c1 a²ω²/2, the cubic
    ⟨γ d3 q1² q̇1²⟩ = γ d3 a⁴ω²/8; nothing on the dual mode, no quadratic damping, and no work
    of the stiffness terms (rounding: 1e-12 relative)."""
    a, w, alpha, gamma = 0.7, 2 * math.pi * 2.0, 0.2, 1e-2
    terms = energy_terms(rom, *_harmonic(a, w), alpha, gamma)
    assert terms["α M"] == pytest.approx(alpha * a**2 * w**2 / 2, rel=1e-12)
    assert terms["γ D̄1, linear modes"] == pytest.approx(gamma * C1 * a**2 * w**2 / 2, rel=1e-12)
    assert terms["γ D̄3(q, q)"] == pytest.approx(gamma * D3 * a**4 * w**2 / 8, rel=1e-12)
    scale = gamma * D3 * a**4 * w**2
    for k in ("γ D̄1, dual modes", "γ D̄2(q)", "K2 (conservative)", "K3 (conservative)"):
        assert abs(terms[k]) < 1e-12 * scale, k


def test_quasi_static_duals_and_the_following_ratio(rom):
    """K1_dd q_d = −K2_d(q, q) gives q2 = −ε q1² and q̇2 = −2ε q1 q̇1 exactly; the damping ratio
    with the dual coordinate zero is d3 a²/(4 c1) (cubic term only), with it following
    quasi-statically the quintic term d5 a⁶ω²/16 and the slave's own damping
    2ζω2 ε² a⁴ω²/2 join in."""
    a, w = 0.7, 2 * math.pi * 2.0
    q, qd = _harmonic(a, w)
    qs, qds = quasi_static_duals(rom, q, qd)
    torch.testing.assert_close(qs[:, 1], -EPS * q[:, 0] ** 2, rtol=1e-12, atol=1e-15)
    torch.testing.assert_close(qds[:, 1], -2 * EPS * q[:, 0] * qd[:, 0], rtol=1e-12,
                               atol=1e-15)
    r = following_ratio(rom, q, qd)
    assert r["as solved"] == r["dual coordinates zero"] == pytest.approx(D3 * a**2 / (4 * C1),
                                                                          rel=1e-12)
    w2 = 2 * math.pi * F2
    lin = C1 * a**2 * w**2 / 2 + 2 * ZETA * w2 * EPS**2 * a**4 * w**2 / 2
    nonlin = D3 * a**4 * w**2 / 8 + D5 * a**6 * w**2 / 16
    assert r["dual coordinates quasi-static"] == pytest.approx(nonlin / lin, rel=1e-10)


def test_switches_remove_what_they_name(rom):
    """The dual-mode couplings are the K2 entries with a dual index (here K2_211, which slaves
    q2 to q1²); 'K2 off' and 'dual-mode couplings off' remove it, 'only the dual-mode
    couplings' and 'K3 off' keep it."""
    k = {name: make(rom).K2[1, 0, 0].item() for name, (make, _) in SWITCHES.items()}
    full = rom.K2[1, 0, 0].item()
    assert full != 0
    assert k["K2 off (K3 kept)"] == k["dual-mode couplings off"] == 0.0
    assert k["only the dual-mode couplings"] == k["K3 off (K2 kept)"] == full
    assert not SWITCHES["no stiffness nonlinearity"][1] and SWITCHES["both nonlinearities"][1]
