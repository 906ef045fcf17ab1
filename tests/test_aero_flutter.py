"""Flutter solvers on a typical section with Theodorsen aerodynamics.

Independent reference: the classical flutter determinant of Theodorsen (NACA Rep. 496, 1935;
Bisplinghoff, Ashley & Halfman 1955, Sec. 9-6), written here from Theodorsen's time-domain lift
and moment with plunge positive *down* and solved for (V, ω) by Newton's method — independent of
the package's section matrices (plunge up), of its p-k iteration and of its RFA. The case is the
one Hodges & Pierce (2011, Sec. 5.5) use: a = -1/5, x_α = 1/10, r_α² = 6/25, ω_h/ω_α = 2/5,
μ = 20; the reference solution is U_F/(b ω_α) = 2.18391, ω_F/ω_α = 0.64898 (k_F = 0.29717).
"""

import numpy as np
import pytest
from scipy.optimize import brentq, fsolve
from scipy.special import hankel2

from torchrom.aero.atmosphere import flight_condition
from torchrom.aero.crossings import pk_crossings
from torchrom.aero.dlm import GAF
from torchrom.aero.flutter import (
    AeroTable,
    ModalStructure,
    alpha_for_gamma,
    alpha_for_gammas,
    critical_root,
    flutter_altitude_pk,
    flutter_altitude_state_space,
    growing_response_frequency,
    ke_sweep,
    pk_sweep,
)
from torchrom.aero.rfa import fit_minimum_state
from torchrom.aero.theodorsen import TypicalSection
from torchrom.errors import InputError

HP = dict(a=-0.2, x_alpha=0.1, r_alpha_sq=6 / 25, sigma=0.4, mu=20.0)


def classical_flutter(b, a, x_alpha, r_alpha_sq, m, omega_h, omega_alpha, rho, guess):
    """Solve Theodorsen's 2×2 flutter determinant (h down) for the flutter speed and frequency."""

    def det(x):
        V, w = x
        k = w * b / V
        C = hankel2(1, k) / (hankel2(1, k) + 1j * hankel2(0, k))
        s = 1j * w
        # L = πρb²(ḧ + Vα̇ − baα̈) + 2πρVbC[ḣ + Vα + b(½−a)α̇]   (lift up, h down)
        L_h = np.pi * rho * b**2 * s**2 + 2 * np.pi * rho * V * b * C * s
        L_a = np.pi * rho * b**2 * (V * s - b * a * s**2) + 2 * np.pi * rho * V * b * C * (
            V + b * (0.5 - a) * s
        )
        # M = πρb²[baḧ − Vb(½−a)α̇ − b²(1/8+a²)α̈] + 2πρVb²(a+½)C[ḣ + Vα + b(½−a)α̇]
        M_h = np.pi * rho * b**2 * b * a * s**2 + 2 * np.pi * rho * V * b**2 * (a + 0.5) * C * s
        M_a = np.pi * rho * b**2 * (
            -V * b * (0.5 - a) * s - b**2 * (1 / 8 + a**2) * s**2
        ) + 2 * np.pi * rho * V * b**2 * (a + 0.5) * C * (V + b * (0.5 - a) * s)
        S = m * x_alpha * b
        I = m * r_alpha_sq * b**2
        # m ḧ + S α̈ + K_h h = -L ;  S ḧ + I α̈ + K_α α = M
        A = np.array(
            [
                [m * s**2 + m * omega_h**2 + L_h, S * s**2 + L_a],
                [S * s**2 - M_h, I * s**2 + I * omega_alpha**2 - M_a],
            ]
        )
        d = np.linalg.det(A) / (m * I * omega_alpha**4)
        return [d.real, d.imag]

    sol, info, ier, msg = fsolve(det, guess, full_output=True, xtol=1e-13)
    assert ier == 1, msg
    return sol


