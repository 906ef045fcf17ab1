"""The harmonic balance equations of B cases: residual and analytic Jacobian (batched).

For the per-case system of :class:`~torchrom.sim.CaseSystem` (the paper's Eq. 54 plus linear
additions, e.g. the aerodynamics of Eqs. 49–50),

    M_t q̈ + (C_0 + c M_t) q̇ + K_l q + s·[K2(q,q) + K3(q,q,q)] + g·[D̄2(q) + D̄3(q,q)] q̇ + D ξ
        = load,          ξ̇ = E q̇ + R ξ,

with M_t = M + M_add, C_0 = α M + γ D̄1 + C_add, K_l = K1 + K_add, s the stiffness switch,
g = γ·d the nonlinear damping factor and c an optional *fictitious* mass-proportional damping
(1/s, zero for a physical orbit; the cold start solves for the c that sustains an orbit of given
amplitude), a periodic orbit q(τ) = Σ a_k cos kτ + b_k sin kτ (τ = ωt,
:mod:`.fourier`) satisfies, harmonic by harmonic,

    Z_k(ω) Q_k + F_k(X, ω) = load δ_k0,     Q_k = a_k − i b_k,

    Z_k(ω) = K_l − (kω)² M_t + i kω (C_0 + c M_t) + D (ikω I − R)⁻¹ E ikω.

The lag states are linear, so they drop out exactly per harmonic (the last term): the
aerodynamics are exactly the RFA's. F_k are the harmonics of the nonlinear force, computed by
alternating frequency–time (AFT) at the alias-free sample count of :mod:`.fourier`. The real
residual stacks, for each k, the cos row Re(Z Q + F) and the sin row −Im(Z Q + F).

The Jacobian is analytic: the linear part is block-diagonal per harmonic (2n × 2n blocks
[[Re Z, Im Z], [−Im Z, Re Z]]); the nonlinear part is the AFT of the tangent matrices,

    ∂F/∂X = P [K_n(τ_j)] E + ω P [C_n(τ_j)] E',   K_n = s·(2K2(q,·) + 3K3(q,q,·)) + g ∂(D_nl q̇)/∂q,
                                                   C_n = g·(D̄2(q) + D̄3(q,q)),

evaluated for all cases and samples with the ROM's compact kernels
(:class:`torchrom.rom.kernels.CompactForces`) and contracted in one GEMM.
Written here: no library offers batched harmonic balance of this model in torch.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from ..rom.kernels import CompactForces
from ..sim.system import CaseSystem
from .fourier import FourierBasis, coefficients_from_samples, n_coefficients

Tensor = torch.Tensor


@dataclass(frozen=True)
class DampedRows:
    """The rows of a batch of states whose nonlinear damping factor g is nonzero: ``g`` (R', 1)
    their factors and ``index`` (R',) their positions, None where every row is damped. A mixed
    batch (γ = 0 cases beside damped ones: the paper's sweep lines, a certificate's first pass)
    evaluates the damping kernels on the damped rows alone (their GEMMs are about half of a
    force-and-tangent evaluation's; at small batches, where reading the coefficients bounds
    them, the gain is small)."""

    g: Tensor
    index: Tensor | None

    @classmethod
    def of(cls, g: Tensor) -> DampedRows | None:
        """From the factors g (R,) (None where no row is damped)."""
        on = g != 0
        if not bool(on.any()):
            return None
        if bool(on.all()):
            return cls(g[:, None], None)
        index = torch.nonzero(on)[:, 0]
        return cls(g[index][:, None], index)

    def take(self, *rows: Tensor) -> tuple[Tensor, ...]:
        """The damped rows of each of ``rows`` (R, ...)."""
        return rows if self.index is None else tuple(r.index_select(0, self.index) for r in rows)

    def add(self, full: Tensor, part: Tensor) -> Tensor:
        """``full`` (R, ...) with ``part`` (R', ...) added on the damped rows."""
        return full + part if self.index is None else full.index_add(0, self.index, part)


def damping_force(kernels: CompactForces, q: Tensor, v: Tensor, m2: Tensor, damped: DampedRows
                  ) -> tuple[Tensor, Tensor]:
    """(g·D_nl(q) q̇, g·D_nl(q)) of the damped rows (R', n), (R', n, n)."""
    qd, vd, m2d = damped.take(q, v, m2)
    Dm = damped.g[..., None] * kernels.damping_nl_matrix(qd, m2d)
    return (Dm @ vd[..., None])[..., 0], Dm


def force_tangents(kernels: CompactForces, q: Tensor, v: Tensor, m2: Tensor,
                   s: Tensor | float | None, damped: DampedRows | None
                   ) -> tuple[Tensor, Tensor, Tensor | None]:
    """(f_nl, K_n, C_n) of R states q, q̇ (R, n) with their quadratic monomials m2 (R, P): the
    force (R, n) and its derivatives in q and q̇ (R, n, n), from one set of the kernels'
    GEMMs. ``s``: the stiffness factors (R, 1), or 1.0 (no product), or None (no nonlinear
    stiffness); ``damped``: the rows with nonlinear damping and their factors, or None (none:
    C_n None)."""
    if s is not None:
        fs, T = kernels.stiffness_and_tangent(q, m2)
        f, Kn = (fs, T) if isinstance(s, float) and s == 1.0 else (s * fs, s[..., None] * T)
    else:
        f, Kn = torch.zeros_like(q), q.new_zeros(*q.shape, q.shape[1])
    if damped is None:
        return f, Kn, None
    fd, Dm = damping_force(kernels, q, v, m2, damped)
    qd, vd = damped.take(q, v)
    Kd = damped.g[..., None] * kernels.damping_force_tangent(qd, vd)
    Cn = Dm if damped.index is None else Kn.new_zeros(Kn.shape).index_copy_(0, damped.index, Dm)
    return damped.add(f, fd), damped.add(Kn, Kd), Cn


@dataclass
class LinearBlocks:
    """Per-case, per-harmonic linear dynamic stiffness Z_k (complex, (B, H, n, n)), its
    ω-derivative and, for k = 0, the static stiffness (B, n, n)."""

    Z: Tensor
    dZ_domega: Tensor | None
    K0: Tensor


class HarmonicBalance:
    """The HB equations of the B cases of ``system`` at H harmonics (float64 or the system's
    dtype, on the system's device).

    Args:
        system: the per-case system (structural ROM + linear additions + lag states).
        H: number of harmonics.
        n_samples: AFT samples per period (default the alias-free minimum 4H + 1).
        symmetric_kernels: the ROM's kernels with symmetric coefficient matrices as upper
            triangles (:mod:`torchrom.rom.kernels`; the shooting map's), else full rows.
        stiffness_by_tangent: the residual's stiffness force by Euler's theorem from the
            tangent's coefficients (:meth:`~torchrom.rom.kernels.CompactForces.
            stiffness_nl_by_tangent`: no cubic monomials, 5 times faster at many samples,
            equal to rounding) instead of the cubic monomials' GEMM. Off for the Newton
            solves, whose continuation paths depend on rounding (:mod:`torchrom.rom.kernels`);
            on for the Fourier certificate's residuals at 3K harmonics.
    """

    def __init__(self, system: CaseSystem, H: int, n_samples: int | None = None,
                 symmetric_kernels: bool = False, stiffness_by_tangent: bool = False):
        self.system = system
        self.stiffness_by_tangent = stiffness_by_tangent
        self.H = int(H)
        self.nh = n_coefficients(self.H)
        dev, dt = system.device, system.dtype
        self.basis = FourierBasis.build(self.H, n_samples, dev, dt)
        rom = system.rom
        self.n = n = rom.n
        self.B = B = system.batch_size
        self.kernels: CompactForces = rom.kernels(dev, dt, symmetric=symmetric_kernels)
        k = self.kernels

        def add(base: Tensor, extra: Tensor | None) -> Tensor:
            base = base.expand(B, n, n)
            return base if extra is None else base + extra

        self.Mt = add(k.M, system.M_add)
        self.C0 = (system.alpha[:, None, None] * k.M + system.gamma[:, None, None] * k.D1)
        if system.C_add is not None:
            self.C0 = self.C0 + system.C_add
        self.Kl = add(k.K1, system.K_add)
        self.s = system.stiffness_nl
        self.g = system.gamma * system.damping_nl
        self.has_stiffness = bool((self.s != 0).any())
        self.has_damping = bool((self.g != 0).any())
        self._damped: dict[int, DampedRows | None] = {}  # per samples per case
        self.load = system.load
        self.n_lag = system.n_lag
        self.k = torch.arange(1, self.H + 1, device=dev, dtype=dt)
        self._projections: Tensor | None = None

    @property
    def _PE(self) -> Tensor:
        """The Jacobian's projections of the sample-wise tangents: [P E | P E'] (nh², 2N),
        built on first use (residual-only equations at many harmonics, e.g. the Fourier
        certificate's at 9H, never need them: nh²·2N grows as H³)."""
        if self._projections is None:
            b = self.basis
            PE = (b.P[:, None, :] * b.E.T[None, :, :]).reshape(self.nh * self.nh, b.N)
            PdE = (b.P[:, None, :] * b.dE.T[None, :, :]).reshape(self.nh * self.nh, b.N)
            self._projections = torch.cat([PE, PdE], dim=1)
        return self._projections

    # -- sizes -----------------------------------------------------------------------------------
    @property
    def n_unknowns(self) -> int:
        """Fourier coefficients n(2H+1) (the Newton system adds ω and one parameter)."""
        return self.n * self.nh

    # -- linear part -----------------------------------------------------------------------------
    def linear_blocks(self, omega: Tensor, c: Tensor | None = None, derivative: bool = True
                      ) -> LinearBlocks:
        """Z_k(ω) for k = 1..H and, with ``derivative``, its ω-derivative (else None; a
        residual does not need it, and with lag states it costs a second solve per harmonic)
        (see the module docstring); ω, c (B,)."""
        k = self.k
        kw = omega[:, None] * k[None, :]  # (B, H)
        C = self.C0 if c is None else self.C0 + c[:, None, None] * self.Mt
        cplx = torch.complex128 if self.Mt.dtype == torch.float64 else torch.complex64
        Mt, C, Kl = self.Mt[:, None], C[:, None], self.Kl[:, None]
        kw4 = kw[:, :, None, None]
        Zr = Kl - kw4**2 * Mt
        Zi = kw4 * C
        if derivative:
            dZr = -2.0 * (k**2)[None, :, None, None] * omega[:, None, None, None] * Mt
            dZi = k[None, :, None, None] * C
        Z = torch.complex(Zr, Zi)
        dZ = torch.complex(dZr, dZi.expand_as(dZr)) if derivative else None
        if self.n_lag:
            sys = self.system
            s = (1j * kw).to(cplx)  # (B, H): ikω
            eye = torch.eye(self.n_lag, dtype=cplx, device=Mt.device)
            A = s[:, :, None, None] * eye - sys.lag_R[:, None].to(cplx)  # (sI − R)
            AinvE = torch.linalg.solve(A, sys.lag_E[:, None].to(cplx).expand(
                -1, self.H, -1, -1))  # (B, H, na, n)
            D = sys.lag_D[:, None].to(cplx)
            Z = Z + s[:, :, None, None] * (D @ AinvE)
            if derivative:
                # d/ds [s D (sI−R)⁻¹ E] = D (sI−R)⁻¹ (−R) (sI−R)⁻¹ E, and ds/dω = ik
                dL = D @ torch.linalg.solve(A, -sys.lag_R[:, None].to(cplx) @ AinvE)
                dZ = dZ + (1j * k.to(cplx))[None, :, None, None] * dL
        return LinearBlocks(Z, dZ, self.Kl)

    def _apply_blocks(self, Z: Tensor, K0: Tensor, X: Tensor) -> Tensor:
        """The linear force coefficients (B, nh, n) of blocks (Z_k, K0) applied to X."""
        out = torch.empty_like(X)
        out[:, 0] = (K0 @ X[:, 0, :, None])[..., 0]
        Q = torch.complex(X[:, 1::2], -X[:, 2::2])  # (B, H, n)
        F = (Z @ Q[..., None])[..., 0]
        out[:, 1::2] = F.real
        out[:, 2::2] = -F.imag
        return out

    # -- nonlinear part --------------------------------------------------------------------------
    def samples(self, X: Tensor, omega: Tensor) -> tuple[Tensor, Tensor]:
        """q and q̇ at the AFT samples, each (B, N, n)."""
        b = self.basis
        return b.E @ X, omega[:, None, None] * (b.dE @ X)

    def damped_rows(self, N: int) -> DampedRows | None:
        """The damped rows of the cases' N samples each, flattened (B·N)."""
        if N not in self._damped:
            self._damped[N] = (DampedRows.of(self.g.repeat_interleave(N)) if self.has_damping
                               else None)
        return self._damped[N]

    def nonlinear_force(self, q: Tensor, v: Tensor) -> Tensor:
        """s·[K2(q,q) + K3(q,q,q)] + g·[D̄2(q) + D̄3(q,q)] q̇ at samples (B, N, n)."""
        B, N, n = q.shape
        k = self.kernels
        q2, v2 = q.reshape(B * N, n), v.reshape(B * N, n)
        f = torch.zeros_like(q2)
        m2 = q2[:, k.pair_i] * q2[:, k.pair_j]
        if self.has_stiffness:  # the force alone, no tangent
            stiffness = k.stiffness_nl_by_tangent if self.stiffness_by_tangent else k.stiffness_nl
            f = f + self.s.repeat_interleave(N)[:, None] * stiffness(q2, m2)
        damped = self.damped_rows(N)
        if damped is not None:
            fd, _ = damping_force(k, q2, v2, m2, damped)
            f = damped.add(f, fd)
        return f.view(B, N, n)

    def nonlinear_tangents(self, q: Tensor, v: Tensor) -> tuple[Tensor, Tensor, Tensor]:
        """(f_nl, K_n, C_n) at samples: force (B, N, n) and the (B, N, n, n) derivatives in q
        and q̇ (module docstring)."""
        B, N, n = q.shape
        k = self.kernels
        q2, v2 = q.reshape(B * N, n), v.reshape(B * N, n)
        f, Kn, Cn = force_tangents(
            k, q2, v2, q2[:, k.pair_i] * q2[:, k.pair_j],
            self.s.repeat_interleave(N)[:, None] if self.has_stiffness else None,
            self.damped_rows(N))
        if Cn is None:
            Cn = q2.new_zeros(B * N, n, n)
        return f.view(B, N, n), Kn.view(B, N, n, n), Cn.view(B, N, n, n)

    # -- equations ---------------------------------------------------------------------------------
    def residual(self, X: Tensor, omega: Tensor, c: Tensor | None = None,
                 blocks: LinearBlocks | None = None) -> Tensor:
        """R (B, nh, n) for coefficients X (B, nh, n), ω (B,) rad/s, fictitious damping c;
        ``blocks``: :meth:`linear_blocks` at (ω, c) when the caller has them (several
        residuals at one ω)."""
        lin = self.linear_blocks(omega, c, derivative=False) if blocks is None else blocks
        R = self._apply_blocks(lin.Z, lin.K0, X)
        if self.has_stiffness or self.has_damping:
            q, v = self.samples(X, omega)
            R = R + coefficients_from_samples(self.nonlinear_force(q, v), self.H)
        if self.load is not None:
            R[:, 0] -= self.load
        return R

    def jacobian(self, X: Tensor, omega: Tensor, c: Tensor | None = None):
        """(R, J, R_ω, R_c): residual (B, nh, n), ∂R/∂X (B, nh·n, nh·n) (rows and columns in the
        flattened (harmonic, coordinate) order), ∂R/∂ω and ∂R/∂c (B, nh, n)."""
        B, n, nh, H = self.B, self.n, self.nh, self.H
        lin = self.linear_blocks(omega, c)
        R = self._apply_blocks(lin.Z, lin.K0, X)
        R_omega = self._apply_blocks(lin.dZ_domega, torch.zeros_like(lin.K0), X)
        # ∂R/∂c = coefficients of M_t q̇ = ω M_t (D X)
        DX = self.basis.D @ X
        R_c = omega[:, None, None] * (DX @ self.Mt.transpose(1, 2))
        if self.has_stiffness or self.has_damping:
            q, v = self.samples(X, omega)
            f, Kn, Cn = self.nonlinear_tangents(q, v)
            R = R + coefficients_from_samples(f, H)
            Nn = self.basis.N
            # one GEMM: [P E | P E'] (nh², 2N) @ [K_n; ω C_n] (2N, B n²)
            T = torch.cat([Kn, omega[:, None, None, None] * Cn], dim=1)  # (B, 2N, n, n)
            T = T.permute(1, 0, 2, 3).reshape(2 * Nn, B * n * n)
            Jn = (self._PE @ T).view(nh, nh, B, n, n)  # [k, l, b, i, j]
            # the full matrix in one pass (a zero fill and an addition of the whole matrix
            # cost as much as the GEMM); the linear blocks, on the diagonal, are added below
            J = Jn.permute(2, 0, 3, 1, 4).contiguous()
            # ∂F/∂ω: the samples of C_n (dq/dτ) projected
            dq = self.basis.dE @ X  # (B, N, n)
            R_omega = R_omega + self.basis.P @ (Cn @ dq[..., None])[..., 0]
        else:
            J = X.new_zeros(B, nh, n, nh, n)
        # the linear part: block-diagonal per harmonic (Eq. 54's linear terms)
        J[:, 0, :, 0, :] += lin.K0
        Zr, Zi = lin.Z.real, lin.Z.imag
        for k in range(1, H + 1):
            a, b = 2 * k - 1, 2 * k
            J[:, a, :, a, :] += Zr[:, k - 1]
            J[:, a, :, b, :] += Zi[:, k - 1]
            J[:, b, :, a, :] -= Zi[:, k - 1]
            J[:, b, :, b, :] += Zr[:, k - 1]
        if self.load is not None:
            R[:, 0] -= self.load
        return R, J.reshape(B, nh * n, nh * n), R_omega, R_c
