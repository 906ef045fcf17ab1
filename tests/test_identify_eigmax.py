"""Batched smallest-eigenvalue maximisation (torchrom.identify.eigmax) against a closed form and
against a second solver (SCS) on random small semidefinite programs."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.identify.eigmax import BarrierOptions, maximise_min_eigenvalue


def test_closed_form_kink():
    """S(x) = diag(1 + x, 2 − x): λ_min = min(1 + x, 2 − x) is maximal at the kink x = ½
    (1.5), with the penalty ρx² at value 1.5 − ρ/4 still at the kink (the one-sided slopes ±1
    exceed 2ρx). The path ends at μ = 1e-10: within k·μ = 2e-10 (1e-9 allowed)."""
    F0 = torch.diag(torch.tensor([1.0, 2.0], dtype=torch.float64))[None]
    F = torch.diag(torch.tensor([1.0, -1.0], dtype=torch.float64))[None, None]
    res = maximise_min_eigenvalue(F0, F, BarrierOptions(penalty=1e-3))
    assert abs(float(res.x[0, 0]) - 0.5) < 1e-9
    assert abs(float(res.min_eigenvalue[0]) - 1.5) < 1e-9
    assert float(res.t[0]) <= float(res.min_eigenvalue[0]) + 1e-15  # t is a lower bound


def _scs_optimum(F0: np.ndarray, F: np.ndarray) -> float:
    """max t s.t. F0 + Σ x_j F_j − t I ⪰ 0 by SCS (no penalty), to 1e-9."""
    import scipy.sparse as sp
    import scs

    k, p = F0.shape[0], F.shape[0]
    il = [(i, j) for j in range(k) for i in range(j, k)]   # SCS: lower triangle by columns
    w = np.array([1.0 if i == j else np.sqrt(2.0) for i, j in il])
    A = np.zeros((len(il), p + 1))
    for c in range(p):
        A[:, c] = -w * np.array([F[c][i, j] for i, j in il])
    A[:, p] = w * np.array([1.0 if i == j else 0.0 for i, j in il])
    b = w * np.array([F0[i, j] for i, j in il])
    c = np.zeros(p + 1)
    c[-1] = -1.0
    sol = scs.SCS({"A": sp.csc_matrix(A), "b": b, "c": c}, {"s": [k]}, eps_abs=1e-10,
                  eps_rel=1e-10, max_iters=200000, verbose=False).solve()
    assert sol["info"]["status"] == "solved"
    return float(sol["x"][-1])


@pytest.mark.parametrize("k, p", [(5, 3), (9, 5), (14, 2)])
def test_random_problems_match_scs(k, p):
    """The subset sizes of the decomposition (5 × 5 with 3 parameters, 9 × 9 with 5,
    14 × 14 with 2). Bounded problems: each direction has a positive and a negative diagonal
    entry, so λ_min → −∞ along every ray. Without penalty the barrier's λ_min equals SCS's t*
    to 1e-7 (SCS at 1e-10; the barrier's path ends within k·1e-10); it is never below its own
    lower bound t."""
    g = torch.Generator().manual_seed(k * 10 + p)
    B = 6
    A = torch.randn(B, k, k, generator=g, dtype=torch.float64)
    F0 = A + A.transpose(1, 2)
    D = torch.randn(B, p, k, k, generator=g, dtype=torch.float64)
    F = 0.5 * (D + D.transpose(-1, -2))
    F[:, :, 0, 0] = 1.0
    F[:, :, 1, 1] = -1.0
    res = maximise_min_eigenvalue(F0, F, BarrierOptions(penalty=0.0))
    for i in range(B):
        ref = _scs_optimum(F0[i].numpy(), F[i].numpy())
        assert abs(float(res.min_eigenvalue[i]) - ref) < 1e-7, (i, ref)
        assert float(res.t[i]) <= float(res.min_eigenvalue[i]) + 1e-12
    # the start x = 0 is a feasible point: the optimum is no lower
    assert (res.min_eigenvalue >= torch.linalg.eigvalsh(F0)[:, 0] - 1e-12).all()