@pytest.fixture(scope="module")
def hp_case():
    ts = TypicalSection(1.0, HP["a"], HP["x_alpha"], HP["r_alpha_sq"], 1.0, HP["sigma"], 1.0)
    rho = ts.density_for_mass_ratio(HP["mu"])
    ref = classical_flutter(
        1.0, HP["a"], HP["x_alpha"], HP["r_alpha_sq"], 1.0, HP["sigma"], 1.0, rho, [2.2, 0.65]
    )
    return ts, rho, ref


def test_independent_reference_value(hp_case):
    _, _, (V, w) = hp_case
    assert V == pytest.approx(2.18391, abs=2e-5)
    assert w == pytest.approx(0.64898, abs=2e-5)


def test_pk_with_exact_theodorsen_matches_the_flutter_determinant(hp_case):
    ts, rho, (V_ref, w_ref) = hp_case
    st = ModalStructure(ts.mass_matrix(), ts.stiffness_matrix())
    aero = AeroTable.from_function(lambda k: ts.gaf([k])[0], ts.semichord)
    sweep = pk_sweep(st, aero, np.linspace(0.5, 3.0, 26), rho)
    # beyond flutter the damped branch has no oscillatory p-k root (it turns real); every root
    # up to the flutter speed converged
    assert all(float(n.split("V=")[1]) > V_ref for n in sweep.notes)
    points = pk_crossings(st, aero, sweep).flutter
    assert len(points) == 1
    # p-k is exact at zero damping: agreement to the iteration tolerance
    assert points[0].velocity == pytest.approx(V_ref, rel=1e-5)
    assert 2 * np.pi * points[0].frequency_hz == pytest.approx(w_ref, rel=1e-5)
    assert points[0].k == pytest.approx(w_ref / V_ref, rel=1e-4)
    # damping is negative below flutter for both modes; V-g records are flat dicts
    assert np.all(sweep.damping[:5] < 0)
    assert {"velocity", "damping_g", "frequency_hz"} <= set(sweep.table()[0])


def test_ke_matches_within_interpolation_error(hp_case):
    ts, rho, (V_ref, w_ref) = hp_case
    st = ModalStructure(ts.mass_matrix(), ts.stiffness_matrix())
    aero = AeroTable.from_function(lambda k: ts.gaf([k])[0], ts.semichord)
    pts = ke_sweep(st, aero, np.geomspace(2.0, 0.05, 200), rho).crossings()
    assert len(pts) == 1
    assert pts[0].velocity == pytest.approx(V_ref, rel=1e-3)  # linear interpolation in k
    assert 2 * np.pi * pts[0].frequency_hz == pytest.approx(w_ref, rel=1e-3)


@pytest.fixture(scope="module")
def hp_rfa(hp_case):
    ts, _, _ = hp_case
    k = np.r_[0.0, np.geomspace(0.005, 2.0, 40)]
    return fit_minimum_state(GAF(0.0, 1.0, k, ts.gaf(k)), n_lags=4)


def test_state_space_on_rfa_within_one_percent(hp_case, hp_rfa):
    ts, rho, (V_ref, w_ref) = hp_case
    st = ModalStructure(ts.mass_matrix(), ts.stiffness_matrix())
    V = brentq(lambda v: critical_root(st, hp_rfa, v, rho).real, 1.5, 3.0, xtol=1e-12)
    assert V == pytest.approx(V_ref, rel=0.01)  # acceptance; observed 0.2 % with default roots
    assert critical_root(st, hp_rfa, V, rho).imag == pytest.approx(w_ref, rel=0.01)
    # p-k on the RFA's own Q(ik) is exact at zero damping: same point as the state space
    aero = AeroTable.from_rfa(hp_rfa)
    pts = pk_crossings(st, aero, pk_sweep(st, aero, np.linspace(1.0, 3.0, 11), rho)).flutter
    assert pts[0].velocity == pytest.approx(V, rel=1e-6)


