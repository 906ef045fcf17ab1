"""Floquet stability of periodic orbits (torchrom.periodic.floquet): a closed form and the
time integrator's verdict from perturbed orbits."""

from __future__ import annotations

import math

import numpy as np
import torch

from torchrom.periodic import BranchOptions, floquet, follow_branches, solve_orbits
from torchrom.rom.analytic import quintic_damping_oscillator, van_der_pol_duffing
from torchrom.sim import CaseSystem, LCOCriteria, Newmark


def test_van_der_pol_multiplier_equals_liouville():
    """One mode: the multipliers' product is exp(−∫(c + d3 q²)dt) (Liouville) and one of them
    is 1, so the other is that exponential, evaluated on the HB orbit itself. The
    extrapolated exponential-midpoint monodromy is fourth order: within 1e-4 at the default
    32 steps per period, within 1e-5 at 128."""
    rom = van_der_pol_duffing(1.0, c1=-0.05, d3=0.4, k3=1.0)
    system = CaseSystem.build(rom, 2, alpha=[0.0, 0.02], gamma=1.0)
    orb = solve_orbits(system, [1.0])
    fl = floquet(system, orb.X, orb.omega)
    fine = floquet(system, orb.X, orb.omega, steps=128)
    tau = torch.linspace(0, 2 * math.pi, 2049, dtype=torch.float64)[:-1]
    H = (orb.X.shape[1] - 1) // 2
    q = orb.X[:, 0, 0][:, None] + sum(orb.X[:, 2 * k - 1, 0][:, None] * torch.cos(k * tau)
                                      + orb.X[:, 2 * k, 0][:, None] * torch.sin(k * tau)
                                      for k in range(1, H + 1))
    T = 2 * math.pi / orb.omega.numpy()
    c = np.array([-0.05, -0.03])
    expected = np.exp(-(c + 0.4 * (q**2).mean(1).numpy()) * T)
    assert np.allclose(fl.critical_modulus, expected, rtol=1e-4)
    assert np.allclose(fine.critical_modulus, expected, rtol=1e-5)
    trivial = fl.multipliers[np.arange(2), fl.trivial]
    assert np.allclose(trivial, 1.0, atol=2e-4)
    assert fl.stable.all()


def test_newmark_confirms_the_stability_of_both_coexisting_orbits():
    """The subcritical oscillator at α = 0 has an unstable and a stable LCO (continuation
    finds both). Newmark started on each orbit, perturbed outward by 5 %, leaves the unstable
    one (ends on the large LCO) and returns to the stable one."""
    rom = quintic_damping_oscillator()

    def builder(p, branches):
        return CaseSystem.build(rom, len(p), alpha=np.asarray(p, float), gamma=1.0)

    br = follow_branches(builder, 1, rom.outputs["q1"],
                         BranchOptions(bounds=(-1.5, 1.0), max_step=0.3))
    pts = [p for p in br.points[0] if p.kind != "hopf"]
    stable = br.stable[0]
    amps = np.array([abs(float(p.X[1, 0])) for p in pts])
    # the two orbits nearest α = 0 on either side of the fold
    unstable_pt = min((p for p, s in zip(pts, stable) if not s), key=lambda p: abs(p.parameter))
    stable_pt = min((p for p, s in zip(pts, stable) if s), key=lambda p: abs(p.parameter))
    assert not stable.all() and stable.any() and amps.max() > 1.5
    starts, alphas = [], []
    for pt in (unstable_pt, stable_pt):
        H = (pt.X.shape[0] - 1) // 2
        q0 = (pt.X[0] + pt.X[1::2].sum(0)).numpy() * 1.05
        v0 = pt.omega * sum(k * pt.X[2 * k] for k in range(1, H + 1)).numpy() * 1.05
        starts.append((q0, v0))
        alphas.append(pt.parameter)
    system = CaseSystem.build(rom, 2, alpha=alphas, gamma=1.0)
    res = Newmark(dt=5e-3, iterations=4, predictor="quadratic").run(
        system, np.stack([s[0] for s in starts]), np.stack([s[1] for s in starts]),
        t_end=60.0, outputs=["q1"], lco=LCOCriteria(rtol=1e-4))
    assert list(res.status) == ["lco", "lco"]
    a_unstable = abs(float(unstable_pt.X[1, 0]))
    a_stable = abs(float(stable_pt.X[1, 0]))
    # the unstable orbit's perturbation grew away to the large LCO; the stable one came back
    assert res.amplitude[0, 0] > 1.2 * a_unstable
    assert abs(res.amplitude[1, 0] / a_stable - 1) < 0.02


def test_condensed_dual_coordinates_match_the_full_monodromy():
    """A fast, well-damped dual mode (200 Hz under a 2 Hz orbit) is condensed onto the slow
    state (:func:`~torchrom.periodic.floquet.condensable`); its damping reaches the slow mode
    through the quintic coupling (K_ld P, first order). The critical multiplier agrees with the
    full state's monodromy at 512 steps within 1e-3 (the neglected terms are of order
    (2ω/ω_d)² = 4e-4 and (ω C_dd/K_dd)² ≈ 1e-4), and the trivial one is recovered within 1e-3."""
    import sys

    F = sys.modules["torchrom.periodic.floquet"]
    rom = quintic_damping_oscillator(c1=-1.0, d3=1.0, d5=0.5, slave_hz=200.0)
    system = CaseSystem.build(rom, 2, alpha=[0.0, 0.2], gamma=1.0)
    orb = solve_orbits(system, rom.outputs["q1"])
    assert list(orb.status) == ["lco", "lco"]
    duals = torch.tensor([1])
    assert F.condensable(system, orb.omega, duals)
    fl = floquet(system, orb.X, orb.omega)
    assert fl.multipliers.shape[1] == 2  # slow state [δq1, δq̇1], no lags
    orig = F.condensable
    try:
        F.condensable = lambda *args: False
        full = floquet(system, orb.X, orb.omega, steps=512)
    finally:
        F.condensable = orig
    assert full.multipliers.shape[1] == 4
    assert np.allclose(fl.critical_modulus, full.critical_modulus, rtol=1e-3)
    assert (fl.critical_modulus < 1).all() and fl.stable.all()
    assert (fl.trivial_error < 1e-3).all()


def test_the_condensed_dual_coordinate_decays_as_its_own_linear_block():
    """The typical section's stiff dual coordinate u (mass m_u, stiffness k_u, no tangent on its
    own row and column: its strain couples it to the plunge only) at γ = 0 is damped by α M
    alone: its multiplier over one LCO period is exp(−α T / 2) exactly (closed form)."""
    from torchrom.periodic import HarmonicBalanceMethod
    from torchrom.periodic.floquet import condensed_multiplier
    from torchrom.study.cases import case_system

    from .aeroelastic_fixtures import section_model

    alpha = 0.05
    system = case_system(section_model(), [{"altitude_ft": 6000.0, "gamma": 0.0,
                                            "alpha": alpha}])[0]
    res = HarmonicBalanceMethod(stability=False).run(system, outputs=["A_Tz"],
                                                     lco=LCOCriteria(max_amplitude=10.0))
    assert list(res.status) == ["lco"]
    X, w = (torch.as_tensor(a) for a in res.orbits)
    mu = condensed_multiplier(system.to(dtype=torch.float64), X, w)
    period = 2 * math.pi / float(w[0])
    assert abs(mu[0] - math.exp(-alpha * period / 2)) < 1e-12
