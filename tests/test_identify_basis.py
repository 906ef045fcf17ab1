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


def test_dual_modes_capture_the_nonlinear_static_response(truss_dual):
    """The reason dual modes exist: the part of a nonlinear static response outside the linear
    modes lies (almost) in the span of the dual modes — checked at a load not among the
    snapshots (mode 1 + mode 2 loading at about 11 % of span)."""
    fe, lin, basis = truss_dual
    M = fe.mass_matrix()
    U = lin.Phi[:, 0] + lin.Phi[:, 1]
    alpha = 0.11 * fe.reference_length / np.abs(U[fe.transverse_dofs]).max()
    u = fe.static_solve(alpha * (fe.stiffness_matrix() @ U)).u
    outside = u - lin.Phi @ (lin.Phi.T @ (M @ u))
    D = basis.Phi[:, 5:]
    left = outside - D @ (D.T @ (M @ outside))
    assert np.sqrt(left @ (M @ left)) < 0.05 * np.sqrt(outside @ (M @ outside))


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
