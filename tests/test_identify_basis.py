"""Basis (linear + dual modes, DIGEST Sec. 6) and the FE-backend protocol on a synthetic FE."""

import numpy as np
import pytest
import scipy.linalg

from torchrom.errors import InputError
from torchrom.identify.backend import CallableBackend, newton_static_solve
from torchrom.identify.basis import DualModeOptions, dual_basis, linear_basis, pod

from .identify_fixtures import TrussWing


@pytest.fixture(scope="module")
def truss_dual():
    fe = TrussWing()
    lin = linear_basis(fe, 5)
    opts = DualModeOptions(combinations=((1, 1), (1, 2), (2, 2)), n_amplitudes=10)
    return fe, lin, dual_basis(fe, lin, 3, opts)


def test_linear_modes_against_dense_eigensolver():
    fe = TrussWing()
    f, V = fe.modes(4)
    K = fe.stiffness_matrix().toarray()
    M = fe.mass_matrix().toarray()
    lam = scipy.linalg.eigh(K, M, eigvals_only=True)[:4]
    assert np.allclose((2 * np.pi * f) ** 2, lam, rtol=1e-10)
    assert np.allclose(V.T @ M @ V, np.eye(4), atol=1e-12)


def test_dual_basis_is_mass_orthonormal_and_outside_linear_span(truss_dual):
    fe, lin, basis = truss_dual
    M = fe.mass_matrix()
    Phi = basis.Phi
    assert basis.kinds == ["linear"] * 5 + ["dual"] * 3
    assert np.allclose(Phi.T @ (M @ Phi), np.eye(8), atol=1e-10)
    assert np.all(np.isnan(basis.frequencies_hz[5:]))
    # POD spectrum: normalised, descending; the first three dominate
    s = basis.pod_values
    assert s.sum() == pytest.approx(1.0) and np.all(np.diff(s) <= 1e-15)
    assert s[:3].sum() > 0.99


def test_dual_amplitudes_cover_the_paper_range(truss_dual):
    fe, _, basis = truss_dual
    recs = basis.snapshots
    assert len(recs) == 3 * 10
    lin = [r["tip_linear_pct_span"] for r in recs]
    assert min(lin) == pytest.approx(0.1) and max(lin) == pytest.approx(15.0)
    assert sum(r["alpha"] > 0 for r in recs) == 15
    # the solved responses are nonlinear: the achieved tip deflection departs from the linear one
    big = [r for r in recs if r["tip_linear_pct_span"] > 14]
    assert all(abs(r["tip_pct_span"] - r["tip_linear_pct_span"]) > 1e-3 for r in big)
    # "response" amplitudes: the FE tip deflection hits its target within 3 %, or (a stiffening
    # response) the α is the one whose linear prediction is the target
    for r in recs:
        t = r["target_pct_span"]
        assert r["tip_pct_span"] <= 1.03 * t
        assert r["tip_pct_span"] >= 0.97 * t or r["tip_linear_pct_span"] == pytest.approx(t)


def _softening_backend():
    """Two DOFs, f(u) = K u − c u³ componentwise: the response to α K U grows faster than α."""
    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    c = np.array([3.0, 1.0])
    return CallableBackend(lambda u: K @ u - c * u**3, lambda u: K - np.diag(3 * c * u**2),
                           np.eye(2), reference_length=1.0, transverse_dofs=[0, 1])


def test_response_amplitudes_follow_a_softening_fe():
    """Where the response softens, the "response" amplitudes stay on the targets (the loads
    with α from the linear prediction overshoot them: the paper's range is of the data)."""
    be = _softening_backend()
    # one linear mode: the dual mode is the response's part along the other DOF (the cubic
    # terms differ per DOF); with both modes linear nothing would be left for it
    lin = linear_basis(be, 1)
    tips = {}
    for control in ("response", "linear"):
        opts = DualModeOptions(combinations=((1, 1),), n_amplitudes=8, tip_range=(0.02, 0.2),
                               amplitude_control=control)
        recs = dual_basis(be, lin, 1, opts).snapshots
        tips[control] = np.array([[r["target_pct_span"], r["tip_pct_span"],
                                   r["tip_linear_pct_span"]] for r in recs])
    target, tip, linear = tips["response"].T
    assert np.all(np.abs(tip - target) <= 0.03 * target) and np.all(linear < target + 1e-12)
    assert np.all(linear[target > 10] < 0.97 * target[target > 10])  # α reduced
    target, tip, linear = tips["linear"].T
    assert np.allclose(linear, target) and tip.max() > 1.1 * target.max()


