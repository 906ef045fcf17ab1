"""Compact batched force kernels of the ROM (hidden behind :class:`NonlinearROM`).

The nonlinear forces are evaluated on the distinct monomials (see :mod:`.monomials`) with a few
dense GEMMs per batch, which is what makes thousands of cases per second possible:

- stiffness  f_K(q) = K1 q + [m2(q), m3(q)] @ Kc                  (Kc: (N2 + N3, n))
- damping    D_T(q) = D1 + reshape([q, m2(q)] @ Dc, (n, n))          (Dc: (n + N2, n·n), Eq. 32)
             d = D_T(q) q̇
- tangent    ∂f_K/∂q = K1 + reshape([q, m2(q)] @ Tc, (n, n))          (Tc: (n + N2, n·n))
- damping-force tangent  ∂(D_T(q) q̇)/∂q = reshape([q̇, q ⊗ q̇] @ Gc, (n, n))
             (Gc: (n + n², n·n)): the q-derivative of the nonlinear damping force (harmonic
             balance and Floquet analysis need it; the time integrator's modified Newton does
             not)

With ``symmetric`` (the shooting map's kernels), where every coefficient matrix of Dc (resp. Tc)
is symmetric in (m, n) — always for Kelvin–Voigt damping (the Hessian of a dissipation function)
and for the tangent of a conservative ROM (the Hessian of its strain energy) — only the
N2 = n(n+1)/2 entries m ≤ n are stored and computed (half the GEMM), and a gather lays out the
full matrices (:meth:`CompactForces.matrices`). Harmonic balance keeps the full rows: its
continuation paths depend on rounding (the symmetrised coefficients, equal to 5e-15, moved the
quick paper study's γ = 0 branch onto a singular point of its H = 5 equations at 8,265 ft,
where it ended instead of at 4,000 ft).

All tensors live on one device/dtype; the kernel holds no state besides its coefficient matrices.
Written here: no library implements ROM force evaluation on monomials.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch

from .conventions import compact_from_symmetric
from .monomials import MonomialIndex, monomial_index

Tensor = torch.Tensor

#: relative asymmetry (of the largest coefficient) below which the matrices a coefficient block
#: builds are treated as symmetric (identified ROMs carry rounding of ~1e-15); the simulator's
#: damping kernel (torchrom.sim.forces) uses the same test
SYMMETRY_RTOL = 1e-12


def _upper_if_symmetric(rows: Tensor, idx: MonomialIndex) -> tuple[Tensor, bool]:
    """Coefficient rows (r, n·n) of matrices [m, j]: their upper triangles (r, N2), pairs in
    ``idx`` order, where every matrix is symmetric (to :data:`SYMMETRY_RTOL`), else as given."""
    n = idx.n
    full = rows.view(-1, n, n)
    scale = float(full.abs().max()) if full.numel() else 0.0
    if scale == 0.0 or float((full - full.transpose(1, 2)).abs().max()) > SYMMETRY_RTOL * scale:
        return rows, False
    full = 0.5 * (full + full.transpose(1, 2))
    return full[:, idx.pairs[:, 0], idx.pairs[:, 1]].contiguous(), True


@dataclass
class CompactForces:
    """Coefficient matrices for batched force evaluation on monomials."""

    n: int
    M: Tensor
    K1: Tensor
    D1: Tensor
    Kc: Tensor  # (N2 + N3, n): stiffness monomial coefficients, transposed for q-rows @ Kc
    Dc: Tensor  # (n + N2, n*n or N2): damping-matrix coefficients of [q, m2]
    Tc: Tensor  # (n + N2, n*n or N2): tangent-stiffness coefficients of [q, m2]
    Gc: Tensor  # (n + n*n, n*n): damping-force tangent coefficients of [q̇, q ⊗ q̇]
    pair_i: Tensor
    pair_j: Tensor
    triple_pair: Tensor
    triple_k: Tensor
    #: (n·n,) the column of an upper-triangle row holding each entry [m, j] (the pair index of
    #: (min, max)); used for Dc / Tc where ``damping_upper`` / ``tangent_upper``
    full_of_upper: Tensor | None = None
    damping_upper: bool = False
    tangent_upper: bool = False
    #: (Tc[:n] / 2, Tc[n:] / 3) (:meth:`stiffness_nl_by_tangent`), built on first use
    _euler: tuple[Tensor, Tensor] | None = field(default=None, repr=False)

    @classmethod
    def build(cls, M, K1, K2, K3, D1, D2, D3, device=None, dtype=torch.float64,
              symmetric: bool = False) -> CompactForces:
        n = M.shape[0]
        idx: MonomialIndex = monomial_index(n)
        c = compact_from_symmetric(K2, K3, D3)
        Kc = torch.cat([c["K2c"], c["K3c"]], dim=1).T.contiguous()
        # damping matrix D_T[m, n] = D1 + D2[m, l, n] q_l + D̃3[m, (l<=p), n] m2_(lp)
        D2rows = D2.permute(1, 0, 2).reshape(n, n * n)
        D3rows = c["D3c"].permute(1, 0, 2).reshape(idx.n_pairs, n * n)
        Dc = torch.cat([D2rows, D3rows], dim=0)
        # tangent stiffness T[m, j] = 2 K2[m, j, l] q_l + 3 K3[m, j, l, p] q_l q_p
        T2rows = (2.0 * K2).permute(2, 0, 1).reshape(n, n * n)
        mult = torch.as_tensor(idx.pair_mult, dtype=K3.dtype)
        K3pairs = K3[:, :, idx.pairs[:, 0], idx.pairs[:, 1]] * mult  # (m, j, P)
        T3rows = (3.0 * K3pairs).permute(2, 0, 1).reshape(idx.n_pairs, n * n)
        Tc = torch.cat([T2rows, T3rows], dim=0)
        damping_upper = tangent_upper = False
        if symmetric:
            Dc, damping_upper = _upper_if_symmetric(Dc, idx)
            Tc, tangent_upper = _upper_if_symmetric(Tc, idx)
        kw = {"device": device, "dtype": dtype}
        ikw = {"device": device, "dtype": torch.long}
        return cls(
            n=n,
            M=M.to(**kw),
            K1=K1.to(**kw),
            D1=D1.to(**kw),
            Kc=Kc.to(**kw),
            Dc=Dc.to(**kw),
            Tc=Tc.to(**kw),
            # ∂/∂q_j of D2_mln q_l q̇_n + D3_mlpn q_l q_p q̇_n = D2_mjn q̇_n + 2 D3_mjpn q_p q̇_n
            Gc=torch.cat([D2.permute(2, 0, 1).reshape(n, n * n),
                          (2.0 * D3).permute(2, 3, 0, 1).reshape(n * n, n * n)]).to(**kw)
            .contiguous(),
            pair_i=torch.as_tensor(idx.pairs[:, 0], **ikw),
            pair_j=torch.as_tensor(idx.pairs[:, 1], **ikw),
            triple_pair=torch.as_tensor(idx.triple_pair, **ikw),
            triple_k=torch.as_tensor(idx.triples[:, 2], **ikw),
            full_of_upper=torch.as_tensor(idx.pair_id.reshape(-1), **ikw),
            damping_upper=damping_upper,
            tangent_upper=tangent_upper,
        )

    def matrices(self, rows: Tensor, upper: bool) -> Tensor:
        """(B, n, n) matrices from GEMM rows (B, n·n), or (B, N2) upper triangles
        (``upper``, the layout of :attr:`Dc` / :attr:`Tc` when stored so)."""
        if upper:
            rows = torch.index_select(rows, 1, self.full_of_upper)
        return rows.view(-1, self.n, self.n)

    # ---------------------------------------------------------------------------------------
    def monomials(self, q: Tensor) -> tuple[Tensor, Tensor]:
        m2 = q[:, self.pair_i] * q[:, self.pair_j]
        m3 = m2[:, self.triple_pair] * q[:, self.triple_k]
        return m2, m3

    def stiffness_nl(self, q: Tensor, m2: Tensor | None = None) -> Tensor:
        """Quadratic + cubic stiffness force K2(q,q) + K3(q,q,q), (B, n)."""
        if m2 is None:
            m2 = q[:, self.pair_i] * q[:, self.pair_j]
        m3 = m2[:, self.triple_pair] * q[:, self.triple_k]
        return torch.cat([m2, m3], dim=1) @ self.Kc

    def stiffness_nl_by_tangent(self, q: Tensor, m2: Tensor | None = None) -> Tensor:
        """K2(q,q) + K3(q,q,q) (B, n) by Euler's theorem for homogeneous forms: with
        T2 = 2K2(q,·) and T3 = 3K3(q,q,·) it is (T2/2 + T3/3) q, one GEMM of [q, m2] with the
        tangent's coefficients (:attr:`Tc`) and a batched product. No cubic monomials are
        materialised: on the Goland ROM (n = 21, N3 = 1771) at 20,800 rows this took 3.7 ms
        per 325 rows against 18.5 ms for :meth:`stiffness_nl` (whose cubic monomials, written
        and read back, bound it); the two agree to 3e-15 of the force's size."""
        if m2 is None:
            m2 = q[:, self.pair_i] * q[:, self.pair_j]
        if self._euler is None:
            self._euler = (self.Tc[:self.n] / 2.0, self.Tc[self.n:] / 3.0)
        half2, third3 = self._euler
        T = self.matrices(torch.addmm(q @ half2, m2, third3), self.tangent_upper)
        return (T @ q[..., None])[..., 0]

    def damping_nl_matrix(self, q: Tensor, m2: Tensor | None = None) -> Tensor:
        """D2(q) + D3(q,q) as a (B, n, n) matrix (the nonlinear part of Eq. 32)."""
        if m2 is None:
            m2 = q[:, self.pair_i] * q[:, self.pair_j]
        return self.matrices(torch.cat([q, m2], dim=1) @ self.Dc, self.damping_upper)

    def tangent_nl(self, q: Tensor, m2: Tensor | None = None) -> Tensor:
        """2 K2(q,·) + 3 K3(q,q,·) as a (B, n, n) matrix."""
        if m2 is None:
            m2 = q[:, self.pair_i] * q[:, self.pair_j]
        return self.matrices(torch.cat([q, m2], dim=1) @ self.Tc, self.tangent_upper)

    def stiffness_and_tangent(self, q: Tensor, m2: Tensor | None = None
                              ) -> tuple[Tensor, Tensor]:
        """(K2(q,q) + K3(q,q,q), 2K2(q,·) + 3K3(q,q,·)) from the tangent's two GEMMs alone:
        with T2 = 2K2(q,·) and T3 = 3K3(q,q,·) the force is (T2/2 + T3/3) q (Euler's theorem
        for homogeneous forms) — no cubic monomials gathered, the dense GEMMs that a batch of
        many samples runs fastest."""
        if m2 is None:
            m2 = q[:, self.pair_i] * q[:, self.pair_j]
        n = self.n
        T2, T3 = q @ self.Tc[:n], m2 @ self.Tc[n:]
        # both matrices from one gather (of the upper triangles, where stored so)
        both = self.matrices(torch.cat([0.5 * T2 + T3 / 3.0, T2 + T3]),
                             self.tangent_upper).view(2, -1, n, n)
        f = (both[0] @ q[..., None])[..., 0]
        return f, both[1]

    def damping_force_tangent(self, q: Tensor, qd: Tensor, m2: Tensor | None = None) -> Tensor:
        """∂/∂q [(D2(q) + D3(q,q)) q̇] as a (B, n, n) matrix: entry [b, m, j] is
        D2_mjn q̇_n + 2 D3_mjpn q_p q̇_n (Eq. 32's damping force differentiated in q; D3 is
        symmetric in its middle two indices). ``m2`` is unused (same call as the others)."""
        y = torch.cat([qd, (q[:, :, None] * qd[:, None, :]).reshape(q.shape[0], -1)], dim=1)
        return (y @ self.Gc).view(-1, self.n, self.n)