def _altitude_case(gamma=0.0, alpha=0.0):
    """The H&P section scaled (ft, slug) to flutter near 10,000 ft at Mach 0.5."""
    b, mach = 3.0, 0.5
    rho10 = float(flight_condition(mach, 10000.0).density)
    m = HP["mu"] * np.pi * rho10 * b**2
    w_a = float(flight_condition(mach, 10000.0).velocity) / (2.18391 * b)
    ts = TypicalSection(b, HP["a"], HP["x_alpha"], HP["r_alpha_sq"], m, HP["sigma"] * w_a, w_a)
    st = ModalStructure(ts.mass_matrix(), ts.stiffness_matrix(), alpha=alpha, gamma=gamma)
    k = np.r_[0.0, np.geomspace(0.005, 2.0, 40)]
    gaf = GAF(mach, b, k, ts.gaf(k))
    return ts, st, gaf, mach


def test_matched_point_altitude_pk_and_state_space():
    ts, st, gaf, mach = _altitude_case()
    # 8 default lags: with 4 the RFA's 0.2 % speed error is 1.3 % in altitude (ρ varies ~3 %
    # per 1,000 ft, so altitude magnifies speed errors)
    rfa = fit_minimum_state(gaf, n_lags=8)
    ss = flutter_altitude_state_space(st, rfa, mach, (0.0, 20000.0), n_grid=21)
    pk = flutter_altitude_pk(st, AeroTable.from_gaf(gaf), mach, (0.0, 20000.0), n_grid=21)
    assert ss.altitude == pytest.approx(pk.altitude, rel=0.01)
    # independent check: the classical determinant at the p-k altitude's density gives the
    # matched speed M a(h) (the altitude where flutter speed = flight speed)
    fc = flight_condition(mach, pk.altitude)
    V, w = classical_flutter(
        ts.semichord,
        ts.a,
        ts.x_alpha,
        ts.r_alpha_sq,
        ts.mass,
        ts.omega_h,
        ts.omega_alpha,
        float(fc.density),
        [fc.velocity, 0.65 * ts.omega_alpha],
    )
    assert V == pytest.approx(fc.velocity, rel=1e-5)
    assert 2 * np.pi * pk.frequency_hz == pytest.approx(w, rel=1e-5)
    assert pk.altitude == pytest.approx(10000.0, abs=5.0)  # the case was scaled to 10,000 ft
    # below the flutter altitude the response grows; its frequency comes from the critical root
    f = growing_response_frequency(st, rfa, mach, [4000.0, 8000.0])
    assert np.all(f > 0)
    assert critical_root(st, rfa, *_vrho(mach, 4000.0)).real > 0


def _vrho(mach, h):
    fc = flight_condition(mach, h)
    return float(fc.velocity), float(fc.density)


def test_alpha_for_gamma_keeps_the_flutter_altitude():
    _, st, gaf, mach = _altitude_case()
    rfa = fit_minimum_state(gaf, n_lags=4)
    target = 9000.0
    alphas = [alpha_for_gamma(st, rfa, g, mach, target) for g in (0.0, 1e-4, 1e-3)]
    assert alphas[0] > alphas[1] > alphas[2]  # more γ needs less α (paper Fig. 9)
    check = flutter_altitude_state_space(
        st.with_damping(alphas[1], 1e-4), rfa, mach, (0, 20000), 21
    )
    assert check.altitude == pytest.approx(target, abs=1.0)


def test_alpha_for_gammas_equals_the_scalar_root():
    """The stacked Illinois iteration finds the same α as Brent's method per γ, to the root
    finders' own tolerance (xtol 1e-10 1/s each: 1e-9 allows both errors and the rounding
    of the affine state matrix), including a γ whose root lies outside the first bracket."""
    _, st, gaf, mach = _altitude_case()
    rfa = fit_minimum_state(gaf, n_lags=4)
    gammas = [0.0, 1e-5, 3e-4, 1e-3, 4e-3]
    many = alpha_for_gammas(st, rfa, gammas, mach, 9000.0, bracket=(-0.5, 0.5))
    one = [alpha_for_gamma(st, rfa, g, mach, 9000.0) for g in gammas]
    assert many == pytest.approx(one, abs=1e-9)
    assert alpha_for_gammas(st, rfa, [], mach, 9000.0).shape == (0,)