def test_dual_walk_past_a_limit_load_gives_up_with_the_reason():
    """A load the FE cannot carry (a static solve that raises past a limit load, as the BAH
    aircraft's inertia-relief solves do) is bisected at most 3 times per target, then the
    walk's larger loads are skipped and the record says why: the work stays bounded (7 solves
    per walk here: the 4 below the limit and 3 failed), the loads below the limit are kept."""
    from torchrom.errors import ConvergenceError

    K = np.array([[2.0, -1.0], [-1.0, 2.0]])
    c = np.array([0.3, 0.1])
    attempts = []

    def solve(load, u0):
        attempts.append(float(np.abs(load).max()))
        if attempts[-1] > 0.1:
            raise ConvergenceError("no equilibrium past the limit load 0.1")
        return newton_static_solve(lambda u: K @ u + c * u**3, lambda u: K + np.diag(3 * c * u**2),
                                   load, u0=u0)

    be = CallableBackend(lambda u: K @ u + c * u**3, lambda u: K + np.diag(3 * c * u**2),
                         np.eye(2), static_solve=solve, reference_length=1.0,
                         transverse_dofs=[0, 1])
    opts = DualModeOptions(combinations=((1, 1),), n_amplitudes=20, tip_range=(0.01, 1.0))
    recs = dual_basis(be, linear_basis(be, 1), 1, opts).snapshots
    for walk in (recs[:10], recs[10:]):  # the positive and the negative loads
        assert [r["status"] for r in walk] == ["ok", "ok"] + ["skipped"] * 8
        assert "the larger loads skipped: no equilibrium past the limit load 0.1" in \
            walk[1]["message"]
        assert walk[1]["solves"] <= 12  # its best load below the limit, to a 10 % target
    assert sum(a > 0.1 for a in attempts) == 3 * 2  # 3 failures per walk, two signs
    assert len(attempts) == sum(r.get("solves", 0) for r in recs) == 14


def test_dual_basis_is_reproducible():
    """Same FE, same options: the same basis bit for bit (signs by orient_columns, fixed
    eigensolver start, fixed solution order)."""
    fe = TrussWing()
    opts = DualModeOptions(combinations=((1, 1), (1, 2)), n_amplitudes=6)
    a = dual_basis(fe, linear_basis(fe, 4), 2, opts).Phi
    b = dual_basis(fe, linear_basis(fe, 4), 2, opts).Phi
    assert np.array_equal(a, b)


def test_orient_columns_is_immune_to_mirror_ties():
    """Mirror-image entries of equal magnitude and opposite sign: "largest entry positive"
    depends on the last bit, the first entry above half the maximum does not."""
    from torchrom.eigen import orient_columns

    v = np.array([0.1, -0.7, 0.3, 0.7, 0.2])
    for eps in (1e-16, -1e-16):
        w = v.copy()
        w[3] += eps
        out = orient_columns(w[:, None])[:, 0]
        assert out[1] == pytest.approx(0.7) and out[3] == pytest.approx(-0.7)
    assert np.array_equal(orient_columns(-v[:, None]), orient_columns(v[:, None]))


