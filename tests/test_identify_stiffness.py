"""Stiffness identification (tangent method Eqs. 37–41, STEP) against independent references:
REFERENCE Sec. 5 (forces written out as printed, tangents by autograd) and the closed-form energy
projection of a St Venant–Kirchhoff truss."""

import numpy as np
import pytest

from torchrom.identify.basis import linear_basis
from torchrom.identify.stiffness import (
    TangentPlan,
    fit_quadratic_matrix,
    identification_amplitudes,
    identify_stiffness_step,
    identify_stiffness_tangent,
)

from .identify_fixtures import TrussWing, touze_backend
from .rom_fixtures import touze_two_mode


def rel(a, b):
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


# The ± amplitude differences cancel K1 exactly; what is left is rounding ~ ε‖K1‖/(a²‖K3‖), which
# is ≤ 1e-13 for a ≥ 0.05 here: 1e-10 leaves three orders of margin.
@pytest.mark.parametrize("amplitude", [0.05, 2.0])
@pytest.mark.parametrize("method", ["tangent", "step"])
def test_touze_recovered_at_two_amplitudes(amplitude, method):
    be = touze_backend()
    rom = touze_two_mode()
    Phi = np.eye(2)
    a = identification_amplitudes(Phi, amplitude)
    if method == "tangent":
        ident, plan, _, _ = identify_stiffness_tangent(be, Phi, a)
        assert len(plan.points) == 1 + 2 * 2 + 2
    else:
        ident, _, _ = identify_stiffness_step(be, Phi, a)
    assert rel(ident.K1, rom.K1.numpy()) < 1e-14
    assert rel(ident.K2, rom.K2.numpy()) < 1e-10
    assert rel(ident.K3, rom.K3.numpy()) < 1e-10
    # combined coefficients of REFERENCE Sec. 5 read off the printed force: f1 has 1.5 ω1² q1²,
    # ω2² q1 q2, 0.5 ω1² q2², ½(ω1²+ω2²) q1³ and q1 q2²
    w1, w2 = 1.13**2, 4.0
    c = ident.combined()
    assert c["K2"][0, 0, 0] == pytest.approx(1.5 * w1, rel=1e-10)
    assert c["K2"][0, 0, 1] == pytest.approx(w2, rel=1e-10)
    assert c["K2"][0, 1, 1] == pytest.approx(0.5 * w1, rel=1e-10)
    assert c["K3"][0, 0, 0, 0] == pytest.approx(0.5 * (w1 + w2), rel=1e-10)
    assert c["K3"][0, 0, 1, 1] == pytest.approx(0.5 * (w1 + w2), rel=1e-10)
    assert abs(c["K3"][0, 0, 0, 1]) < 1e-10


def test_one_sided_pairs_match_symmetric_pairs():
    """The paper's one-sided Eq. 41 and the ± variant agree for a cubic model."""
    be = touze_backend()
    Phi = np.eye(2)
    a = identification_amplitudes(Phi, 0.3)
    sym, p_sym, _, _ = identify_stiffness_tangent(be, Phi, a, symmetric_pairs=True)
    one, p_one, _, _ = identify_stiffness_tangent(be, Phi, a, symmetric_pairs=False)
    assert len(p_one.points) == len(p_sym.points) - 1
    assert rel(one.K3, sym.K3) < 1e-12


def test_fit_quadratic_matrix_exact_on_random_polynomial():
    rng = np.random.default_rng(0)
    n = 4
    T0 = rng.normal(size=(n, n))
    A1 = rng.normal(size=(n, n, n))
    A2 = rng.normal(size=(n, n, n, n))
    A2 = 0.5 * (A2 + A2.transpose(0, 1, 3, 2))
    plan = TangentPlan(rng.uniform(0.1, 2, n))
    T = np.stack([T0 + np.einsum("mnj,j->mn", A1, q) + np.einsum("mnjl,j,l->mn", A2, q, q)
                  for q in plan.points])
    t0, a1, a2 = fit_quadratic_matrix(plan, T)
    assert rel(t0, T0) < 1e-14 and rel(a1, A1) < 1e-13 and rel(a2, A2) < 1e-12


@pytest.fixture(scope="module")
def truss_basis():
    fe = TrussWing()
    return fe, linear_basis(fe, 5).Phi


@pytest.mark.parametrize("amplitude", [1e-3, 0.05])
def test_truss_tangent_matches_intrusive(truss_basis, amplitude):
    fe, Phi = truss_basis
    ref = fe.intrusive_rom(Phi)
    a = identification_amplitudes(Phi, amplitude, fe.reference_length, fe.translational_dofs)
    ident, _, _, _ = identify_stiffness_tangent(fe, Phi, a)
    # cubic FE: exact up to rounding ε‖K1‖/(a²‖K3‖) ≲ 1e-11 at a = 1e-3 span
    assert rel(ident.K2, ref.K2.numpy()) < 1e-10
    assert rel(ident.K3, ref.K3.numpy()) < 1e-9
    r = ident.residuals
    assert r["tangent_asymmetry"] < 1e-12 and r["K2_full"] < 1e-10 and r["K3_full"] < 1e-9


