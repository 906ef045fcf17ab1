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


# -- the damping tolerance: noise, divergence and flutter (issue 46) -------------------------


def _synthetic_sweep(tol_noise: float = 2.4e-4):
    """Three p-k branches over V = 100..500 (b = 1): a mode the aerodynamics hardly load, its
    g wobbling within ±``tol_noise`` with sign changes (the swept wingbox's chordwise mode:
    ±2.4e-4); a flutter crossing, g linear from -0.06 to +0.02 (zero at V = 400); a real root
    (Im s = 0), Nastran's g = 2 s b / (V ln 2) from -0.01 to +0.01 (zero at V = 300)."""
    from torchrom.aero.flutter import ModeSweep

    v = np.linspace(100.0, 500.0, 9)
    noise = tol_noise * np.array([-1.0, 0.9, -0.6, 1.0, -1.0, 0.8, -0.3, 0.7, 1.0])
    flutter = np.linspace(-0.06, 0.02, 9)
    real = np.linspace(-0.01, 0.01, 9)
    w1, w2 = 2 * np.pi * 14.0, 2 * np.pi * 3.0
    s = np.c_[0.5 * noise * w1 + 1j * w1, 0.5 * flutter * w2 + 1j * w2,
              real * v * np.log(2.0) / 2.0 + 0j]
    g = np.c_[noise, flutter, real]
    k = np.abs(s.imag) / v[:, None]
    return ModeSweep("PK", v, np.full(9, 1.2), s, k, g)


def test_noise_within_the_tolerance_is_no_flutter_row_and_a_real_root_is_divergence():
    """The rules of torchrom.aero.crossings on synthetic g curves (linear interpolation, exact
    here: g is linear between samples): at the default tolerance (1e-3) the wobbling branch
    gives no row and is listed as not loaded, the real root's crossing is a divergence at
    V = 300 (never flutter), the oscillatory crossing is the one flutter point at V = 400. At a
    tolerance below the wobble (1e-5) the same wobble gives crossings: the rule is what keeps
    them out."""
    from torchrom.aero.crossings import split_rigid
    from torchrom.aero.flutter import G_TOLERANCE

    sweep = _synthetic_sweep()
    assert G_TOLERANCE == 1e-3
    found = split_rigid(sweep.crossings(), [False, False, False], sweep)
    (flutter,) = found.flutter
    assert flutter.mode == 1 and flutter.velocity == pytest.approx(400.0, rel=1e-12)
    assert not flutter.divergence and flutter.frequency_hz == pytest.approx(3.0, rel=1e-12)
    (div,) = found.divergence
    assert div.mode == 2 and div.divergence and div.velocity == pytest.approx(300.0, rel=1e-12)
    assert div.frequency_hz == 0.0 and div.as_dict()["divergence"] is True
    assert found.not_loaded == [0] and found.g_tolerance == G_TOLERANCE
    noisy = split_rigid(sweep.crossings(1e-5), [False, False, False], sweep, 1e-5)
    assert {p.mode for p in noisy.flutter} == {0, 1} and noisy.not_loaded == []
    # a wobble beyond the tolerance is a loaded mode (its crossings count)
    loud = _synthetic_sweep(tol_noise=2e-3)
    assert 0 in {p.mode for p in loud.crossings()} and loud.not_loaded() == []


def test_a_real_root_near_zero_is_not_an_unloaded_mode():
    """A branch whose root is real (k at the p-k floor) has Nastran's small g = 2 s b /
    (V ln 2) of a root near s = 0 (bah_plane's FLUTTER 501 at 4,774 m/s: |g| <= 5e-8): its root
    left the imaginary axis, so it is loaded, not "not loaded"."""
    from torchrom.aero.flutter import ModeSweep

    v = np.array([4774.0, 4815.0, 4856.0])
    s = np.array([[3.6e-5 + 0j], [-1.1e-7 + 0j], [2.9e-8 + 0j]])
    g = 2 * s.real * 2.0 / (v[:, None] * np.log(2.0))
    sweep = ModeSweep("PK", v, np.full(3, 1.225), s, np.full((3, 1), 1e-4), g, semichord=2.0)
    assert np.all(np.abs(g) < 1e-7) and sweep.not_loaded() == []


def _lightly_loaded_case(eps: float):
    """:func:`_case` with a third uncoupled mode (ω = 40 rad/s, the third branch) whose
    aerodynamic damping d = eps (k - 2/3) changes sign at k = 2/3, i.e. at V = 60:
    g = -ρ V b d / (2 ω) (closed form, as the module docstring's), |g| <= 0.34 eps on
    V = 30..100."""
    structure = ModalStructure(np.eye(3), np.diag([W1**2, W2**2, 1600.0]))

    def q(k):
        return np.diag([1j * k * A1 * (k - K1) * (k - K2), 1j * k * A2 * (k - K3),
                        1j * k * eps * (k - 2.0 / 3.0)])

    return structure, AeroTable.from_function(q, 1.0)


def test_a_mode_the_aerodynamics_hardly_load_is_listed_not_flagged():
    """p-k (refined crossings): the third mode's damping crosses zero at V = 60 exactly but
    stays within ±5.1e-4 (eps = 1.5e-3): at the default tolerance no row, listed as not
    loaded, while the hump and the sustained crossing of the other modes are found as before
    (1e-6). At a tolerance of 1e-9 its crossing is a flutter row at V = 60 (1e-6: Brent on
    Re s of the branch): the noise the tolerance removes."""
    structure, aero = _lightly_loaded_case(1.5e-3)
    speeds = np.arange(30.0, 101.0, 10.0)
    sweep = pk_sweep(structure, aero, speeds, 1.0, eps=1e-9)
    assert np.abs(sweep.damping[:, 2]).max() <= 5.1e-4
    found = pk_crossings(structure, aero, sweep, eps=1e-9)
    assert [p.mode for p in found.flutter] == [0, 1] and found.not_loaded == [2]
    assert found.flutter[0].velocity == pytest.approx(W1 / K2, rel=1e-6)
    assert found.divergence == []
    strict = pk_crossings(structure, aero, sweep, eps=1e-9, tol=1e-9)
    (noise,) = [p for p in strict.flutter if p.mode == 2]
    assert noise.velocity == pytest.approx(60.0, rel=1e-6) and strict.not_loaded == []


def test_divergence_of_a_real_root_is_reported_with_its_speed_closed_form():
    """One mode (ω = 10 rad/s) with aerodynamic stiffness -c and damping d:
    Q(k) = -c + i k d, b = 1, ρ = 1. The p-k root solves s² + q (b/V) d s + ω² - q c = 0: its
    pair turns real and one root passes through s = 0 where q c = ω², V_D = √(2 ω² / (ρ c)).
    Nastran's real-root damping keeps the crossing; it is a divergence at V_D (1e-6: Brent on
    Re s), never a flutter point."""
    c, d = 2.0, 0.05
    structure = ModalStructure(np.eye(1), np.diag([100.0]))
    aero = AeroTable.from_function(lambda k: np.array([[-c + 1j * k * d]]), 1.0)
    v_d = np.sqrt(2 * 100.0 / c)
    sweep = pk_sweep(structure, aero, np.linspace(0.5, 1.5, 11) * v_d, 1.0, eps=1e-9,
                     real_root_damping="nastran")
    found = pk_crossings(structure, aero, sweep, eps=1e-9)
    assert found.flutter == []
    (div,) = found.divergence
    assert div.velocity == pytest.approx(v_d, rel=1e-6) and div.frequency_hz == 0.0
    assert div.refined and div.divergence
