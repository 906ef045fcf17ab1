"""LCOs from scratch by harmonic balance (torchrom.periodic.solve) against closed forms and
time marching."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.periodic import HBOptions, solve_orbits
from torchrom.rom.analytic import quintic_damping_oscillator, van_der_pol_duffing
from torchrom.sim import CaseSystem, LCOCriteria, Newmark


def test_van_der_pol_closed_form():
    """REFERENCE Sec. 4: ω = 2π, c1 = −0.05, d3 = 0.4: A = 2√(−c1/d3) = 0.70711, which a
    tight ODE solution matches to ~1e-4 (averaging error); HB must be at least as close. With
    a cubic stiffness k3 the frequency follows ω(1 + 3 k3 A²/(8ω²)) to first order in k3 A²/ω²
    (here 1.5e-3, so ≤ ~1e-5 off). A case with positive net damping decays."""
    rom = van_der_pol_duffing(1.0, c1=-0.05, d3=0.4, k3=[0.0])
    system = CaseSystem.build(rom, 2, alpha=[0.0, 0.2], gamma=1.0)
    orb = solve_orbits(system, [1.0])
    assert list(orb.status) == ["lco", "decay"]
    amp = orb.amplitude(torch.ones(1, 1))[:, 0]
    assert amp[0] == pytest.approx(2 * math.sqrt(0.05 / 0.4), rel=1e-4)
    assert amp[1] == 0.0
    assert orb.frequency_hz[0] == pytest.approx(1.0, rel=1e-4)

    w = 2 * math.pi
    k3 = 0.2
    rom = van_der_pol_duffing(1.0, c1=-0.05, d3=0.4, k3=k3)
    orb = solve_orbits(CaseSystem.build(rom, 1, gamma=1.0), [1.0])
    A = orb.amplitude(torch.ones(1, 1))[0, 0]
    assert orb.frequency_hz[0] == pytest.approx(1 + 3 * k3 * A**2 / (8 * w**2), rel=2e-5)


def test_hb_matches_newmark_on_a_coupled_rom():
    """The demo's three coupled modes: HB against Newmark at dt = 2 ms within 1e-3 (Newmark's
    own error at that step is 3.3e-4 in amplitude here: halving dt brings it to 2e-5 of HB's
    answer, at three times this test's cost)."""
    rom = van_der_pol_duffing([1.0, 2.3, 4.1], c1=[-0.6, 0.05, 0.1], d3=1.0, k3=[8.0, 0, 0],
                              coupling=[[0, 6, 0], [6, 0, 6], [0, 6, 0]])
    system = CaseSystem.build(rom, 2, alpha=[0.1, 0.3], gamma=1.0)
    orb = solve_orbits(system, np.ones(3))
    res = Newmark(dt=2e-3, iterations=3).run(system, np.tile([1.0, 0, 0], (2, 1)), t_end=100.0,
                                              outputs=["sum"], lco=LCOCriteria(rtol=1e-5))
    assert list(res.status) == ["lco", "lco"]
    amp = orb.amplitude(torch.ones(1, 3))[:, 0]
    assert np.allclose(amp, res.amplitude[:, 0], rtol=1e-3)
    assert np.allclose(orb.frequency_hz, res.frequency_hz, rtol=1e-4)


def test_neighbour_chains_give_the_cold_answers():
    """Warm starts along a chain converge to the same orbits as cold starts (to the Newton
    tolerance), in fewer iterations; a chain across the Hopf point starts the LCO cases cold
    again after a decaying neighbour."""
    rom = van_der_pol_duffing(1.0, c1=-0.6, d3=1.0, k3=2.0)
    alpha = np.linspace(0.0, 0.8, 9)
    system = CaseSystem.build(rom, len(alpha), alpha=alpha, gamma=1.0)
    cold = solve_orbits(system, [1.0])
    warm = solve_orbits(system, [1.0], chains=[list(range(8, -1, -1))], positions=alpha)
    assert list(cold.status) == list(warm.status)
    lco = cold.status == "lco"
    a_cold = cold.amplitude(torch.ones(1, 1))[:, 0]
    a_warm = warm.amplitude(torch.ones(1, 1))[:, 0]
    assert np.allclose(a_cold[lco], a_warm[lco], rtol=1e-8)
    assert warm.iterations.sum() < cold.iterations.sum()


def test_a_warm_case_costs_a_few_iterations():
    """Along a chain in α of the quintic oscillator (a slaved dual mode), every case after the
    first two is solved at its neighbour's H from the secant predictor and checked against
    its H − 2 orbit, itself extrapolated from the neighbours' (:func:`_check_harmonics`):
    at most 4 Newton iterations in all (2 at H, 1–2 at H − 2; a cold start takes 14–17
    here), and the same orbits as cold starts to the Newton tolerance."""
    rom = quintic_damping_oscillator(c1=-1.0, d3=1.0, d5=0.5)
    alpha = np.linspace(0.0, 0.6, 13)
    system = CaseSystem.build(rom, len(alpha), alpha=alpha, gamma=1.0)
    cold = solve_orbits(system, rom.outputs["q1"])
    order = list(range(12, -1, -1))
    warm = solve_orbits(system, rom.outputs["q1"], chains=[order], positions=alpha)
    assert (cold.status == "lco").all() and (warm.status == "lco").all()
    assert (warm.harmonics == cold.harmonics).all()
    assert warm.iterations[order[2:]].max() <= 4
    assert cold.iterations.min() >= 10
    r = torch.as_tensor(rom.outputs["q1"])[None]
    assert np.allclose(warm.amplitude(r), cold.amplitude(r), rtol=1e-8)


def test_bounds_and_bad_input():
    rom = van_der_pol_duffing(1.0, c1=-0.05, d3=0.4)
    system = CaseSystem.build(rom, 1, gamma=1.0)
    # the LCO (0.707) is larger than the allowed amplitude: diverged, no amplitude
    orb = solve_orbits(system, [1.0], HBOptions(max_amplitude=0.3))
    assert orb.status[0] == "diverged"
    assert np.isnan(orb.amplitude(torch.ones(1, 1))[0, 0])
    with pytest.raises(InputError, match="output_row"):
        solve_orbits(system, [0.0])
    with pytest.raises(InputError, match="harmonics"):
        HBOptions(harmonics=0)
    with pytest.raises(InputError, match="start_harmonics <= harmonics"):
        HBOptions(start_harmonics=7, harmonics=5)
