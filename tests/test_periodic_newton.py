"""Batched Newton of torchrom.periodic.newton on a small hand-made system."""

import torch

from torchrom.periodic.newton import MAX_LIMITED_STEPS, NewtonOptions, newton


def _system(c: float):
    """Unknowns X = (x0, a1, b1) of one coordinate, ω and μ, with R = [x0² + c, a1 + ω − 1,
    b1 + μ + a1], the phase condition b1 = 0 and w·z = μ = 0: a root x0 = ±√−c for c < 0, none
    for c > 0."""

    def evaluate(X, omega, mu, active):
        x = X[:, :, 0]
        R = torch.stack([x[:, 0] ** 2 + c, x[:, 1] + omega - 1, x[:, 2] + mu + x[:, 1]], 1)
        B = len(X)
        J = torch.zeros(B, 3, 3, dtype=X.dtype)
        J[:, 0, 0] = 2 * x[:, 0]
        J[:, 1, 1] = 1
        J[:, 2, 1] = J[:, 2, 2] = 1
        R_w = torch.zeros(B, 3, 1, dtype=X.dtype)
        R_w[:, 1] = 1
        R_m = torch.zeros(B, 3, 1, dtype=X.dtype)
        R_m[:, 2] = 1
        return R[..., None], J, R_w, R_m

    w = torch.zeros(1, 5, dtype=torch.float64)
    w[0, -1] = 1.0
    return evaluate, w


def _solve(c: float, x0: float):
    evaluate, w = _system(c)
    X = torch.tensor([[[x0], [0.0], [0.0]]], dtype=torch.float64)
    one = torch.ones(1, dtype=torch.float64)
    return newton(evaluate, X, one, 0 * one, torch.ones(1, dtype=torch.float64), w, 0 * one,
                  1e-12 * one, NewtonOptions(max_iterations=25))


def test_a_case_without_a_root_stops_after_its_limited_steps():
    """x0² + 1 = 0 has no real root: every Newton step, |x0² + 1| / |2 x0| > |x0| / 2, is
    limited to half the orbit's size, and the case stops unconverged after
    MAX_LIMITED_STEPS of them, not after max_iterations."""
    res = _solve(1.0, 1.0)
    assert not bool(res.converged[0])
    assert int(res.iterations[0]) == MAX_LIMITED_STEPS < 25


def test_a_case_with_a_root_converges():
    res = _solve(-4.0, 1.5)
    assert bool(res.converged[0])
    assert abs(float(res.X[0, 0, 0]) - 2.0) < 1e-10
    assert abs(float(res.omega[0]) - 1.0) < 1e-12