def test_alpha_for_gammas_of_a_free_aircraft_is_the_elastic_flutter():
    """A free aircraft (:func:`tests._aero_fakes.rigid_and_elastic`, exact RFA) with a third
    mode the aerodynamics do not touch (ω = 5 rad/s). With C = α M + γ K each uncoupled root's
    growth rate is -(c - ½ ρ V b |A1|)/2, so the elastic root (ω = 10 rad/s, |A1| = 0.35) is
    neutral at α = 0.175 ρV - 100 γ (closed form), the rigid one (K = 0, |A1| = 0.25) at
    α = 0.125 ρV whatever γ, and the untouched one at α = -25 γ. For γ > 5e-4 ρV the rigid
    root needs the larger α, and for γ = 2e-3 the elastic α (-0.085) lies below the untouched
    mode's (-0.05): the α found must still be the elastic one (the rigid and the untouched
    roots grow there, checked). Tolerance 1e-9 1/s: the root finders' xtol (1e-10) and the
    rounding of the affine state matrix (as the test above)."""
    from torchrom.aero.flutter import oscillatory_roots

    from ._aero_fakes import rigid_and_elastic

    structure, _, rfa = rigid_and_elastic(0.5, untouched_k=25.0)
    c = flight_condition(0.5, 20000.0, "ft")
    rho_v = float(c.density * c.velocity)
    gammas = np.array([0.0, 1e-4, 1e-3, 2e-3])
    elastic = 0.175 * rho_v - 100.0 * gammas
    rigid, untouched = 0.125 * rho_v, -25.0 * gammas
    assert np.sum(rigid > elastic + 0.01) == 2  # the rigid root would set two of the four
    assert untouched[3] > elastic[3] + 0.03  # and the untouched one the last
    found = alpha_for_gammas(structure, rfa, gammas, 0.5, 20000.0)
    assert found == pytest.approx(elastic, abs=1e-9)
    for i in (2, 3):
        assert alpha_for_gamma(structure, rfa, gammas[i], 0.5, 20000.0) == pytest.approx(
            elastic[i], abs=1e-9)
    roots = oscillatory_roots(structure.with_damping(found[3], gammas[3]), rfa, c.velocity,
                              c.density)
    assert roots.rigid.real.max() > 0.02
    assert np.sort(roots.elastic.real)[-2:] == pytest.approx([0.0, 0.0425 - 0.025],
                                                            abs=1e-3)


def test_modal_structure_from_rom_like_object():
    torch = pytest.importorskip("torch")

    class Rom:
        M = torch.eye(3, dtype=torch.float64)
        K1 = torch.diag(torch.tensor([1.0, 4.0, 9.0], dtype=torch.float64))
        D1 = K1.clone()

    st = ModalStructure.from_rom(Rom(), 2, alpha=0.2565, gamma=1.338e-4)
    np.testing.assert_allclose(st.C, 0.2565 * np.eye(2) + 1.338e-4 * np.diag([1.0, 4.0]))
    np.testing.assert_allclose(st.natural_frequencies_hz(), [1 / (2 * np.pi), 2 / (2 * np.pi)])
    with pytest.raises(InputError, match="positive definite"):
        ModalStructure(-np.eye(2), np.eye(2))


