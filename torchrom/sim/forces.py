"""Batched nonlinear ROM forces in the layout the time integrator needs (hand-written kernels).

For a batch of B states the integrator evaluates, once per nonlinear iteration,

    f_nl = s ⊙ [K2(q,q) + K3(q,q,q)] + g ⊙ [D̄2(q) + D̄3(q,q)] q̇                 (Eq. 54, γ d = g)

with per-case scales s (the stiffness nonlinearity flag or scale) and g = γ·d (γ times the damping
nonlinearity flag). The coefficients are the ROM's combined monomial coefficients (Eqs. 25–28,
:mod:`torchrom.rom.conventions`), reordered so that the work is a few dense GEMMs with a shared
coefficient matrix and no large temporaries:

- monomials are kept *feature-major* (rows = monomials, columns = cases), so every gather copies
  contiguous rows of B values;
- quadratic monomials m2 = q_i q_j (i ≤ j) are stored in co-lexicographic order (by j, then i),
  so the pairs with j ≤ k are a prefix of m2 and the cubic force is
  Σ_k q_k ⊙ (K̃3_[:, (·,·,k)] m2[:N_k]) — the 1771 cubic monomials of a 21-mode ROM are never
  written to memory;
- the nonlinear damping matrix D̄2(q) + D̄3(q,q) (Eq. 32) is one GEMM of its coefficients with
  [q; m2]; when it is symmetric for every q (always for Kelvin–Voigt damping, where it is the
  Hessian of the dissipation function) only its upper triangle is computed (half the work).

Nothing mixes cases: every operation is a GEMM with a shared coefficient matrix or an elementwise
/ per-column operation, so a NaN in one case never reaches another.
"""

from __future__ import annotations

import numpy as np
import torch

from ..rom import NonlinearROM
from ..rom.conventions import compact_from_symmetric
from ..rom.monomials import monomial_index

Tensor = torch.Tensor

#: relative asymmetry below which the nonlinear damping matrix is treated as symmetric
DAMPING_SYMMETRY_RTOL = 1e-12


def colex_pairs(n: int) -> np.ndarray:
    """(N2, 2) pairs (i, j), i ≤ j, in co-lexicographic order: index(i, j) = j(j+1)/2 + i."""
    return np.array([(i, j) for j in range(n) for i in range(j + 1)], dtype=np.int64).reshape(-1, 2)


