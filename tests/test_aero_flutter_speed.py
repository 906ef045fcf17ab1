"""Flutter speed at a fixed density (Mach 0 aerodynamics), torchrom.aero.flutter_speed.

Independent reference: the classical flutter determinant of Hodges & Pierce's typical section
(tests/test_aero_flutter.py; U_F = 2.18391 b ω_α, ω_F = 0.64898 ω_α at μ = 20), with its exact
Theodorsen GAFs tabulated at Mach 0 and the mass set for μ = 20 at 10,000 ft (USSA-76). p-k is
exact at zero damping: 1e-4 (the GAF table interpolated in k); the state space on the 8-lag
RFA: 0.5 % (its fit error).
"""

import numpy as np
import pytest

from torchrom.aero.atmosphere import atmosphere
from torchrom.aero.dlm import GAF
from torchrom.aero.flutter import AeroTable, ModalStructure
from torchrom.aero.flutter_speed import flutter_speed_pk, flutter_speed_state_space, speed_range
from torchrom.aero.rfa import fit_minimum_state
from torchrom.aero.theodorsen import TypicalSection

from .test_aero_flutter import HP


def test_flutter_speed_at_mach_0_is_the_classical_one():
    b, w_a, alt = 3.0, 100.0, 10000.0
    rho = float(atmosphere(alt, "ft").density)
    ts = TypicalSection(b, HP["a"], HP["x_alpha"], HP["r_alpha_sq"],
                        HP["mu"] * np.pi * rho * b**2, HP["sigma"] * w_a, w_a)
    st = ModalStructure(ts.mass_matrix(), ts.stiffness_matrix())
    k = np.r_[0.0, np.geomspace(0.005, 2.0, 40)]
    gaf = GAF(0.0, b, k, ts.gaf(k))
    table = AeroTable.from_gaf(gaf)
    lo, hi = speed_range(st, table)
    # V = ω b / k over the table: the lowest in-vacuo ω at k = 2, the highest at k = 0.005
    w = 2 * np.pi * st.natural_frequencies_hz()
    assert (lo, hi) == pytest.approx((w[0] * b / 2.0, w[-1] * b / 0.005), rel=1e-12)
    pk, sweep = flutter_speed_pk(st, table, alt)
    assert pk.velocity == pytest.approx(2.18391 * b * w_a, rel=1e-4)
    assert 2 * np.pi * pk.frequency_hz == pytest.approx(0.64898 * w_a, rel=1e-4)
    assert pk.kind == "sustained" and pk.density == pytest.approx(rho)
    assert sweep.velocity[0] == pytest.approx(lo) and sweep.velocity[-1] == pytest.approx(hi)
    ss = flutter_speed_state_space(st, fit_minimum_state(gaf, n_lags=8), table, alt)
    assert ss.velocity == pytest.approx(pk.velocity, rel=5e-3)
    assert ss.as_dict()["dynamic_pressure"] == pytest.approx(0.5 * rho * ss.velocity**2)


def test_rigid_body_roots_are_never_the_flutter_speed():
    """A free aircraft at Mach 0 (:func:`tests._aero_fakes.rigid_and_elastic`: uncoupled rigid
    and elastic modes, exact quasi-steady GAFs and RFA): at sea-level density the rigid root's
    damping crosses zero first, at V = 0.8/ρ, the elastic one at V = (8/7)/ρ with
    ω = 10 rad/s (closed form). Both methods give the elastic speed (p-k refined by Brent on
    its branch: 1e-6; the state space by Brent on the growth rate: 1e-6) and frequency (1e-6),
    and list the rigid root apart with its mode: p-k at its linearly interpolated crossing
    (between the sweep's samples around 0.8/ρ), the state space at the sample before it."""
    from ._aero_fakes import rigid_and_elastic

    structure, gaf, rfa = rigid_and_elastic(0.0)
    table = AeroTable.from_gaf(gaf)
    rho = float(atmosphere(0.0, "ft").density)
    pk, sweep = flutter_speed_pk(structure, table, 0.0)
    ss = flutter_speed_state_space(structure, rfa, table, 0.0)
    v = sweep.velocity
    rigid_v = 0.8 / rho
    i = int(np.searchsorted(v, rigid_v))  # v[i - 1] < rigid_v <= v[i]
    for r in (pk, ss):
        assert r.velocity == pytest.approx(8 / 7 / rho, rel=1e-6), r.method
        assert r.frequency_hz == pytest.approx(10 / (2 * np.pi), rel=1e-6), r.method
        ((j, at),) = r.rigid_body_crossings
        assert j == 0, r.method
        assert r.as_dict()["rigid_body_crossings"] == [{"mode": 1, "velocity": at}]
    assert v[i - 1] <= pk.rigid_body_crossings[0][1] <= v[i]
    assert ss.rigid_body_crossings[0][1] == v[i - 1]