def test_round_off_damping_is_not_flutter():
    """A mode the aerodynamics do not touch has g ~ ±1e-15 from round-off: no crossing there;
    a real crossing (g from -0.02 to +0.03) is found once, interpolated linearly."""
    from torchrom.aero.flutter import G_ROUNDOFF, ModeSweep, zero_crossings

    v = np.linspace(100.0, 500.0, 9)
    noise = 1e-15 * np.array([-1, 1, -1, 1, -2, 3, -1, 1, 2])
    real = np.linspace(-0.06, 0.02, 9)  # crosses zero between points 6 and 7 (at V = 400)
    g = np.c_[noise, real]
    w = 2 * np.pi * np.c_[np.full(9, 10.0), np.full(9, 20.0)]
    s = 0.5 * g * w + 1j * w
    sweep = ModeSweep("PK", v, np.full(9, 1.2), s, np.ones_like(g), g)
    (p,) = sweep.crossings()
    assert p.mode == 1 and p.velocity == pytest.approx(400.0, rel=1e-12)
    assert zero_crossings(noise) == [] and zero_crossings([-1e-3, 5e-9, 2e-8]) == [0]
    assert zero_crossings([-1e-3, 0.5 * G_ROUNDOFF, -1e-3, 1e-3]) == [2]


def test_pk_damping_of_real_roots_is_nastrans():
    """Nastran prints a real (k = 0) p-k root's damping as g = 2 s b / (V ln 2). Reference: the
    f06 numbers themselves (printed to 5-8 digits, so 1e-4): bah_plane Mach 0.2 POINT 1 at
    V = 30 (b = REFC/2 = 2): s = 9.3382457e-4, g = 1.7963175e-4; 0012_flutter POINT 2 at
    V = 162.486 (b = 0.5): s = -40.9415, g = -0.363519. Oscillatory roots keep g = 2σ/ω."""
    from torchrom.aero.flutter import pk_damping

    g = pk_damping(np.array([[9.3382457e-4 + 0j]]), [30.0], 2.0)[0, 0]
    assert g == pytest.approx(1.7963175e-4, rel=1e-4)
    g = pk_damping(np.array([[-40.9415 + 0j]]), [162.486], 0.5)[0, 0]
    assert g == pytest.approx(-0.363519, rel=1e-4)
    g = pk_damping(np.array([[-0.17802 + 15.293j]]), [30.0], 2.0)[0, 0]
    assert g == 2 * -0.17802 / 15.293


def test_pk_rigid_body_mode_closed_form():
    """A rigid-body mode (ω = 0) with quasi-steady aerodynamics Q = c + i k d, beside an
    uncoupled elastic mode (10 rad/s, no aerodynamics): the p-k root of the rigid mode solves
    s² + q (b/V) d s + q c = 0 exactly (Q_I/k = d for every k), s = -q b d/(2V) +
    i √(q c - (q b d/2V)²). The rigid root starts from the mode at s = 0 (the companion matrix
    is defective there), the elastic one stays at 10i. Tolerance 1e-6: the p-k iteration stops
    at a relative change of k of eps = 1e-8."""
    b, c, d, rho = 0.5, 2.0, 3.0, 1.2
    structure = ModalStructure(np.eye(2), np.diag([0.0, 100.0]))
    aero = AeroTable.from_function(lambda k: np.diag([c + 1j * k * d, 0.0]), b)
    V = np.array([5.0, 10.0, 20.0])
    sw = pk_sweep(structure, aero, V, rho, eps=1e-8, real_root_damping="nastran")
    q = 0.5 * rho * V**2
    re = -q * b * d / (2 * V)
    expected = re + 1j * np.sqrt(q * c - re**2)
    assert np.abs(sw.eigenvalues[:, 0] / expected - 1).max() <= 1e-6
    assert np.abs(sw.eigenvalues[:, 1] - 10j).max() <= 1e-9
    assert not sw.crossings()


