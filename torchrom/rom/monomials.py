"""Symmetric monomial index sets used by the compact (combined) storage of the ROM tensors.

With n generalized coordinates q, the distinct quadratic monomials are q_i q_j with i ≤ j
(N2 = n(n+1)/2 of them) and the distinct cubic ones q_i q_j q_k with i ≤ j ≤ k
(N3 = n(n+1)(n+2)/6). A nonlinear force written on these monomials needs about 5× fewer
multiply-adds than the dense 4-index tensor (DESIGN, "How the batched simulator should be fast").
The ordering is lexicographic in (i, j[, k]), which is also the ordering of the paper's combined
coefficients K̃2_mnl (l ≥ n) and K̃3_mnlp (p ≥ l ≥ n), Eqs. 25–26.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
import torch


@dataclass(frozen=True)
class MonomialIndex:
    """Index arrays for the quadratic and cubic monomials of n variables.

    Attributes:
        n: number of variables.
        pairs: (N2, 2) int array of (i, j), i ≤ j.
        triples: (N3, 3) int array of (i, j, k), i ≤ j ≤ k.
        pair_mult: (N2,) number of distinct orderings of each pair (1 or 2).
        triple_mult: (N3,) number of distinct orderings of each triple (1, 3 or 6).
        triple_pair: (N3,) index into ``pairs`` of (i, j) so that m3 = m2[triple_pair] * q[k].
        pair_id: (n, n) int array, pair_id[i, j] = index of the sorted pair.
    """

    n: int
    pairs: np.ndarray
    triples: np.ndarray
    pair_mult: np.ndarray
    triple_mult: np.ndarray
    triple_pair: np.ndarray
    pair_id: np.ndarray

    @property
    def n_pairs(self) -> int:
        return len(self.pairs)

    @property
    def n_triples(self) -> int:
        return len(self.triples)


@lru_cache(maxsize=16)
def monomial_index(n: int) -> MonomialIndex:
    """Return the (cached) monomial index sets for ``n`` variables."""
    if n < 1:
        raise ValueError(f"monomial_index: n must be >= 1, got {n}")
    pairs = np.array([(i, j) for i in range(n) for j in range(i, n)], dtype=np.int64)
    pair_id = np.full((n, n), -1, dtype=np.int64)
    for p, (i, j) in enumerate(pairs):
        pair_id[i, j] = pair_id[j, i] = p
    triples = np.array(
        [(i, j, k) for i in range(n) for j in range(i, n) for k in range(j, n)], dtype=np.int64
    ).reshape(-1, 3)
    pair_mult = np.where(pairs[:, 0] == pairs[:, 1], 1, 2)
    n_distinct = np.array([len(set(t)) for t in triples.tolist()], dtype=np.int64)
    triple_mult = np.choose(n_distinct - 1, [1, 3, 6])
    triple_pair = pair_id[triples[:, 0], triples[:, 1]]
    return MonomialIndex(n, pairs, triples, pair_mult, triple_mult, triple_pair, pair_id)


def quadratic_monomials(q: torch.Tensor, index: MonomialIndex) -> torch.Tensor:
    """q_i q_j for i ≤ j; ``q`` is (..., n), result (..., N2)."""
    i = torch.as_tensor(index.pairs[:, 0], device=q.device)
    j = torch.as_tensor(index.pairs[:, 1], device=q.device)
    return q[..., i] * q[..., j]


def cubic_monomials(
    q: torch.Tensor, m2: torch.Tensor, index: MonomialIndex
) -> torch.Tensor:
    """q_i q_j q_k for i ≤ j ≤ k, built from the quadratic monomials ``m2``."""
    p = torch.as_tensor(index.triple_pair, device=q.device)
    k = torch.as_tensor(index.triples[:, 2], device=q.device)
    return m2[..., p] * q[..., k]