def test_an_untouched_undamped_mode_is_no_state_space_flutter():
    """The free aircraft of :func:`tests._aero_fakes.rigid_and_elastic` with a third mode that
    neither the air nor the structure damps (ω = 20 rad/s, no GAF, no damping: Re s = ±1e-14,
    round-off, as bah_plane's 8.70 Hz mode at α = γ = 0). Its root's damping is within
    G_ROUNDOFF, so it is no flutter point: the state-space flutter speed stays the elastic
    crossing, (8/7)/ρ (1e-6), as p-k's (which applies the same rule)."""
    from torchrom.aero.dlm import GAF
    from torchrom.aero.flutter import ModalStructure
    from torchrom.aero.flutter_speed import flutter_speed_at_density
    from torchrom.aero.rfa import RFA

    structure = ModalStructure(np.eye(3), np.diag([0.0, 100.0, 400.0]),
                               C0=np.diag([0.1, 0.2, 0.0]))
    a0, a1 = np.diag([0.05, 0.0, 0.0]), np.diag([-0.25, -0.35, 0.0])
    k = np.r_[0.0, np.geomspace(1e-3, 2.0, 40)]
    table = AeroTable.from_gaf(GAF(0.0, 1.0, k, a0[None] + 1j * k[:, None, None] * a1[None]))
    rfa = RFA(a0, a1, np.zeros((3, 3)), np.zeros((3, 0)), np.zeros((0, 0)), np.zeros((0, 3)),
              np.zeros(0), "roger", 1.0, 0.0)
    rho = float(atmosphere(0.0, "ft").density)
    ss = flutter_speed_at_density(structure, rfa, table, rho)
    assert ss.velocity == pytest.approx(8 / 7 / rho, rel=1e-6)
    assert ss.frequency_hz == pytest.approx(10 / (2 * np.pi), rel=1e-6)
    pk, _ = flutter_speed_pk(structure, table, 0.0)
    assert pk.velocity == pytest.approx(ss.velocity, rel=1e-6)


def _uncoupled(c2: float, d2: float, a0=(0.0, 0.0), d1: float = -0.35, k_max: float = 20.0):
    """Two uncoupled unit-mass modes, ω = 10 and 20 rad/s, b = 1, quasi-steady aerodynamics
    Q(k) = A0 + i k A1 (exact in the table and in an RFA with no lag states), A1 =
    diag(d1, d2), structural damping C0 = diag(0.2, c2). Mode j's root solves
    s² + (c_j + ½ ρ V b A1_jj) s + ω_j² + q A0_jj = 0: its damping crosses zero where
    c_j = -½ ρ V A1_jj (mode 1 with d1 = -0.35: ρV = 8/7, k = 8.75 at ρ = 1). The table runs
    from k = 1e-3 to ``k_max``."""
    from torchrom.aero.rfa import RFA

    a0, a1 = np.diag(a0), np.diag([d1, d2])
    structure = ModalStructure(np.eye(2), np.diag([100.0, 400.0]), C0=np.diag([0.2, c2]))
    k = np.r_[0.0, np.geomspace(1e-3, k_max, 40)]
    table = AeroTable.from_gaf(GAF(0.0, 1.0, k, a0[None] + 1j * k[:, None, None] * a1[None]))
    rfa = RFA(a0, a1, np.zeros((2, 2)), np.zeros((2, 0)), np.zeros((0, 0)), np.zeros((0, 2)),
              np.zeros(0), "roger", 1.0, 0.0)
    return structure, table, rfa