def test_truss_step_matches_intrusive(truss_basis):
    fe, Phi = truss_basis
    ref = fe.intrusive_rom(Phi[:, :3])
    a = identification_amplitudes(Phi[:, :3], 0.02, fe.reference_length)
    ident, plan, _ = identify_stiffness_step(fe, Phi[:, :3], a)
    assert len(plan.points) == 2 * 3 + 4 * 3 + 2 * 1
    assert rel(ident.K2, ref.K2.numpy()) < 1e-10
    assert rel(ident.K3, ref.K3.numpy()) < 1e-10


def _perturbed_touze(extra_force, extra_tangent):
    be = touze_backend()
    f0, k0 = be._f, be._kt
    be._f = lambda u: f0(u) + extra_force(u)
    be._kt = lambda u: k0(u) + extra_tangent(u)
    return be


def test_residuals_flag_non_cubic_and_non_conservative_models():
    """Residuals are rounding for a cubic potential model and O(1) when the FE is not."""
    Phi = np.eye(2)
    a = identification_amplitudes(Phi, 0.5)
    clean, _, _, _ = identify_stiffness_tangent(touze_backend(), Phi, a)
    assert max(clean.residuals.values()) < 1e-14
    # sixth-order potential W = q1³ q2³: the tangent is quartic, the cubic fit is inconsistent
    sextic = _perturbed_touze(
        lambda u: 3 * np.array([u[0] ** 2 * u[1] ** 3, u[0] ** 3 * u[1] ** 2]),
        lambda u: np.array([[6 * u[0] * u[1] ** 3, 9 * u[0] ** 2 * u[1] ** 2],
                            [9 * u[0] ** 2 * u[1] ** 2, 6 * u[0] ** 3 * u[1]]]))
    ident, _, _, _ = identify_stiffness_tangent(sextic, Phi, a)
    assert ident.residuals["K3_storage"] > 1e-3
    # a follower-like non-conservative force c q1² on dof 2: asymmetric tangent
    follower = _perturbed_touze(lambda u: np.array([0.0, u[0] ** 2]),
                                lambda u: np.array([[0.0, 0.0], [2 * u[0], 0.0]]))
    ident, _, _, _ = identify_stiffness_tangent(follower, Phi, a)
    assert ident.residuals["tangent_asymmetry"] > 1e-2
    assert ident.residuals["K2_full"] > 1e-2


def _sextic_touze(c: float):
    """Touzé's cubic model plus c q1³ q2³ in its potential (a quartic tangent: not cubic)."""
    return _perturbed_touze(
        lambda u: 3 * c * np.array([u[0] ** 2 * u[1] ** 3, u[0] ** 3 * u[1] ** 2]),
        lambda u: c * np.array([[6 * u[0] * u[1] ** 3, 9 * u[0] ** 2 * u[1] ** 2],
                                [9 * u[0] ** 2 * u[1] ** 2, 6 * u[0] ** 3 * u[1]]]))


def _largest_residual(backend, amplitude: float = 0.5) -> float:
    Phi = np.eye(2)
    ident, _, _, _ = identify_stiffness_tangent(backend, Phi,
                                                identification_amplitudes(Phi, amplitude))
    return max(ident.residuals.values())


def test_residual_worded_as_rounding_for_a_cubic_model():
    """Touzé's model is cubic: its largest residual (measured 0, < 1e-14 asserted above) is
    worded as rounding, as is the band's edge itself."""
    from torchrom.identify.stiffness import ROUNDING_RESIDUAL, residual_wording

    value = _largest_residual(touze_backend())
    assert value <= ROUNDING_RESIDUAL
    assert residual_wording(value) == "rounding level for a cubic FE"
    assert residual_wording(ROUNDING_RESIDUAL) == "rounding level for a cubic FE"


def test_residual_worded_as_small_for_a_slightly_non_cubic_model():
    """With c = 1e-4 the sextic term's residual is 9.5e-6 (0.0948 c at amplitude 0.5, linear in
    c): between the bands' edges, worded small and not as rounding; just past the rounding
    edge and at the small edge the same."""
    from torchrom.identify.stiffness import ROUNDING_RESIDUAL, SMALL_RESIDUAL, residual_wording

    value = _largest_residual(_sextic_touze(1e-4))
    assert ROUNDING_RESIDUAL < value <= SMALL_RESIDUAL
    for v in (value, 1.01 * ROUNDING_RESIDUAL, SMALL_RESIDUAL):
        assert residual_wording(v).startswith("small: the FE is not exactly cubic"), v


def test_residual_worded_as_large_with_what_to_do():
    """With c = 1 the residual is 0.095: large, and the advice (a smaller --amplitude) is
    right for it: halving the amplitude divides it by 4 (the quartic tangent's departure from
    the fitted quadratic grows as a²; 4 to 1e-9). Not finite is large too."""
    from torchrom.identify.stiffness import SMALL_RESIDUAL, residual_wording

    model = _sextic_touze(1.0)
    value = _largest_residual(model)
    assert value > SMALL_RESIDUAL
    for v in (value, 1.01 * SMALL_RESIDUAL, float("nan"), float("inf")):
        words = residual_wording(v)
        assert words.startswith("large") and "--amplitude" in words, v
    assert _largest_residual(model, 0.25) == pytest.approx(value / 4, rel=1e-9)
