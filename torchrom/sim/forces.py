"""Batched nonlinear ROM forces in the layout the time integrator needs (hand-written kernels).

For a batch of B states the integrator evaluates, once per nonlinear iteration,

    f_nl = s ⊙ [K2(q,q) + K3(q,q,q)] + g ⊙ [D̄2(q) + D̄3(q,q)] q̇                 (Eq. 54, γ d = g)

with per-case scales s (the stiffness nonlinearity flag or scale) and g = γ·d (γ times the damping
nonlinearity flag). The coefficients are the ROM's combined monomial coefficients (Eqs. 25–28,
:mod:`torchrom.rom.conventions`), reordered so that the work is a few dense GEMMs with a shared
coefficient matrix and no large temporaries:

- everything is *feature-major* (rows = monomials or coordinates, columns = cases), the layout
  of the integrator's state, so every gather copies contiguous rows of B values and every GEMM
  has the batch as its long dimension;
- quadratic monomials m2 = q_i q_j (i ≤ j) are stored in co-lexicographic order (by j, then i),
  so the pairs with j ≤ k are a prefix of m2 and the cubic force is
  Σ_k q_k ⊙ (K̃3_[:, (·,·,k)] m2[:N_k]); for large batches the 1771 cubic monomials of a 21-mode
  ROM are never written to memory (21 GEMMs on prefixes of m2), for small batches they are
  gathered and one GEMM does the work (fewer kernel launches, which dominate there);
- the nonlinear damping matrix D̄2(q) + D̄3(q,q) (Eq. 32) and the quadratic stiffness force come
  out of ONE GEMM of their stacked coefficients with x = [q; m2]; when the damping matrix is
  symmetric for every q (always for Kelvin–Voigt damping, where it is the Hessian of the
  dissipation function) only its upper triangle is computed (half the work);
- on request the same GEMM also gives the nonlinear tangent stiffness 2K2(q,·) + 3K3(q,q,·)
  (upper triangle of its symmetric part; exact for a conservative ROM), which with the damping
  matrix forms the Jacobian the integrator's iteration matrix is refreshed with.

For small ROMs the force of a nonlinear iteration has its own form (:meth:`evaluate_small`):
every monomial with a nonzero coefficient, per-case scale included, is gathered from the state
[q̇; q] and one GEMM sums them — 5 kernels instead of ~15, which is what a launch-bound step
of a few modes needs (a 3-mode ROM spends its time in kernel dispatch at any batch size).

Nothing mixes cases: every operation is a GEMM with a shared coefficient matrix or an elementwise
/ per-column operation, so a NaN in one case never reaches another.
"""

from __future__ import annotations

import numpy as np
import torch

from ..rom import NonlinearROM
from ..rom.conventions import compact_from_symmetric
from ..rom.kernels import SYMMETRY_RTOL
from ..rom.monomials import monomial_index

Tensor = torch.Tensor

#: from this many modes on the cubic stiffness of large batches runs block-wise without
#: materialising the cubic monomials (fewer bytes moved)
BLOCKED_MIN_N = 8
#: ... and from this batch size on (below it, gathering the cubic monomials and one GEMM costs
#: fewer kernel launches than the n block GEMMs; measured crossover 64–512 cases for n = 21)
BLOCKED_MIN_BATCH = 128
#: from this many modes on only the upper triangle of the symmetric damping matrix is computed
SYMMETRIC_MIN_N = 6
#: up to this many monomials with a coefficient (stiffness and damping together: 4 for the sparse
#: 3-mode demo ROM, 43 for a dense 3-mode one, ~500 at n = 8) the integrator's iterations
#: evaluate the force with :meth:`evaluate_small`
SMALL_MAX_MONOMIALS = 512


def colex_pairs(n: int) -> np.ndarray:
    """(N2, 2) pairs (i, j), i ≤ j, in co-lexicographic order: index(i, j) = j(j+1)/2 + i."""
    return np.array([(i, j) for j in range(n) for i in range(j + 1)], dtype=np.int64).reshape(-1, 2)


def _full_of_upper(pairs: np.ndarray) -> np.ndarray:
    """(n, n) index of the upper-triangle entry (row of ``pairs``) holding each entry of a
    symmetric matrix."""
    n = int(pairs.max()) + 1
    full_of = np.empty((n, n), dtype=np.int64)
    full_of[pairs[:, 0], pairs[:, 1]] = full_of[pairs[:, 1], pairs[:, 0]] = np.arange(len(pairs))
    return full_of


