"""Branches of periodic orbits from the Hopf point (torchrom.periodic.continuation): the
subcritical quintic-damping oscillator against its closed form."""

from __future__ import annotations

import cmath
import math

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.periodic import BranchOptions, follow_branches, hopf_points
from torchrom.rom.analytic import quintic_damping_oscillator
from torchrom.sim import CaseSystem

SCALE = 0.1  # c1, d3, d5 = 0.1, −0.5, 0.2: damping ≪ ω, where first-order averaging holds


def _kappa(frequency_hz=2.0, slave_hz=20.0, zeta=0.5):
    """The slaved mode's factor on the quintic term (rom.analytic.quintic_damping_oscillator)."""
    r = 2 * frequency_hz / slave_hz
    h = 1 / complex(1 - r**2, 2 * zeta * r)
    return 2 + abs(h) ** 2 - 2 * abs(h) * math.cos(cmath.phase(h))


@pytest.fixture(scope="module")
def branch():
    rom = quintic_damping_oscillator(c1=1.0 * SCALE, d3=-5.0 * SCALE, d5=2.0 * SCALE)

    def builder(p, branches):
        return CaseSystem.build(rom, len(p), alpha=np.asarray(p, float), gamma=1.0)

    opts = BranchOptions(bounds=(-1.5 * SCALE, 1.0 * SCALE), max_step=0.3)
    return rom, builder, follow_branches(builder, 1, rom.outputs["q1"], opts)


def test_hopf_point_is_where_the_net_linear_damping_vanishes(branch):
    rom, builder, br = branch
    hop = br.hopf[0]
    assert hop["found"] and hop["unstable_below"]
    assert hop["parameter"] == pytest.approx(-1.0 * SCALE, rel=1e-9)
    assert hop["frequency_hz"] == pytest.approx(2.0, rel=1e-6)


def test_fold_and_unstable_branch_against_averaging(branch):
    """Averaging: net damping (α + c1) + d3 A²/4 + κ d5 A⁴/8 = 0. The fold (its extremum in
    α) and the amplitudes of the unstable branch between the Hopf point and the fold must be
    within 1 % (the closed form is the small-damping limit; at this scale it differs from the
    exact orbits by ~0.4 % at the fold)."""
    rom, builder, br = branch
    k = _kappa()
    c1, d3, d5 = 1.0 * SCALE, -5.0 * SCALE, 2.0 * SCALE
    x_fold = -d3 / (k * d5)
    alpha_fold = -c1 - d3 * x_fold / 4 - k * d5 * x_fold**2 / 8
    folds = [p.fold for p in br.points[0] if p.fold is not None]
    assert len(folds) == 1
    assert folds[0][0] == pytest.approx(alpha_fold, rel=1e-2)
    assert folds[0][1] == pytest.approx(math.sqrt(x_fold), rel=1e-2)
    pts = [p for p in br.points[0] if p.kind != "hopf"]
    stable = br.stable[0]
    checked = 0
    for p, s in zip(pts, stable):
        A = abs(float(p.X[1, 0]))
        if s or A < 0.3:
            continue
        # the small root of the quadratic in x = A² at this α
        a, b, c = k * d5 / 8, d3 / 4, p.parameter + c1
        x = (-b - math.sqrt(b * b - 4 * a * c)) / (2 * a)
        assert A == pytest.approx(math.sqrt(x), rel=1e-2)
        checked += 1
    assert checked >= 3
    # stable beyond the fold, unstable before it
    amps = np.array([abs(float(p.X[1, 0])) for p in pts])
    assert not stable[amps < 0.95 * folds[0][1]].any()
    assert stable[amps > 1.05 * folds[0][1]].all()


def test_no_hopf_point_in_the_bounds():
    rom = quintic_damping_oscillator()

    def builder(p, branches):
        return CaseSystem.build(rom, len(p), alpha=np.asarray(p, float), gamma=1.0)

    hop = hopf_points(builder, 1, (0.0, 1.0))
    assert not hop["found"][0]
    br = follow_branches(builder, 1, rom.outputs["q1"], BranchOptions(bounds=(0.0, 1.0)))
    assert br.points == [[]]
    with pytest.raises(InputError, match="bounds"):
        BranchOptions(bounds=(1.0, 0.0))