def test_a_root_within_the_tolerance_is_no_flutter_by_either_method():
    """Mode 2 (ω = 20) with c2 = 0.004, A1 = -0.004: g = -(c2 - ½ ρ V 0.004)/ω crosses zero
    at ρV = 2 and stays within ±4e-4 over V = 1..6 at ρ = 1 (closed form). At the default
    tolerance neither method reports it: both give mode 1's crossing, V = 8/7 (1e-6; p-k by
    Brent on its branch, the state space by Brent on the root), and p-k lists mode 2 as not
    loaded; at a tolerance of 1e-9 it is loaded (its crossing counts)."""
    from torchrom.aero.flutter_speed import flutter_speed_at_density, flutter_speed_pk_at_density

    structure, table, rfa = _uncoupled(0.004, -0.004)
    pk, sweep = flutter_speed_pk_at_density(structure, table, 1.0, speeds=(1.0, 6.0))
    ss = flutter_speed_at_density(structure, rfa, table, 1.0, speeds=(1.0, 6.0))
    assert np.abs(sweep.damping[:, 1]).max() <= 4.1e-4
    for r in (pk, ss):
        assert r.velocity == pytest.approx(8 / 7, rel=1e-6), r.method
        assert r.frequency_hz == pytest.approx(10 / (2 * np.pi), rel=1e-6), r.method
        assert r.divergence_velocity is None and r.g_tolerance == 1e-3
    assert pk.not_loaded == [1] and pk.as_dict()["not_loaded_modes"] == [2]
    strict, _ = flutter_speed_pk_at_density(structure, table, 1.0, speeds=(1.0, 6.0),
                                            g_tolerance=1e-9)
    assert strict.not_loaded == []


def test_a_root_within_the_tolerance_does_not_mask_the_flutter_of_another():
    """Mode 2 slightly unstable over the whole range (c2 = 0, A1 = -0.004: g = +0.1 ρ V e-3,
    at most +6e-4 on V = 1..6): a criterion on the largest growth rate beyond round-off sees
    an unstable root from the first speed and no upward crossing, so mode 1's flutter at
    V = 8/7 is lost (shown at a tolerance of 1e-9); within the default tolerance the state
    space finds it (1e-6) and p-k too."""
    from torchrom.aero.flutter_speed import flutter_speed_at_density, flutter_speed_pk_at_density

    structure, table, rfa = _uncoupled(0.0, -0.004)
    ss = flutter_speed_at_density(structure, rfa, table, 1.0, speeds=(1.0, 6.0))
    assert ss.velocity == pytest.approx(8 / 7, rel=1e-6)
    pk, _ = flutter_speed_pk_at_density(structure, table, 1.0, speeds=(1.0, 6.0))
    assert pk.velocity == pytest.approx(8 / 7, rel=1e-6)
    masked = flutter_speed_at_density(structure, rfa, table, 1.0, speeds=(1.0, 6.0),
                                      g_tolerance=1e-9)
    assert masked.velocity is None


def test_divergence_is_reported_apart_by_both_methods():
    """Mode 2 with a negative aerodynamic stiffness, A0_22 = -100, and an aerodynamic
    damping A1_22 = 0.5 (mode 1 stable: A1_11 = +0.35): its stiffness 400 - 100 q vanishes at
    q = 4, V_D = √8 at ρ = 1 (closed form), where its pair has turned real and one root passes
    through s = 0. The p-k (Nastran's real-root damping; Brent on Re s of its branch) and the
    state space (where K + q A0 is singular, the pencil's eigenvalue) give V_D as a
    divergence (1e-6), no flutter."""
    from torchrom.aero.flutter_speed import flutter_speed_at_density, flutter_speed_pk_at_density

    structure, table, rfa = _uncoupled(0.0, 0.5, a0=(0.0, -100.0), d1=0.35)
    pk, _ = flutter_speed_pk_at_density(structure, table, 1.0, speeds=(2.0, 6.0))
    ss = flutter_speed_at_density(structure, rfa, table, 1.0, speeds=(2.0, 6.0))
    for r in (pk, ss):
        assert r.velocity is None, r.method
        assert r.divergence_velocity == pytest.approx(np.sqrt(8.0), rel=1e-6), r.method
    assert pk.divergence_mode == 1 and pk.as_dict()["divergence_mode"] == 2
    assert ss.as_dict()["divergence_velocity"] == ss.divergence_velocity


def test_a_p_k_crossing_beyond_the_table_is_not_flutter():
    """The same crossing as above (mode 1 at V = 8/7, k = 8.75) on a table that stops at
    k = 2: its Q there is extrapolated, so p-k lists it apart (mode, speed, k; the speed
    still solved, 1e-6: this Q is linear in k and its spline's extrapolation exact) and gives
    no flutter point."""
    from torchrom.aero.flutter_speed import flutter_speed_pk_at_density

    structure, table, _ = _uncoupled(0.004, 0.1, k_max=2.0)
    pk, _ = flutter_speed_pk_at_density(structure, table, 1.0, speeds=(0.5, 6.0))
    assert pk.velocity is None
    ((j, v, k),) = pk.extrapolated_crossings
    assert j == 0 and v == pytest.approx(8 / 7, rel=1e-6) and k == pytest.approx(8.75, rel=1e-6)
    assert pk.as_dict()["extrapolated_crossings"][0]["mode"] == 1
