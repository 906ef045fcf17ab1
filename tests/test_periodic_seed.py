"""Orbits seeded by a short time integration (torchrom.periodic.seed)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from torchrom.periodic import HBOptions, solve_orbits
from torchrom.periodic.seed import SEED_HARMONICS, seed_unresolved, seeded_orbits, unresolved
from torchrom.rom.analytic import van_der_pol_duffing
from torchrom.sim import CaseSystem


def _coupled():
    """The coupled three-mode VdP–Duffing ROM of test_periodic_solve (Newmark-checked there)."""
    rom = van_der_pol_duffing([1.0, 2.3, 4.1], c1=[-0.6, 0.05, 0.1], d3=1.0, k3=[8.0, 0, 0],
                              coupling=[[0, 6, 0], [6, 0, 6], [0, 6, 0]])
    return CaseSystem.build(rom, 2, alpha=[0.1, 0.3], gamma=1.0)


def test_unresolved_cases():
    opts = HBOptions()
    status = np.array(["lco", "lco", "lco", "unconverged", "decay", "diverged"], dtype=object)
    change = np.array([1e-4, 1e-2, np.nan, np.nan, np.nan, np.nan])
    trunc = np.array([1e-5, 1e-5, 1e-5, np.nan, np.nan, np.nan])
    assert unresolved(status, change, trunc, opts).tolist() == [False, True, True, True, False,
                                                                False]


def test_seeded_orbit_is_the_ladders_orbit():
    """From no orbit at all (a cold start at H = 5, the time integration, then the ladder from
    H = 15): the same orbits as the harmonic ladder's (amplitude 2e-5, frequency 1e-6: the
    ladder's orbit is accepted at H ≤ 9 and carries its truncation error, measured 4e-6 in
    amplitude; it is Newmark-checked to 1e-3 in test_periodic_solve), accepted at the first H
    with a measured change."""
    system = _coupled()
    r = torch.ones(3, dtype=torch.float64)
    ref = solve_orbits(system, r.numpy())
    s = seeded_orbits(system, r, None, None, np.zeros(2, dtype=bool), HBOptions())
    assert list(s.status) == ["lco", "lco"] and s.accepted.all()
    assert (s.harmonics == SEED_HARMONICS[1]).all()
    amp = ref.amplitude(r[None])[:, 0]
    from torchrom.periodic.solve import orbit_amplitude

    seeded_amp = orbit_amplitude(s.X @ r[:, None], s.status, 512)[:, 0]
    assert seeded_amp == pytest.approx(amp, rel=2e-5)
    assert (s.omega / (2 * math.pi)).numpy() == pytest.approx(ref.frequency_hz, rel=1e-6)


def test_seed_replaces_only_unresolved_cases():
    """A case the ladder left unaccepted (here: a tolerance on the amplitude change no H up
    to 9 can meet) is re-solved from its time-integration seed and marked; with H fixed by
    the user (max_harmonics = harmonics) nothing is seeded."""
    system = _coupled()
    r = torch.ones(3, dtype=torch.float64)
    tight = HBOptions(amplitude_rtol=1e-13, residual_tol=1e-3)
    orb = solve_orbits(system, r.numpy(), tight)
    assert unresolved(orb.status, orb.amplitude_change, orb.truncation, tight).all()
    before = orb.amplitude(r[None])[:, 0]
    after, seeded = seed_unresolved(system, r, orb, tight, "unresolved")
    assert seeded.all() and (after.harmonics >= SEED_HARMONICS[0]).all()
    assert after.amplitude(r[None])[:, 0] == pytest.approx(before, rel=2e-5)
    fixed = HBOptions(start_harmonics=5, harmonics=5, max_harmonics=5, amplitude_rtol=1e-13)
    orb = solve_orbits(system, r.numpy(), fixed)
    _, seeded = seed_unresolved(system, r, orb, fixed, "unresolved")
    assert not seeded.any()