class NonlinearForces:
    """The nonlinear part of the ROM force for a batch, on one device and dtype.

    Args:
        rom: the structural ROM (its float64 tensors are the master copy).
        device, dtype: where and in which precision to evaluate.
        stiffness, damping: include the nonlinear stiffness / damping terms at all (the
            integrator switches a term off when every case in the batch has a zero scale for it).
    """

    def __init__(self, rom: NonlinearROM, device=None, dtype=torch.float64, *,
                 stiffness: bool = True, damping: bool = True):
        n = rom.n
        self.n = n
        self.n_pairs = n * (n + 1) // 2
        lex = monomial_index(n)
        cp = colex_pairs(n)
        lex_of_colex = lex.pair_id[cp[:, 0], cp[:, 1]]
        compact = compact_from_symmetric(rom.K2, rom.K3, rom.D3)
        kw = {"device": device, "dtype": dtype}
        self.pair_i = torch.as_tensor(cp[:, 0], device=device)
        self.pair_j = torch.as_tensor(cp[:, 1], device=device)

        # stiffness: quadratic coefficients per colex pair, cubic ones per k block
        K2c = compact["K2c"][:, lex_of_colex]  # (n, N2)
        K3c = compact["K3c"]  # (n, N3) lex
        triple_id = np.full((n, n, n), -1, dtype=np.int64)
        triple_id[lex.triples[:, 0], lex.triples[:, 1], lex.triples[:, 2]] = np.arange(
            lex.n_triples)
        self.has_k2 = bool(stiffness and K2c.abs().max() > 0)
        self.K2 = K2c.to(**kw).contiguous()
        blocks = []
        for k in range(n):
            Nk = (k + 1) * (k + 2) // 2
            ids = triple_id[cp[:Nk, 0], cp[:Nk, 1], k]
            blk = K3c[:, ids]
            # a block with no coefficient costs nothing (sparse analytic ROMs, e.g. Van der Pol)
            blocks.append(blk.to(**kw).contiguous() if blk.abs().max() > 0 else None)
        self.K3_blocks = blocks if stiffness else [None] * n
        self.has_k3 = any(b is not None for b in self.K3_blocks)
        self.has_stiffness = self.has_k2 or self.has_k3

        # damping matrix coefficients: D_nl(q)[m, p] = Σ_r x_r C[r, (m, p)], x = [q; m2(colex)]
        D2 = rom.D2  # (m, l, p): D2_mlp q_l q̇_p
        D3c = compact["D3c"][:, lex_of_colex, :]  # (m, P, p)
        coef = torch.cat([D2.permute(1, 0, 2), D3c.permute(1, 0, 2)], dim=0)  # (n + N2, m, p)
        self.has_damping = bool(damping and coef.abs().max() > 0)
        scale = float(coef.abs().max()) or 1.0
        asym = float((coef - coef.transpose(1, 2)).abs().max())
        self.symmetric_damping = asym <= DAMPING_SYMMETRY_RTOL * scale
        if self.symmetric_damping:
            coef = 0.5 * (coef + coef.transpose(1, 2))
            upper = coef[:, cp[:, 0], cp[:, 1]]  # (n + N2, N2): entries (i ≤ j)
            self.D = upper.T.to(**kw).contiguous()  # (N2, n + N2)
            full_of = np.empty((n, n), dtype=np.int64)
            for P, (i, j) in enumerate(cp):
                full_of[i, j] = full_of[j, i] = P
            self.expand = torch.as_tensor(full_of.reshape(-1), device=device)
        else:
            self.D = coef.reshape(coef.shape[0], n * n).T.to(**kw).contiguous()  # (n², n + N2)
            self.expand = None

    @property
    def active(self) -> bool:
        return self.has_stiffness or self.has_damping

    def features(self, q: Tensor) -> Tensor:
        """[q; m2(q)] feature-major, (n + N2, B)."""
        qT = q.T.contiguous()
        X = torch.empty((self.n + self.n_pairs, q.shape[0]), device=q.device, dtype=q.dtype)
        X[: self.n] = qT
        torch.mul(qT.index_select(0, self.pair_i), qT.index_select(0, self.pair_j),
                  out=X[self.n:])
        return X

    def stiffness_T(self, X: Tensor) -> Tensor:
        """K2(q,q) + K3(q,q,q), feature-major (n, B), from the features X."""
        m2 = X[self.n:]
        f = self.K2 @ m2 if self.has_k2 else None
        for k, blk in enumerate(self.K3_blocks):
            if blk is not None:
                part = blk @ m2[: blk.shape[1]]
                f = part.mul_(X[k]) if f is None else f.addcmul_(part, X[k])
        return f if f is not None else X.new_zeros(self.n, X.shape[1])

    def damping_matrix_T(self, X: Tensor) -> Tensor:
        """D̄2(q) + D̄3(q,q) per case, feature-major (n, n, B) (the nonlinear part of Eq. 32)."""
        U = self.D @ X
        if self.expand is not None:
            U = U.index_select(0, self.expand)
        return U.view(self.n, self.n, X.shape[1])

    def __call__(self, q: Tensor, v: Tensor, s: Tensor | None, g: Tensor | None) -> Tensor:
        """f_nl (B, n) for states q, q̇ (B, n) and per-case scales s, g (1, B) (None: unused).

        The result may be a transposed view (feature-major storage)."""
        X = self.features(q)
        f = None
        if self.has_damping and g is not None:
            D = self.damping_matrix_T(X)
            f = (D * v.T.unsqueeze(0)).sum(1).mul_(g)
        if self.has_stiffness and s is not None:
            fK = self.stiffness_T(X)
            f = fK.mul_(s) if f is None else f.addcmul_(fK, s)
        return f.T if f is not None else torch.zeros_like(q)