@pytest.mark.parametrize("weights, tol", [("unit", 0.03), ("relative", 0.10)])
def test_dual_modes_capture_the_nonlinear_static_response(truss_dual, weights, tol):
    """The reason dual modes exist: the part of a nonlinear static response outside the linear
    modes lies (almost) in the span of the dual modes — checked at a load not among the
    snapshots (mode 1 + mode 2 loading at about 11 % of span), in the energy norm of the
    (stiffness-norm) POD. With only three dual modes on this very nonlinear truss (residuals up
    to 35 times the linear part) unit snapshot weights, which favour the quadratic (small-
    amplitude) content, capture it best (measured 0.9 %); the default relative weights, which
    favour the large amplitudes, leave 6.9 % (they are the better choice on the Goland wing,
    see torchrom.identify.basis)."""
    fe, lin, _ = truss_dual
    opts = DualModeOptions(combinations=((1, 1), (1, 2), (2, 2)), n_amplitudes=10,
                           snapshot_weights=weights)
    basis = dual_basis(fe, lin, 3, opts)
    M, K = fe.mass_matrix(), fe.stiffness_matrix()
    U = lin.Phi[:, 0] + lin.Phi[:, 1]
    alpha = 0.11 * fe.reference_length / np.abs(U[fe.transverse_dofs]).max()
    u = fe.static_solve(alpha * (K @ U)).u
    outside = u - lin.Phi @ (lin.Phi.T @ (M @ u))
    D = basis.Phi[:, 5:]
    left = outside - D @ np.linalg.solve(D.T @ (K @ D), D.T @ (K @ outside))
    assert np.sqrt(left @ (K @ left)) < tol * np.sqrt(outside @ (K @ outside))


def test_pod_of_known_snapshots():
    rng = np.random.default_rng(1)
    M = np.diag(rng.uniform(1, 2, 6))
    A = rng.normal(size=(6, 2))
    S = A @ rng.normal(size=(2, 8))
    W, lam = pod(S, M, 2)
    assert np.allclose(W.T @ M @ W, np.eye(2), atol=1e-12)
    assert lam[2:].max() < 1e-12
    with pytest.raises(InputError, match="independent directions"):
        pod(S, M, 3)


def test_newton_static_solve_and_counters():
    fe = TrussWing()
    load = fe.pressure_like_load(3e4, step=True)
    before = fe.counters.static_solves
    sol = fe.static_solve(load)
    assert sol.converged
    assert np.linalg.norm(fe.internal_force(sol.u) - load) < 1e-9 * np.linalg.norm(load)
    assert fe.counters.static_solves == before + 1 and fe.counters.newton_iterations > 0


def test_callable_backend_validates_and_solves():
    k = 2.0

    def f(u):
        return k * u + u**3

    def kt(u):
        return np.diag(k + 3 * u**2)

    be = CallableBackend(f, kt, np.eye(3))
    sol = be.static_solve(np.array([1.0, 10.0, -50.0]))
    assert np.allclose(f(sol.u), [1.0, 10.0, -50.0], rtol=1e-10)
    with pytest.raises(InputError, match="expected 3"):
        be.internal_force(np.zeros(2))
    with pytest.raises(InputError, match="material tangent"):
        be.material_tangent(np.zeros(3))
    # newton_static_solve with a warm start at the answer returns it at once
    again = newton_static_solve(f, kt, np.array([1.0, 10.0, -50.0]), u0=sol.u)
    assert again.iterations == 0


def test_parse_combinations_names_pairs_and_errors():
    from torchrom.identify.basis import (
        BENDING_TORSION_COMBINATIONS,
        PAPER_COMBINATIONS,
        parse_combinations,
    )

    assert parse_combinations("paper") == PAPER_COMBINATIONS
    assert parse_combinations("bending-torsion") == BENDING_TORSION_COMBINATIONS
    assert parse_combinations("1:1,2:3") == ((1, 1), (2, 3))
    with pytest.raises(InputError, match="--combinations: expected one of"):
        parse_combinations("1-2")


