"""Labelled flutter crossings (torchrom.aero.crossings) on a case with a closed-form answer.

Two uncoupled modes (b = 1, ρ = 1, unit modal masses) with aerodynamics Q_jj(k) = i k d_j(k), no
aerodynamic stiffness. The p-k root of mode j solves s² + q (b/V) d_j(k) s + ω_j² = 0, so
Re s = -ρ V b d_j(k)/4 changes sign exactly where d_j(k) does, and there Im s = ω_j, i.e. at the
speed V = ω_j b / k of each zero k of d_j:

* mode 1 (ω = 10 rad/s): d = A (k - k1)(k - k2) is negative between k1 = 10/56 and k2 = 10/51: a
  hump from V = 51 to V = 56, between two sweep speeds (50, 60): no sample is unstable, so sign
  checks miss it; the samples' negative maximum at 50 (g = -0.0042) is probed;
* mode 2 (ω = 30 rad/s): d = A2 (k - k3), k3 = 30/77.7, negative for k < k3: unstable from
  V = 77.7 to the end of the range (sustained).

Tolerance 1e-6 relative: the p-k iteration stops at a relative change of k of 1e-7 and Brent's
method at 1e-9 of the speed.
"""

import numpy as np
import pytest

from torchrom.aero.crossings import pk_crossings, rigid_body_modes
from torchrom.aero.flutter import HUMP, SUSTAINED, AeroTable, ModalStructure, pk_sweep

W1, W2 = 10.0, 30.0
K1, K2, K3 = W1 / 56.0, W1 / 51.0, W2 / 77.7
A1 = 20.0  # ρ b A1 / (2 ω1) = 1: g = -V (k - k1)(k - k2) near the hump, +0.004 at its peak
A2 = 0.5


def _case():
    structure = ModalStructure(np.eye(2), np.diag([W1**2, W2**2]))

    def q(k):
        return np.diag([1j * k * A1 * (k - K1) * (k - K2), 1j * k * A2 * (k - K3)])

    return structure, AeroTable.from_function(q, 1.0)


@pytest.mark.parametrize("speeds", [np.arange(30.0, 101.0, 10.0), np.arange(30.0, 101.0, 7.0)],
                         ids=["step 10", "step 7"])
def test_hump_between_samples_and_sustained_crossing_closed_form(speeds):
    structure, aero = _case()
    sweep = pk_sweep(structure, aero, speeds, 1.0, eps=1e-9)
    # the samples of mode 1 never go unstable (step 7 puts one on the onset, V = 51, where g
    # is 0 to round-off): a sign check sees no crossing there
    assert np.all(sweep.damping[:, 0] < 1e-12)
    assert [p.mode for p in sweep.crossings()] == [1]
    found = pk_crossings(structure, aero, sweep, eps=1e-9)
    assert found.rigid_body == []
    hump, sustained = found.flutter
    assert hump.kind == HUMP and hump.mode == 0 and hump.refined
    assert hump.velocity == pytest.approx(W1 / K2, rel=1e-6)
    assert hump.stable_velocity == pytest.approx(W1 / K1, rel=1e-6)
    assert hump.frequency_hz == pytest.approx(W1 / (2 * np.pi), rel=1e-6)
    assert hump.stable_frequency_hz == pytest.approx(W1 / (2 * np.pi), rel=1e-6)
    assert sustained.kind == SUSTAINED and sustained.mode == 1 and sustained.refined
    assert sustained.velocity == pytest.approx(W2 / K3, rel=1e-6)
    assert sustained.stable_velocity is None
    assert sustained.k == pytest.approx(K3, rel=1e-6)
    rec = sustained.as_dict()
    assert rec["kind"] == "sustained" and rec["mode"] == 2 and rec["stable_velocity"] is None


def test_speeds_listed_twice_probe_between_distinct_speeds_once():
    """Speeds 50 and 60 listed more than once (BAH_Plane lists each speed twice, 0.01 apart):
    the hump between 50 and 60 is probed between the distinct neighbouring speeds and listed
    once."""
    structure, aero = _case()
    sweep = pk_sweep(structure, aero, [40.0, 50.0, 50.0, 50.0, 60.0, 60.0, 80.0], 1.0,
                     eps=1e-9)
    hump, sustained = pk_crossings(structure, aero, sweep, eps=1e-9).flutter
    assert hump.kind == HUMP and hump.velocity == pytest.approx(W1 / K2, rel=1e-6)
    assert hump.stable_velocity == pytest.approx(W1 / K1, rel=1e-6)
    assert sustained.velocity == pytest.approx(W2 / K3, rel=1e-6)


def test_a_hump_that_straddles_samples_is_refined_on_both_sides():
    """Speeds 50, 53, 57, 60: the hump (51 to 56) has samples inside it; the linear crossings
    of the samples are moved to the closed-form speeds."""
    structure, aero = _case()
    sweep = pk_sweep(structure, aero, [45.0, 50.0, 53.0, 57.0, 60.0], 1.0, eps=1e-9)
    (linear,) = sweep.crossings()
    assert linear.kind == HUMP and not linear.refined
    (hump,) = pk_crossings(structure, aero, sweep, eps=1e-9).flutter
    assert hump.velocity == pytest.approx(W1 / K2, rel=1e-6)
    assert hump.stable_velocity == pytest.approx(W1 / K1, rel=1e-6)
    assert abs(linear.velocity - W1 / K2) > 1e-3  # what the refinement corrected


def test_rigid_body_roots_are_apart():
    """A branch marked rigid keeps its crossing (linear: a rigid root is not refined nor
    probed) out of the flutter points; the rigid-body modes are those below 1e-3 of the lowest
    elastic frequency (bah_plane's basis: two 0 Hz modes, the lowest elastic one 2.454 Hz;
    round-off rigid modes of 1e-7 Hz too)."""
    structure, aero = _case()
    sweep = pk_sweep(structure, aero, [45.0, 50.0, 53.0, 57.0, 60.0, 80.0], 1.0, eps=1e-9)
    found = pk_crossings(structure, aero, sweep, rigid=[True, False], eps=1e-9)
    assert [p.mode for p in found.flutter] == [1]
    (rigid,) = found.rigid_body
    assert rigid.mode == 0 and rigid.rigid_body and rigid.kind == HUMP and not rigid.refined
    assert rigid_body_modes([0.0, 0.0, 2.454, 3.754, 56.6]).tolist() == [1, 1, 0, 0, 0]
    assert rigid_body_modes([4.8e-7, 2.454, 9.0]).tolist() == [1, 0, 0]
    assert rigid_body_modes([2.454, 9.0]).tolist() == [0, 0]
