"""Shooting on the discrete Newmark map (torchrom.periodic.shooting) against closed forms, a
second method (harmonic balance + Liouville) and long Newmark runs."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from torchrom.periodic import solve_orbits
from torchrom.periodic.shooting import OrbitStart, ShootingOptions, shoot, start_from_fourier
from torchrom.rom import NonlinearROM
from torchrom.rom.analytic import quintic_damping_oscillator, van_der_pol_duffing
from torchrom.sim import CaseSystem, LCOCriteria, Newmark

W = 2 * math.pi  # 1 Hz linear frequency


def rotating_oscillators(d3: float, k3: float = 1.0) -> NonlinearROM:
    """Two identical modes with damping d3 |q|² q̇_i and stiffness k3 |q|² q_i: with net linear
    damping α (M = I), q = A (cos ωt, sin ωt) is an exact orbit with |q|² = A² constant, so
    α + γ d3 A² = 0 and ω² = W² + k3 A² exactly (A² = −α/(γ d3))."""
    n = 2
    K3 = np.zeros((n,) * 4)
    D3 = np.zeros((n,) * 4)
    for i in range(n):
        for a in range(n):
            D3[i, a, a, i] = d3
            for b in range(n):
                for c in range(n):
                    K3[i, a, b, c] = k3 / 3 * ((a == b) * (c == i) + (a == c) * (b == i)
                                               + (b == c) * (a == i))
    eye = np.eye(n)
    return NonlinearROM(eye, W * W * eye, K3=K3, D1=0 * eye, D3=D3, outputs={"q1": [1.0, 0.0]})


def circle_start(A: float, w: float, offset: float = 0.02) -> OrbitStart:
    """A start off the circle (radius, phase and period perturbed)."""
    return OrbitStart(torch.tensor([[A * (1 + offset), offset]]),
                      torch.tensor([[0.0, A * w * (1 - offset)]]), torch.zeros(1, 0),
                      torch.tensor([2 * math.pi / w * (1 + offset / 2)]))


@pytest.mark.parametrize("alpha, d3, stable", [(-0.5, 0.5, False), (0.5, -0.5, False)])
def test_rotating_orbit_closed_form(alpha, d3, stable):
    """Amplitude exact: the circle |q| = A is invariant under the trapezoidal map too (checked
    to 1e-6: the amplitude is read from N samples with a parabola through the peak, which
    leaves ≈ (2π/N)⁴/8 ≈ 1e-7 at N = 128). The period's error is the Newmark rule's
    O((ωh)²): Richardson on N = 128 and 256 steps leaves 1e-6 of the closed form (the
    extrapolated error is O(h⁴) ≈ 1e-8). Both orbits are unstable: the subcritical one
    radially (a multiplier > 1), the supercritical one to elliptic deformations of the circle
    (the 1:1 resonant pair); the trivial multiplier is 1."""
    rom = rotating_oscillators(d3)
    system = CaseSystem.build(rom, 1, alpha=alpha, gamma=1.0)
    A = math.sqrt(-alpha / d3)
    w = math.sqrt(W**2 + A**2)
    T = {}
    for N in (128, 256):
        r = shoot(system, circle_start(A, w), [1.0, 0.0],
                  options=ShootingOptions(dt=2 * math.pi / w / N))
        assert r.converged.all() and r.iterations[0] <= 6
        assert abs(r.amplitude[0, 0] / A - 1) < 1e-6
        assert r.trivial_error[0] < 1e-6
        assert r.stable[0] is stable and r.critical_multiplier[0] > 1.05
        T[N] = float(r.period[0])
    T_extrapolated = T[256] + (T[256] - T[128]) / 3
    assert abs(T_extrapolated * w / (2 * math.pi) - 1) < 1e-6
    assert 1e-6 < abs(T[256] * w / (2 * math.pi) - 1) < (w * T[256] / 256) ** 2 / 12 * 1.01


def test_van_der_pol_multipliers_match_liouville_and_floquet():
    """One Van der Pol–Duffing mode: the multipliers' product is exp(−∫(c + d3 q²) dt)
    (Liouville) with one of them 1, so the critical one is that exponential (evaluated on the
    HB orbit, a second method). The discrete map's multipliers differ from the flow's by
    O((ωh)²) ≈ 1.5e-4 at 512 steps per period: tolerance 5e-4. Two cases of different period
    share the batch (each takes its own N)."""
    rom = van_der_pol_duffing(1.0, c1=-0.05, d3=0.4, k3=1.0)
    system = CaseSystem.build(rom, 2, alpha=[0.0, 0.02], gamma=1.0)
    orb = solve_orbits(system, [1.0])
    start = start_from_fourier(system, orb.X, orb.omega, [1.0])
    T = 2 * math.pi / orb.omega.numpy()
    r = shoot(system, start, [1.0], options=ShootingOptions(dt=float(T.min()) / 512))
    assert r.converged.all()
    tau = torch.linspace(0, 2 * math.pi, 2049, dtype=torch.float64)[:-1]
    H = (orb.X.shape[1] - 1) // 2
    q = orb.X[:, 0, 0][:, None] + sum(orb.X[:, 2 * k - 1, 0][:, None] * torch.cos(k * tau)
                                      + orb.X[:, 2 * k, 0][:, None] * torch.sin(k * tau)
                                      for k in range(1, H + 1))
    expected = np.exp(-(np.array([-0.05, -0.03]) + 0.4 * (q**2).mean(1).numpy()) * T)
    assert np.allclose(r.critical_multiplier, expected, rtol=5e-4)
    assert (r.trivial_error < 1e-4).all() and all(s is True for s in r.stable)
    # the amplitude of the discrete orbit vs HB's: O((ωh)²) apart
    assert np.allclose(r.amplitude[:, 0], orb.amplitude(torch.ones(1, 1))[:, 0], rtol=5e-4)


def test_shooting_matches_a_long_newmark_run():
    """The simulator at the same step converges to the discrete orbit: a strongly attracting
    Van der Pol–Duffing LCO run until its amplitude changes by < 1e-6 per cycle (the peak
    reading's own floor is ~1e-7) agrees
    with shooting at h = T/N to 1e-5 (the step differs from the simulator's dt by < 1/(2N)
    relative; its effect on the amplitude is O((ωh)²/N) ≈ 1e-7)."""
    rom = van_der_pol_duffing(1.0, c1=-0.6, d3=1.0, k3=2.0)
    system = CaseSystem.build(rom, 1, alpha=0.0, gamma=1.0)
    dt = 5e-3
    res = Newmark(dt=dt, iterations=4, predictor="quadratic").run(
        system, [0.5], t_end=200.0, outputs=["sum"], lco=LCOCriteria(rtol=1e-6, cycles=4))
    assert res.status[0] == "lco"
    T = 1 / res.frequency_hz[0]
    start = OrbitStart(torch.as_tensor(res.q), torch.as_tensor(res.v), torch.zeros(1, 0),
                       torch.tensor([T]))
    r = shoot(system, start, [1.0], options=ShootingOptions(dt=dt))
    assert r.converged.all()
    assert abs(r.amplitude[0, 0] / res.amplitude[0, 0] - 1) < 1e-5
    assert abs(r.frequency_hz[0] / res.frequency_hz[0] - 1) < 1e-5
    assert r.first_amplitude_correction[0] < 1e-5


def test_unstable_and_stable_orbits_of_the_subcritical_oscillator():
    """The quintic-damping oscillator at α = 0 has an unstable LCO beside a stable one; by
    first-order averaging c1 + d3 A²/4 + κ d5 A⁴/8 = 0 (κ = 1.043 for the slaved mode,
    :func:`~torchrom.rom.analytic.quintic_damping_oscillator`): A = 1.0074 and 1.944, exact to
    first order in the damping (the neglected terms grow with the amplitude's damping
    coefficients, ~2 % at A = 2: tolerance 3 %). Newton converges to either from
    a plain harmonic start (the slave on its manifold q2 = −ε q1²), and the monodromy says
    which is unstable."""
    rom = quintic_damping_oscillator()
    system = CaseSystem.build(rom, 2, alpha=0.0, gamma=1.0)
    eps = 0.05
    A0 = np.array([1.0, 2.0])
    start = OrbitStart(torch.tensor(np.stack([A0, -eps * A0**2], 1)), torch.zeros(2, 2),
                       torch.zeros(2, 0), torch.tensor([0.5, 0.5]))
    r = shoot(system, start, rom.outputs["q1"], options=ShootingOptions(dt=0.5 / 512))
    assert r.converged.all()
    assert list(r.stable) == [False, True]
    assert np.allclose(r.amplitude[:, 0], [1.0074, 1.944], rtol=3e-2)
    assert (r.trivial_error < 1e-4).all()


def test_a_bad_case_never_spoils_the_others():
    """A NaN start is marked and dropped; the other case converges to the same orbit as alone."""
    rom = van_der_pol_duffing(1.0, c1=-0.6, d3=1.0, k3=2.0)
    system = CaseSystem.build(rom, 2, alpha=0.0, gamma=1.0)
    good = OrbitStart(torch.tensor([[1.5]]), torch.tensor([[0.0]]), torch.zeros(1, 0),
                      torch.tensor([0.9]))
    both = OrbitStart(torch.tensor([[1.5], [math.nan]]), torch.tensor([[0.0], [0.0]]),
                      torch.zeros(2, 0), torch.tensor([0.9, 0.9]))
    alone = shoot(system.select([0]), good, [1.0], options=ShootingOptions(dt=0.9 / 128))
    pair = shoot(system, both, [1.0], options=ShootingOptions(dt=0.9 / 128))
    assert alone.converged[0] and pair.converged.tolist() == [True, False]
    assert pair.amplitude[0, 0] == pytest.approx(alone.amplitude[0, 0], rel=1e-12)
    assert np.isnan(pair.amplitude[1, 0]) and pair.stable[1] is None


def test_a_far_start_is_relaxed_along_its_trajectory_first():
    """A start 3 % off the Van der Pol–Duffing orbit (first scaled correction 0.28, above
    ``relax_above`` = 0.2): with ``relax_periods`` it is moved two periods along its
    trajectory before Newton, without it Newton starts there; both reach the same discrete
    orbit: the period to 1e-8 (the tolerance is 1e-9), the amplitude to 1e-5 (read from 128
    samples whose phase differs with the section: a parabola through the peak leaves
    ~(2π/N)⁴/8 ≈ 1e-6). A start within ``relax_above`` (first correction 0.13) is not
    relaxed: the same iterations either way."""
    rom = van_der_pol_duffing(1.0, c1=-0.6, d3=1.0, k3=2.0)
    system = CaseSystem.build(rom, 1, alpha=0.0, gamma=1.0)
    runs = {}
    for q0 in (1.5, 2.0):
        start = OrbitStart(torch.tensor([[q0]]), torch.tensor([[0.0]]), torch.zeros(1, 0),
                           torch.tensor([0.9]))
        for periods in (0, 2):
            runs[q0, periods] = shoot(system, start, [1.0], options=ShootingOptions(
                dt=0.9 / 128, relax_periods=periods, relax_above=0.2))
    assert all(r.converged[0] for r in runs.values())
    far, near = runs[1.5, 0], runs[2.0, 0]
    assert far.first_correction[0] > 0.2 > near.first_correction[0]
    assert runs[1.5, 2].amplitude[0, 0] == pytest.approx(far.amplitude[0, 0], rel=1e-5)
    assert runs[1.5, 2].frequency_hz[0] == pytest.approx(far.frequency_hz[0], rel=1e-8)
    assert [r.relaxed[0] for r in runs.values()] == [False, True, False, False]
    assert runs[2.0, 2].iterations[0] == near.iterations[0]


def test_bad_options():
    from torchrom.errors import InputError

    with pytest.raises(InputError, match="shooting.dt"):
        ShootingOptions(dt=-1.0)
    with pytest.raises(InputError, match="implicit Newmark"):
        ShootingOptions(beta=0.0)
    with pytest.raises(InputError, match="shooting.relax_periods"):
        ShootingOptions(relax_periods=-1)


def test_accept_against_the_richardson_extrapolation():
    """``OrbitStart.coarse_amplitude`` (the discrete orbit's amplitude at 2h): ``accept``
    compares the reported amplitude with the Richardson extrapolation (4 A(h) − A(2h))/3
    instead of A(h). A start reporting that extrapolation (from its own evaluations at h and
    2h, 64 steps per period, where it lies 1.6e-4 from A(h)) is accepted after one evaluation
    with the coarse amplitude and iterated to the discrete orbit without it."""
    rom = van_der_pol_duffing(1.0, c1=-0.6, d3=1.0, k3=2.0)
    system = CaseSystem.build(rom, 1, alpha=0.0, gamma=1.0)
    orb = solve_orbits(system, [1.0])
    start = start_from_fourier(system, orb.X, orb.omega, [1.0])
    dt = float(2 * math.pi / orb.omega[0]) / 64
    a = {}
    for h in (dt, 2 * dt):
        r = shoot(system, start, [1.0], options=ShootingOptions(dt=h, max_iterations=0))
        a[h] = r.start_amplitude * (1 + r.first_amplitude_correction)
    reported = torch.as_tensor((4 * a[dt] - a[2 * dt]) / 3)
    assert abs(float(reported[0] / a[dt][0]) - 1) > 1e-4
    options = ShootingOptions(dt=dt, accept=5e-5)
    alone = shoot(system, OrbitStart(start.q, start.v, start.xi, start.period, reported),
                  [1.0], options=options)
    assert not alone.accepted[0] and alone.converged[0] and alone.iterations[0] >= 1
    both = shoot(system, OrbitStart(start.q, start.v, start.xi, start.period, reported,
                                    torch.as_tensor(a[2 * dt])), [1.0], options=options)
    assert both.accepted[0] and both.iterations[0] == 0 and both.stable[0] is True