def test_pk_below_the_table_is_quasi_steady():
    """Below the lowest positive tabulated k the p-k aerodynamics are Q_R at the lowest
    tabulated k (the steady one when k = 0 is tabulated) plus i k Q_I(k_d)/k_d, not an
    extrapolation. With a table at k = 0, 0.001, 0.05 whose Q_R is c at k = 0 and grows
    linearly with k, a rigid mode's root at k < 0.001 is the quasi-steady one,
    s² + q (b/V) (Q_I(0.001)/0.001) s + q c = 0, to 1e-9 (closed form)."""
    b, rho, V = 2.0, 1.0, 30.0
    k = np.array([0.0, 0.001, 0.05])
    c, slope, d = -1e-3, 5.0, 0.4
    Q = (c + slope * k + 1j * d * k)[:, None, None]
    aero = AeroTable.from_gaf(GAF(k=k, Q=Q, mach=0.2, semichord=b), interpolation="linear")
    assert aero.k_min == 0.0 and aero.k_damp == 0.001
    sw = pk_sweep(ModalStructure(np.eye(1), np.zeros((1, 1))), aero, [V], rho, eps=1e-10,
                  real_root_damping="nastran")
    q = 0.5 * rho * V**2
    roots = np.roots([1.0, q * (b / V) * d, q * c])  # real: c < 0 (a divergent rigid mode)
    assert sw.eigenvalues[0, 0].imag == 0.0 and sw.k[0, 0] < 0.001
    assert np.min(np.abs(roots - sw.eigenvalues[0, 0].real)) <= 1e-9 * np.abs(roots).max()
    assert sw.damping[0, 0] == pytest.approx(2 * sw.eigenvalues[0, 0].real * b / (V * np.log(2)))


def test_excursions_label_humps_and_sustained_crossings():
    """Each upward zero crossing of a sampled damping pairs with the next downward one (a hump)
    or with none (sustained: unstable to the last sample); a root unstable from the first
    sample opens nothing; round-off (|g| <= G_ROUNDOFF) is no crossing. ModeSweep.crossings
    interpolates both speeds linearly (here exactly: g linear between samples)."""
    from torchrom.aero.flutter import HUMP, SUSTAINED, ModeSweep, excursions

    assert excursions([-1, 1, -1, -1, 1, 1]) == [(0, 1), (3, None)]
    assert excursions([1, -1, 1]) == [(1, None)]
    assert excursions([-1, 1e-9, -1]) == []
    v = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    g = np.array([-1.0, 1.0, -1.0, -3.0, 1.0])[:, None]
    s = 0.5 * g * 10.0 + 10.0j
    hump, sustained = ModeSweep("PK", v, np.ones(5), s, np.ones_like(g), g).crossings()
    assert (hump.kind, hump.velocity, hump.stable_velocity) == (HUMP, 0.5, 1.5)
    assert (sustained.kind, sustained.velocity, sustained.stable_velocity) == (
        SUSTAINED, 3.75, None)
    assert not hump.refined and hump.as_dict()["kind"] == "hump"


def test_matched_point_pk_reports_rigid_body_roots_apart():
    """A free aircraft's rigid-body root is never the ROM's flutter point: two uncoupled modes,
    a rigid one (K = 0, aerodynamic stiffness 0.05 q) and an elastic one (ω = 10 rad/s), each
    with structural damping c and aerodynamic damping ½ ρ V b d < 0, so each root's damping
    crosses zero where ρ V = 2 c / (b |d|) (closed form): the rigid root at ρV = 0.8 (about
    14,700 ft at Mach 0.5), above the elastic one at ρV = 1.1429. The flutter point is the
    elastic crossing (altitude from the atmosphere by Brent, 1 ft; frequency 10/2π Hz, 1e-6),
    the rigid one is listed apart."""
    from torchrom.aero.flutter import AeroTable, ModalStructure, flutter_altitude_pk

    structure = ModalStructure(np.eye(2), np.diag([0.0, 100.0]), C0=np.diag([0.1, 0.2]))
    table = AeroTable(lambda k: np.diag([0.05 - 0.25j * k, -0.35j * k]), 1.0)
    res = flutter_altitude_pk(structure, table, 0.5, (0.0, 30000.0))

    def rho_v(h):
        c = flight_condition(0.5, h, "ft")
        return float(c.density * c.velocity)

    expected = brentq(lambda h: rho_v(h) - 2 * 0.2 / 0.35, 0.0, 30000.0)
    assert res.mode == 1
    assert res.altitude == pytest.approx(expected, abs=1.0)
    assert res.frequency_hz == pytest.approx(10 / (2 * np.pi), rel=1e-6)
    ((j, h),) = res.rigid_body_crossings
    rigid_at = brentq(lambda h: rho_v(h) - 2 * 0.1 / 0.25, 0.0, 30000.0)
    assert j == 0 and h >= rigid_at and h - rigid_at < 30000.0 / 40
    assert res.as_dict()["rigid_body_crossings"] == [{"mode": 1, "altitude": h}]


