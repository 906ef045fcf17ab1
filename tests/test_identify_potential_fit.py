"""The potential fit about a state (torchrom.identify.potential_fit) against exact quartic
potentials: their V3, V4 recovered from forces and tangents at a few points."""

import itertools

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.identify.potential_fit import PotentialMonomials, fit_potential


def _symmetric(rng, n, order):
    T = rng.normal(size=(n,) * order)
    return sum(np.transpose(T, p) for p in itertools.permutations(range(order))) / \
        len(list(itertools.permutations(range(order))))


def _quartic(n, loaded, seed=0):
    """K (n, n) positive definite, V3 and V4 fully symmetric, zero where the fit keeps no
    monomial (fewer than 1 / 2 indices among the first ``loaded``)."""
    rng = np.random.default_rng(seed)
    B = rng.normal(size=(n, n))
    K = B @ B.T + n * np.diag(np.arange(1, n + 1.0) ** 2)
    V3, V4 = _symmetric(rng, n, 3), _symmetric(rng, n, 4)
    for t in itertools.product(range(n), repeat=3):
        if sum(i < loaded for i in t) < 1:
            V3[t] = 0.0
    for t in itertools.product(range(n), repeat=4):
        if sum(i < loaded for i in t) < 2:
            V4[t] = 0.0
    return K, V3, V4


def _data(K, V3, V4, X):
    N = 0.5 * np.einsum("abc,pb,pc->pa", V3, X, X) + \
        np.einsum("abcd,pb,pc,pd->pa", V4, X, X, X) / 6
    T = K + np.einsum("abc,pc->pab", V3, X) + 0.5 * np.einsum("abcd,pc,pd->pab", V4, X, X)
    return N, T


@pytest.mark.parametrize("loaded", [4, 2])
def test_an_exact_quartic_potential_is_recovered(loaded):
    """Forces and tangents of an exact quartic potential (random, symmetric) at points loading
    the first ``loaded`` coordinates (and the others a little, as a slaved response does):
    K2 = V3/2, K3 = V4/6 to 1e-9 of their largest entry (a linear least-squares solve on exact
    data: rounding, amplified by the monomials' spread of scales), fits ~1e-12."""
    n = 4
    K, V3, V4 = _quartic(n, loaded)
    rng = np.random.default_rng(1)
    X = rng.normal(size=(40, n)) * 0.05
    X[:, loaded:] *= 0.01
    N, T = _data(K, V3, V4, X)
    fit = fit_potential(X, T, N, K, loaded)
    assert np.abs(fit.K2 - V3 / 2).max() <= 1e-9 * np.abs(V3).max()
    assert np.abs(fit.K3 - V4 / 6).max() <= 1e-9 * np.abs(V4).max()
    assert fit.force_fit < 1e-10 and fit.tangent_fit < 1e-10


def test_monomial_derivatives_are_the_finite_differences():
    """gradient and hessian of the kept monomials against central differences (step 1e-5,
    error O(h²) ~ 1e-10 on O(1) monomials)."""
    mono = PotentialMonomials.of(3, 2)
    y = np.array([0.3, -0.7, 1.1])
    h = 1e-5

    def values(z):
        return np.prod(z[None, :] ** mono.exponents, axis=1)

    g = mono.gradient(y)
    H = mono.hessian(y)
    iu, ju = np.triu_indices(3)
    for i in range(3):
        e = np.zeros(3)
        e[i] = h
        np.testing.assert_allclose(g[i], (values(y + e) - values(y - e)) / (2 * h), atol=1e-9)
        dg = (mono.gradient(y + e) - mono.gradient(y - e)) / (2 * h)
        for r, (a, b) in enumerate(zip(iu, ju)):
            if b == i:
                np.testing.assert_allclose(H[r], dg[a], atol=1e-8)


def test_kept_monomials_are_counted():
    """n = 3, one loaded: cubic monomials with index 0 (10 − 4 = 6), quartic ones with index 0
    at least twice (x0² times any quadratic of 3: 6)."""
    mono = PotentialMonomials.of(3, 1)
    assert (mono.order == 3).sum() == 6 and (mono.order == 4).sum() == 6


def test_too_few_solves_are_refused():
    K, V3, V4 = _quartic(3, 3)
    X = np.array([[0.01, 0.0, 0.0], [-0.01, 0.0, 0.0]])
    N, T = _data(K, V3, V4, X)
    with pytest.raises(InputError, match="determine only"):
        fit_potential(X, T, N, K, 3)


def test_an_unstable_state_is_refused():
    K = -np.eye(2)
    with pytest.raises(InputError, match="positive diagonal"):
        fit_potential(np.ones((1, 2)), np.zeros((1, 2, 2)), np.zeros((1, 2)), K, 2)