def test_transverse_rule_chooses_combinations_from_mode_kinds():
    """The rule loads the first two transverse modes with the first three — or up to the second
    bending mode when a torsion mode lies below it —, skipping in-plane and axial modes; on the
    calibrated heavy Goland wing (1 bending, 2 torsion, 3 bending) it is the validated
    bending-torsion set, on the updated wing (1 bending, 2-3 torsion, 4 bending) it adds the
    second bending mode 4."""
    from torchrom.fe import goland
    from torchrom.identify.basis import (
        BENDING_TORSION_COMBINATIONS,
        parse_combinations,
        transverse_combinations,
    )

    kinds = ["bending", "in-plane", "torsion", "axial", "bending", "torsion"]
    assert transverse_combinations(kinds) == ((1, 1), (1, 3), (1, 5), (3, 3), (3, 5))
    assert transverse_combinations(["in-plane", "bending"]) == ((2, 2),)
    with pytest.raises(InputError, match="no transverse"):
        transverse_combinations(["in-plane", "axial"])
    with pytest.raises(InputError, match="needs the mode kinds"):
        parse_combinations("transverse")
    assert transverse_combinations(["bending", "torsion", "torsion", "torsion", "bending"]) == (
        (1, 1), (1, 2), (1, 3), (1, 4), (1, 5), (2, 2), (2, 3), (2, 4), (2, 5))
    assert transverse_combinations(["torsion", "bending"]) == ((1, 1), (1, 2), (2, 2))
    kinds = goland(variant="calibrated").modes(9).kinds
    assert parse_combinations("transverse", kinds=kinds) == BENDING_TORSION_COMBINATIONS
    kinds = goland(variant="updated").modes(9).kinds
    assert parse_combinations("transverse", kinds=kinds) == (
        (1, 1), (1, 2), (1, 3), (1, 4), (2, 2), (2, 3), (2, 4))


def _two_linear_modes(n: int = 6):
    from torchrom.identify.basis import Basis

    return Basis(np.eye(n)[:, :2], ["bending", "bending"], np.array([1.0, 2.0]))


def test_dual_count_follows_the_snapshots_rank():
    """Snapshots whose parts outside the linear modes (e1, e2) span e3, e4 only: asked for 3
    dual modes, the basis gets the 2 there are, with a warning that says why (issue 34: a
    Cholesky LinAlgError before), and they span exactly e3, e4 (projector error at rounding)."""
    from torchrom.identify.basis import dual_modes_from_responses

    rng = np.random.default_rng(0)
    U = np.zeros((40, 6))
    U[:, :2] = rng.normal(size=(40, 2))
    U[:, 2:4] = 1e-3 * rng.normal(size=(40, 2))  # the nonlinear part: two directions
    with pytest.warns(UserWarning, match="span 2 independent directions.*using 2 dual modes"):
        basis, rel = dual_modes_from_responses(_two_linear_modes(), np.eye(6), U, 3, K=np.eye(6))
    assert basis.kinds.count("dual") == 2 and basis.n == 4
    V = basis.Phi[:, 2:]
    assert np.abs(V.T @ V - np.eye(2)).max() < 1e-12  # mass-orthonormal (M = I)
    assert np.abs(V[[0, 1, 4, 5]]).max() < 1e-12  # within span(e3, e4)
    assert rel.max() > 1e-4


def test_massless_snapshot_directions_are_no_dual_modes():
    """A part along a massless DOF (e5: M = 0 there) cannot be mass-normalised: it is skipped
    and counted in the warning; the dual mode is the part with mass (e3)."""
    from torchrom.identify.basis import dual_modes_from_responses

    rng = np.random.default_rng(1)
    U = np.zeros((30, 6))
    U[:, :2] = rng.normal(size=(30, 2))
    U[:, 2] = 1e-3 * rng.normal(size=30)
    U[:, 4] = 5e-3 * rng.normal(size=30)  # larger, so the POD puts it first
    M = np.diag([1.0, 1.0, 1.0, 1.0, 0.0, 1.0])
    with pytest.warns(UserWarning, match="1 of them without mass.*using 1 dual modes"):
        basis, _ = dual_modes_from_responses(_two_linear_modes(), M, U, 2, K=np.eye(6))
    v = basis.Phi[:, 2]
    assert abs(abs(v[2]) - 1.0) < 1e-12 and np.abs(np.delete(v, 2)).max() < 1e-12


def test_linear_responses_make_no_dual_modes():
    """Responses with nothing outside the linear modes but rounding (a stick model of linear
    CBARs: 5e-15 measured) are refused with what to do (--dual 0), not turned into dual modes
    of noise."""
    from torchrom.identify.basis import dual_modes_from_responses

    U = np.zeros((10, 6))
    U[:, :2] = np.random.default_rng(2).normal(size=(10, 2))
    U[:, 3] = 1e-16 * U[:, 0]
    with pytest.raises(InputError, match="use --dual 0"):
        dual_modes_from_responses(_two_linear_modes(), np.eye(6), U, 2, K=np.eye(6))