def test_matched_point_state_space_reports_rigid_body_roots_apart():
    """The state-space (RFA) form of the test above: the free aircraft of
    :func:`tests._aero_fakes.rigid_and_elastic` (an exact RFA with no lag states). The rigid
    root is oscillatory (its aerodynamic stiffness) and crosses zero first, at ρV = 0.8, so the
    largest growth rate of all oscillatory roots would put the flutter point there; the
    flutter point is the elastic crossing (ρV = 8/7: altitude by Brent, 1 ft; frequency
    10/2π Hz, 1e-6), and the rigid one is listed apart, at the altitude sample above its
    crossing (the p-k's convention), with its mode."""
    from torchrom.aero.flutter import (
        critical_root,
        flutter_altitude_state_space,
        oscillatory_roots,
    )

    from ._aero_fakes import rigid_and_elastic

    structure, _, rfa = rigid_and_elastic(0.5)
    res = flutter_altitude_state_space(structure, rfa, 0.5, (0.0, 30000.0))

    def rho_v(h):
        c = flight_condition(0.5, h, "ft")
        return float(c.density * c.velocity)

    expected = brentq(lambda h: rho_v(h) - 8 / 7, 0.0, 30000.0)
    rigid_at = brentq(lambda h: rho_v(h) - 0.8, 0.0, 30000.0)
    assert rigid_at > expected + 1000.0  # the rigid root goes first: the test can fail
    assert res.altitude == pytest.approx(expected, abs=1.0)
    assert res.frequency_hz == pytest.approx(10 / (2 * np.pi), rel=1e-6)
    ((j, h),) = res.rigid_body_crossings
    assert j == 0 and h >= rigid_at and h - rigid_at < 30000.0 / 40
    assert res.as_dict()["rigid_body_crossings"] == [{"mode": 1, "altitude": h}]
    # between the two crossings the rigid root grows and the critical root is the elastic one
    c = flight_condition(0.5, 0.5 * (expected + rigid_at), "ft")
    roots = oscillatory_roots(structure, rfa, c.velocity, c.density)
    (rigid,) = roots.rigid
    assert rigid.real > 0 and roots.rigid_mode.tolist() == [0]
    assert critical_root(structure, rfa, c.velocity, c.density).real < 0
    assert abs(critical_root(structure, rfa, c.velocity, c.density).imag - 10.0) < 0.5


def test_refine_crossing_on_an_end_of_the_bracket():
    """A root crossing Re s = 0 exactly at an end of the bracket, computed there as +1e-16 (the
    wrong side, by rounding): that end is returned instead of Brent's "f(a) and f(b) must have
    different signs" (seen on a grid altitude in CI); an ordinary bracket is refined to xtol."""
    from types import SimpleNamespace

    from torchrom.aero.flutter import refine_crossing

    def roots_at(x, at=9000.0, noise=1e-16):
        re = (x - at) * 1e-4 if x != at else noise
        return SimpleNamespace(elastic=np.array([complex(re, 10.0), complex(-5.0, 30.0)]))

    x, root = refine_crossing(roots_at, 8000.0, 9000.0, complex(0.0, 10.0), 1e-3)
    assert x == 9000.0 and root.real == 1e-16
    x, _ = refine_crossing(lambda h: roots_at(h, at=8500.0), 8000.0, 9000.0,
                           complex(0.0, 10.0), 1e-3)
    assert x == pytest.approx(8500.0, abs=1e-3)