def _small_monomials(n: int, cp: np.ndarray, K2c: Tensor | None, K3: Tensor | None,
                     m3_pair: Tensor, m3_k: Tensor, dcoef: Tensor | None
                     ) -> tuple[Tensor, tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """Coefficients (n, M) and factor indices (i0, i1, i2) of the monomials x_{i0} x_{i1} y_{i2}
    of :meth:`NonlinearForces.evaluate_small` (x = [q̇; q], y = [g q̇; s q; s; g]) with a
    nonzero coefficient: s q_i q_j (K2, pair (i, j) colex), q_i q_j (s q_k) (gathered K3),
    q_l (g q̇_p) · 1 as q_l q̇_p g (D̄2) and q_i q_j (g q̇_p) (D̄3); ``dcoef`` (n + N2, m, p):
    the damping matrix D[m, p] = Σ_r x_r dcoef[r, m, p], x = [q; m2]."""
    S_ROW, G_ROW = 2 * n, 2 * n + 1  # rows of s and g in y
    cols, idx = [], []
    if K2c is not None:
        cols.append(K2c)
        idx.append(np.stack([n + cp[:, 0], n + cp[:, 1], np.full(len(cp), S_ROW)], 1))
    if K3 is not None:
        cols.append(K3)
        pair, k = m3_pair.numpy(), m3_k.numpy()
        idx.append(np.stack([n + cp[pair, 0], n + cp[pair, 1], n + k], 1))
    if dcoef is not None:
        # column (r, p): coefficient dcoef[r, :, p] of x_r q̇_p
        cols.append(dcoef.permute(1, 0, 2).reshape(n, -1))
        r, p = np.meshgrid(np.arange(dcoef.shape[0]), np.arange(n), indexing="ij")
        r, p = r.reshape(-1), p.reshape(-1)
        lin = r < n  # x_r = q_r: the monomial q_r q̇_p g
        pr = cp[np.maximum(r - n, 0)]
        i0 = np.where(lin, n + r, n + pr[:, 0])
        i1 = np.where(lin, p, n + pr[:, 1])
        i2 = np.where(lin, G_ROW, p)
        idx.append(np.stack([i0, i1, i2], 1))
    W = torch.cat([c.to(torch.float64) for c in cols], dim=1)
    index = np.concatenate(idx)
    keep = (W != 0).any(0).numpy()  # a monomial without a coefficient costs nothing
    index = index[keep]
    return W[:, torch.as_tensor(keep)], (index[:, 0], index[:, 1], index[:, 2])


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
        self.n_pairs = N2 = n * (n + 1) // 2
        lex = monomial_index(n)
        cp = colex_pairs(n)
        lex_of_colex = lex.pair_id[cp[:, 0], cp[:, 1]]
        compact = compact_from_symmetric(rom.K2, rom.K3, rom.D3)
        kw = {"device": device, "dtype": dtype}
        ikw = {"device": device, "dtype": torch.long}
        self.blocked = n >= BLOCKED_MIN_N
        self.pair_i = torch.as_tensor(cp[:, 0], **ikw)
        self.pair_j = torch.as_tensor(cp[:, 1], **ikw)

        # stiffness: quadratic coefficients per colex pair, cubic ones per k block (the cubic
        # monomials (i, j, k), i ≤ j ≤ k, ordered by k, then (i, j) colex)
        K2c = compact["K2c"][:, lex_of_colex]  # (n, N2)
        K3c = compact["K3c"]  # (n, N3) lex
        self.has_k2 = bool(stiffness and K2c.abs().max() > 0)
        self.has_k3 = bool(stiffness and K3c.abs().max() > 0)
        self.has_stiffness = self.has_k2 or self.has_k3
        triple_id = np.full((n, n, n), -1, dtype=np.int64)
        triple_id[lex.triples[:, 0], lex.triples[:, 1], lex.triples[:, 2]] = np.arange(
            lex.n_triples)
        # a block with no coefficient costs nothing (sparse ROMs)
        blocks = []
        for k in range(n):
            Nk = (k + 1) * (k + 2) // 2
            coef = K3c[:, triple_id[cp[:Nk, 0], cp[:Nk, 1], k]]
            if self.has_k3 and coef.abs().max() > 0:
                blocks.append((k, coef))
        self.K3_blocks = [(k, c.to(**kw).contiguous()) for k, c in blocks]
        # the same coefficients for gathered cubic monomials m3 = m2[prefix of block k] * q_k
        self.K3_gathered = (torch.cat([c for _, c in blocks], dim=1).to(**kw).contiguous()
                            if blocks else None)
        self.m3_pair = torch.as_tensor(np.concatenate(
            [np.arange(c.shape[1]) for _, c in blocks] or [np.zeros(0, np.int64)]), **ikw)
        self.m3_k = torch.as_tensor(np.concatenate(
            [np.full(c.shape[1], k) for k, c in blocks] or [np.zeros(0, np.int64)]), **ikw)

        # damping matrix coefficients: D_nl(q)[m, p] = Σ_r x_r C[r, (m, p)], x = [q; m2(colex)]
        D2 = rom.D2  # (m, l, p): D2_mlp q_l q̇_p
        D3c = compact["D3c"][:, lex_of_colex, :]  # (m, P, p)
        coef = torch.cat([D2.permute(1, 0, 2), D3c.permute(1, 0, 2)], dim=0)  # (n + N2, m, p)
        self.has_damping = bool(damping and coef.abs().max() > 0)
        scale = float(coef.abs().max()) or 1.0
        asym = float((coef - coef.transpose(1, 2)).abs().max())
        self.symmetric_damping = asym <= SYMMETRY_RTOL * scale
        if self.symmetric_damping and n >= SYMMETRIC_MIN_N:
            coef = 0.5 * (coef + coef.transpose(1, 2))
            D = coef[:, cp[:, 0], cp[:, 1]].T  # (N2, n + N2): entries (i ≤ j)
            self.expand = torch.as_tensor(_full_of_upper(cp).reshape(-1), device=device)
        else:
            # rows (p, m), p major: the product with q̇ then sums over the leading dimension
            D = coef.transpose(1, 2).reshape(coef.shape[0], n * n).T  # (n², n + N2)
            self.expand = None
        self.upper_expand = torch.as_tensor(_full_of_upper(cp).reshape(-1), device=device)
        # one GEMM for the damping matrix entries and the quadratic stiffness force
        rows = []
        self.n_damping_rows = D.shape[0] if self.has_damping else 0
        if self.has_damping:
            rows.append(D)
        if self.has_k2:
            rows.append(torch.cat([K2c.new_zeros(n, n), K2c], dim=1))
        self.W = torch.cat(rows).to(**kw).contiguous() if rows else None
        self.n_x = n + N2
        # ... and, for the Jacobian, the tangent stiffness rows after them: T[(m, j), x_r] with
        # 2 K2_mjl for x_r = q_l and 3 K3_mjlp·(orderings of l ≤ p) for x_r = q_l q_p
        self.W_jacobian = None
        if self.has_stiffness:
            mult = torch.as_tensor(np.where(cp[:, 0] == cp[:, 1], 1.0, 2.0), dtype=rom.K3.dtype)
            T = torch.cat([2.0 * rom.K2.permute(2, 0, 1),
                           3.0 * (rom.K3[:, :, cp[:, 0], cp[:, 1]] * mult).permute(2, 0, 1)])
            T = 0.5 * (T + T.transpose(1, 2))
            rows.append(T[:, cp[:, 0], cp[:, 1]].T)  # (N2, n + N2): entries (i ≤ j)
            self.W_jacobian = torch.cat(rows).to(**kw).contiguous()
        self.small = None
        if self.active:
            dcoef = torch.cat([D2.permute(1, 0, 2), D3c.permute(1, 0, 2)], dim=0)
            W, idx = _small_monomials(n, cp, K2c if self.has_k2 else None,
                                      self.K3_gathered.cpu() if self.has_k3 else None,
                                      self.m3_pair.cpu(), self.m3_k.cpu(),
                                      dcoef if self.has_damping else None)
            if W.shape[1] <= SMALL_MAX_MONOMIALS:
                # factor rows in [x; y] = [q̇; q; g q̇; s q; s; g]: x_{i0}, x_{i1}, y_{i2}
                factors = np.concatenate([idx[0], idx[1], 2 * n + idx[2]])
                self.small = (W.to(**kw).contiguous(), torch.as_tensor(factors, **ikw))

    @property
    def active(self) -> bool:
        return self.has_stiffness or self.has_damping

    def small_scales(self, s: Tensor | None, g: Tensor | None) -> tuple[Tensor, Tensor]:
        """The per-case scales of :meth:`evaluate_small` for scales s, g (1, B) (None: unused):
        (2n, B) rows [g…g; s…s] for the state [q̇; q], and (2, B) rows [s; g]."""
        ref = s if s is not None else g
        s = s if s is not None else torch.zeros_like(ref)
        g = g if g is not None else torch.zeros_like(ref)
        B = ref.shape[-1]
        return torch.cat([g.expand(self.n, B), s.expand(self.n, B)]), torch.cat([s, g])

    def evaluate_small(self, z: Tensor, z_scale: Tensor, sg: Tensor) -> Tensor:
        """f_nl (n, B) of the state z = [q̇; q] (2n, B), feature-major, with the scales of
        :meth:`small_scales`: every monomial x_a x_b y_c of a nonzero coefficient, y the scaled
        state [g q̇; s q; s; g], in one GEMM (for ROMs with ``small`` set: a few modes)."""
        W, factors = self.small
        # rows [x; y]: the three factors of every monomial in one gather, multiplied by prod
        xy = torch.cat([z, z * z_scale, sg])
        return W @ xy.index_select(0, factors).view(3, W.shape[1], -1).prod(0)

    def features_T(self, qT: Tensor) -> Tensor:
        """x = [q; m2(colex)], feature-major (n + N2, B), from q feature-major (n, B)."""
        m2 = qT.index_select(0, self.pair_i).mul_(qT.index_select(0, self.pair_j))
        return torch.cat([qT, m2])

    def cubic_T(self, qT: Tensor, m2: Tensor, out: Tensor | None) -> Tensor | None:
        """K3(q,q,q) added to ``out`` (n, B) (None: a new tensor, or None without cubic terms)."""
        if not self.K3_blocks:
            return out
        if self.blocked and qT.shape[1] >= BLOCKED_MIN_BATCH:
            for k, blk in self.K3_blocks:
                part = blk @ m2[: blk.shape[1]]
                out = part.mul_(qT[k]) if out is None else out.addcmul_(part, qT[k])
            return out
        m3 = m2.index_select(0, self.m3_pair).mul_(qT.index_select(0, self.m3_k))
        part = self.K3_gathered @ m3
        return part if out is None else out.add_(part)

    def evaluate_T(self, qT: Tensor, vT: Tensor, s: Tensor | None, g: Tensor | None,
                   jacobian: bool = False):
        """f_nl feature-major (n, B) for q, q̇ feature-major (n, B) and per-case scales s, g
        (1, B) (None: that term unused).

        With ``jacobian``: (f_nl, K, D) where K = 2K2(q,·) + 3K3(q,q,·) (symmetric part) and
        D = D̄2(q) + D̄3(q,q), unscaled, each (n, n, B) laid out for a per-case product
        Σ_k A[k] x[k] (entry [k, m] = matrix[m, k]), or None where that term is unused."""
        n, B = self.n, qT.shape[1]
        X = self.features_T(qT)
        W = self.W_jacobian if jacobian and self.W_jacobian is not None else self.W
        U = W @ X if W is not None else None
        f = Dm = fK = None
        if self.has_damping and g is not None:
            Dm = U[: self.n_damping_rows]
            if self.expand is not None:
                Dm = Dm.index_select(0, self.expand)
            # Σ_p D[p, m] q̇_p over the leading dimension (rows (p, m)): streams Dm once
            Dm = Dm.view(n, n, B)
            f = (Dm * vT.unsqueeze(1)).sum(0).mul_(g)
        if self.has_stiffness and s is not None:
            if self.has_k2:
                fK = U[self.n_damping_rows: self.n_damping_rows + n]
            fK = self.cubic_T(qT, X[n:], fK)
            f = fK.mul_(s) if f is None else f.addcmul_(fK, s)
        f = f if f is not None else torch.zeros_like(qT)
        if not jacobian:
            return f
        Kt = None
        if self.W_jacobian is not None and s is not None:
            Kt = U[-self.n_pairs:].index_select(0, self.upper_expand).view(n, n, B)
        return f, Kt, Dm

    def __call__(self, q: Tensor, v: Tensor, s: Tensor | None, g: Tensor | None) -> Tensor:
        """f_nl (B, n) for states q, q̇ (B, n) and per-case scales s, g (1, B) (None: unused).

        The result may be a transposed view (the kernel works feature-major)."""
        return self.evaluate_T(q.T.contiguous(), v.T.contiguous(), s, g).T
