"""A certificate that separates time scales: the slow motion certified by Newton–Kantorovich
with the stiff dual coordinates eliminated, the neglected fast dynamics bounded from the
computed orbit (issue 48).

Split q = (l, d): the slow coordinates l and the dual ones d (:func:`~.solve.dual_coordinates`;
the model must condense them, :func:`~.floquet.condensable`: no mass, lag or added coupling).
Their rows, M_dd d̈ + C q̇ + K_d q + f_d(q, q̇) = 0, are solved on the orbit pointwise in time:

1. the static part K_dd h + K_dl l + f_d(l, h, 0) = 0 by Newton per AFT sample
   (:data:`DUAL_ITERATIONS` steps; the ROM's duals answer the slow motion quadratically, and
   the exact h is cheaper than its truncated series);
2. the dynamic part by chord steps with that static tangent T_dd(τ), d ← d − T_dd⁻¹ r_d(d)
   (:data:`FAST_ITERATIONS`; r_d the whole dual rows' residual, its time derivatives spectral on
   harmonics ≤ k*): the quasi-static response plus its corrections for the duals' inertia and
   damping, a Neumann series whose ratio on harmonic k is ρ_k = (kω)² ‖T_dd⁻¹M_dd‖ + kω
   ‖T_dd⁻¹C_dd‖ — the iterative improvement of a slow manifold (Fenichel's geometric singular
   perturbation theory; Kristiansen, Brøns & Starke, "An iterative method for the
   approximation of fibers in slow-fast systems", SIAM J. Appl. Dyn. Syst. 2014).
   k* (:func:`fast_limit`) is the highest harmonic with ρ_k ≤ :data:`RHO_MAX` along the orbit.

The slow map G(X, ω) (:class:`SlowSystem`) is then the slow rows' residual with d eliminated:
their linear part per harmonic (lag states exactly), the rest by AFT at 4K_R + 1 samples (not
a polynomial: its harmonics decay geometrically and the samples resolve them far beyond
K_R). Its Jacobian is the condensed tangent (:func:`condensed_tangents`, the Schur complement
T_ll − T_ld T_dd⁻¹ T_dl pointwise in time with the first corrections for the duals' damping
and inertia, as :mod:`.floquet`), assembled per harmonic pair from the tangent's Fourier
coefficients (:func:`multiplication_operator`), so the 800–5,700× raw-coordinate effect of the
duals' quadratic coupling (:mod:`.fourier_certificate`) never enters.

The orbit is solved at K = min(19, k*/2) harmonics by Newton from the method's orbit
(:func:`solve_slow`) and certified by two chord steps, as :mod:`.fourier_certificate` does
(a Newton–Kantorovich estimate with an approximate inverse A; cf. the radii-polynomial
approach for Fourier series with non-polynomial nonlinearities, Lessard, Mireles James &
Ransford, Physica D 334, 2016): A is the bordered condensed Jacobian on harmonics ≤ 2K
(factored once) and the mean condensed dynamic stiffness per harmonic above (quasi-static
above k*), δ₀ = A G(X) with the residual at 2K harmonics, δ₁ = A G(X − δ₀) at 3K, κ =
‖δ₁‖/‖δ₀‖ (‖δ₀‖ at least :data:`ROUNDING` of the orbit), κ ≤ 1/4 required. The neglected fast
dynamics enter η as a perturbation of the slow rows mapped through A: the next dual correction
z (what step 2 would add, times 1/(1 − ρ), ρ its measured ratio, ≤ 1/2), and above k* the
quasi-static duals' harmonics amplified by the mean dual operator's gain ‖(T̄_dd − (kω)² M_dd +
ikω C̄_dd)⁻¹ T̄_dd‖ + 1 (:func:`_above_dynamic`). Then ‖X* − X₁‖ ≤ η e(κ) + (fast part),
e(κ) of :func:`~.fourier_certificate.kantorovich_excess`. Each output y = c_l l + c_d d of the
corrected orbit X₁ has its amplitude enclosed by samples at 16,384 phases, and moves by at most
max_τ ‖c_l + Sᵀ c_d‖₂ (S = −T_dd⁻¹T_dl: the slow error carried onto the duals) times that
distance plus |c_d · z| (the duals' own); the frequency by that distance over the orbit's size.
Stability: :mod:`.floquet` on the corrected orbit (the condensed monodromy) and the duals' own
decay (:func:`~.floquet.condensed_multiplier`), the larger.

Measured (issue 48) on the ``bench_lco --quick`` harmonic-balance rows against the RK4 ODE
orbit of tests/ode_reference.py (12,500 steps per period; the damped rows' truths computed on
the same model in the same process), 0.10 CPU s per row (one thread, batches of 10):

- γ = 1e-3, 4,000–10,000 ft: K = 8 (k* = 16–17: the duals' Kelvin–Voigt damping limits it),
  κ = 0.011–0.036, every row certified and every bound holding: A_Tz bounds 1.3e-6–1.0e-5
  (errors 1.7e-7–9.3e-7), A_Tx 7.9e-5–5.1e-4 (5.7e-7–9.4e-6), A_Ty 7.8e-6–5.9e-5
  (2.3e-7–2.7e-6), max_mode1 2.1e-6–1.6e-5 (2.1e-7–7.3e-7), frequency 1.0e-6–7.8e-6
  (1.5e-9–6.3e-7); critical multipliers 0.4316–0.7870 against the ODE's 0.4314–0.7868.
- γ = 0, 10,000 ft: K = 11, κ = 0.066, certified: A_Tz 2.2e-4 off against 7.9e-4, A_Tx
  1.2e-4 / 2.5e-2, A_Ty 3.9e-4 / 4.5e-3, max_mode1 2.2e-4 / 1.2e-3, frequency 6.4e-6 /
  6.1e-4, multiplier 0.9307 against 0.9294 (stable, as the ODE).
- γ = 0, 8,500 ft: κ = 0.19, every bound holding (A_Tz 7.7e-4 / 3.1e-3) but above the 1e-3
  tolerance; 4,000–7,000 ft refused (κ = 0.35–0.80, and the condensed monodromy's trivial
  multiplier not resolved at 4,000 and 7,000 ft).
- γ = 1e-4 (4,000, 5,500, 10,000 ft, which the Fourier certificate refuses but 10,000 ft):
  10,000 ft certified (A_Tz 3.1e-7 / 6.2e-5); 4,000 and 5,500 ft refused (κ = 0.23, 0.12,
  their monodromy's trivial multiplier more than 0.05 off).

Why the γ = 0 rows at 4,000–8,500 ft stay refused: there is no separation of time scales to
exploit. The slowest dual mode along those orbits is at 62–69 Hz (the tangent's, min over τ),
harmonic 32–35 of the 1.94–1.96 Hz LCO, and the slow orbit has a resonance at harmonics 20–21
(its K = 19 residual peaks there, 200–260 at 4,000 ft against 0.02–0.6 below): the harmonics
the orbit needs reach (kω/ω_d)² ≈ 0.4–1. With the duals' corrections on 25–31 harmonics the
Neumann series diverged (ratio 0.6–6e170); with them held to ρ ≤ 1/2 (k* ≈ 22, K = 11) κ is
0.35–0.80 at 4,000–7,000 ft and 0.19 at 8,500 ft, whose A_Tz bound (3.1e-3, against an error
of 7.7e-4) is above the 1e-3 tolerance; at K = 15 or 19 with the corrections still held to k*
the duals' content above k* (amplified by their gain near harmonic 32) dominates η and the
bounds grow 2–25 times. With the exact slow-map Jacobian (matrix-free, GMRES with A as
preconditioner) on 38 harmonics κ was 0.04 (10,000 ft), 0.07 (8,500 ft), 0.73 (4,000 ft), but
0.64 at 10,000 ft once the residual's harmonics 39–57 (above the duals) enter: the slow map is
not contracting there, whatever its inverse; three preconditioned Richardson steps with that
Jacobian (differences of the map) diverged (κ 1.3–220).

Written here: the certificate composes this project's harmonic balance and Floquet solver.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..sim.system import CaseSystem
from .balance import HarmonicBalance, force_tangents
from .fourier import (
    FourierBasis,
    coefficients_from_samples,
    parabolic_extreme,
    resize_harmonics,
)
from .fourier_certificate import (
    MAX_CONTRACTION,
    kantorovich_excess,
    sampled_amplitude,
    state_norm,
)
from .newton import equilibrated_lu
from .solve import dual_coordinates

Tensor = torch.Tensor

#: Newton iterations of the pointwise static dual equations (quadratic convergence from the
#: previous iterate's duals: 1e-16 relative in 3 on the Goland orbits)
DUAL_ITERATIONS = 3
#: AFT samples per period as a multiple of the residual's harmonics (the slow force on the
#: slow manifold is not a polynomial: its harmonics decay geometrically, the samples resolve
#: them far beyond the residual's harmonics)
SAMPLE_FACTOR = 4
#: Newton iterations of the slow system's orbit from a harmonic-balance row
SLOW_NEWTON_ITERATIONS = 8
#: the slow orbit's Newton stops when the scaled correction is below this
SLOW_NEWTON_TOL = 1e-11
#: the orbit's harmonics (2H + 1 of the harmonic-balance rows' H = 9: the slow modes'
#: resonant harmonics 12–15 inside, the slowest dual along the Goland γ = 0 orbits, 62–69 Hz,
#: at harmonics 32–35, above the 2K = 38 of the residual only by the ratio it needs)
SLOW_HARMONICS = 19
#: the fewest harmonics of a slow orbit (below, the certificate refuses the row: the duals'
#: dynamic corrections do not converge at the harmonics the orbit needs)
MIN_SLOW_HARMONICS = 5
#: the largest convergence ratio of the duals' dynamic corrections on a harmonic they act on
#: (:func:`fast_limit`; their remainder is then at most the last correction again)
RHO_MAX = 0.5
#: relative size of the chord steps that is rounding (the residual's 1e-16 of the forces
#: through the inverse): κ is measured against at least this much
ROUNDING = 1e-12
#: phases at which the corrected orbit's outputs are sampled for their amplitudes: the
#: enclosure ½ (π/P)² Σ k²|Y_k| is 1.8e-8 of Σ k²|Y_k|
AMPLITUDE_SAMPLES = 16384
#: the slow orbit's Newton is accepted below this scaled step (its bound takes the rest)
SLOW_NEWTON_ACCEPT = 1e-6
#: the stability tolerance of :mod:`.floquet`
STABILITY_TOL = 1e-6
#: dynamic corrections of the duals' quasi-static response (chord steps on their rows)
FAST_ITERATIONS = 3
#: the approximate inverse's coupled harmonics, a multiple of the orbit's
COUPLED = 2
#: the harmonics (a multiple of the orbit's) on which the duals' dynamic corrections act
DYNAMIC = 1
#: the second chord step's residual harmonics, a multiple of the orbit's
SECOND = 3


def split_coordinates(system: CaseSystem) -> tuple[Tensor, Tensor]:
    """(slow, dual) coordinate indices."""
    duals = dual_coordinates(system)
    mask = torch.ones(system.n, dtype=torch.bool, device=system.device)
    mask[duals] = False
    return torch.nonzero(mask).reshape(-1), duals


@dataclass
class SlowState:
    """The full motion on the slow manifold of slow coefficients X (B, 2K+1, nl) at ω:
    samples (B, N, ·) of q, q̇ (full), the tangents K_t = K_l + K_n, C_t = C_0 + C_n (B, N,
    n, n), the slow residual's coefficients R (B, 2K_R+1, nl), the next dual correction z that
    the map leaves out (samples (B, N, nd): the neglected fast dynamics), the full coefficients
    of q (B, 2K_R+1, n), the static duals h (samples) and the sup of each dual correction
    taken (B, FAST_ITERATIONS + 1), the neglected one last."""

    q: Tensor
    v: Tensor
    Kt: Tensor
    Ct: Tensor
    R: Tensor
    neglected: Tensor
    Xfull: Tensor
    h: Tensor
    corrections: Tensor


class SlowSystem:
    """The slow equations of the B cases of ``system`` at K harmonics (module docstring):
    residuals at K_R ≥ K harmonics from N samples."""

    def __init__(self, system: CaseSystem, K: int, K_R: int, N: int | None = None,
                 dynamic: int | None = None):
        self.system = system
        self.K, self.K_R = int(K), int(K_R)
        self.dynamic = min(int(dynamic or K_R), self.K_R)
        self.N = N = int(N or (SAMPLE_FACTOR * self.K_R + 1) | 1)
        # the force by Euler's theorem from the tangent's coefficients (5 times faster at many
        # samples, equal to rounding: :class:`~.balance.HarmonicBalance`)
        self.hb = hb = HarmonicBalance(system, self.K_R, stiffness_by_tangent=True)
        self.lin, self.duals = split_coordinates(system)
        dev, dt = system.device, system.dtype
        self.basis = FourierBasis.build(self.K_R, N, dev, dt)
        l, d = self.lin, self.duals
        self.n, self.nl, self.nd = system.n, l.numel(), d.numel()
        self.Mdd = hb.Mt[:, d][:, :, d]
        self.load = system.load

    # -- helpers --------------------------------------------------------------------------------
    def _derivative_samples(self, y: Tensor, omega: Tensor, order: int) -> Tensor:
        """d^order y/dt^order at the samples of periodic samples y (B, N, m), spectrally, its
        harmonics up to ``dynamic`` (the same for every evaluation of one certificate)."""
        f = FourierBasis.build(self.dynamic, self.N, y.device, y.dtype)
        c = coefficients_from_samples(y, f.H)
        for _ in range(order - 1):
            c = f.D @ c
        return omega[:, None, None] ** order * (f.dE @ c)

    def _stiffness(self, q: Tensor) -> tuple[Tensor, Tensor]:
        """The nonlinear stiffness force and its tangent at samples q (B, N, n) (no damping:
        the static equations)."""
        B, N, n = q.shape
        hb = self.hb
        if not hb.has_stiffness:
            return torch.zeros_like(q), q.new_zeros(B, N, n, n)
        k = hb.kernels
        q2 = q.reshape(B * N, n)
        f, Kn, _ = force_tangents(k, q2, q2, q2[:, k.pair_i] * q2[:, k.pair_j],
                                  hb.s.repeat_interleave(N)[:, None], None)
        return f.view(B, N, n), Kn.view(B, N, n, n)

    def _full(self, ql: Tensor, qd: Tensor) -> Tensor:
        q = ql.new_zeros(*ql.shape[:-1], self.n)
        q[..., self.lin] = ql
        q[..., self.duals] = qd
        return q

    # -- the slow map ---------------------------------------------------------------------------
    def evaluate(self, X: Tensor, omega: Tensor, h0: Tensor | None = None) -> SlowState:
        """The slow map at slow coefficients X (B, 2K'+1, nl) (K' ≤ K_R) and ω (B,);
        ``h0`` (B, N, nd): a start for the static duals (else zero)."""
        hb, b = self.hb, self.basis
        l, d = self.lin, self.duals
        Xr = resize_harmonics(X, self.K_R)
        ql = b.E @ Xr
        vl = omega[:, None, None] * (b.dE @ Xr)
        B, N = ql.shape[:2]
        hd = ql.new_zeros(B, N, self.nd) if h0 is None else h0.clone()
        Kl = hb.Kl[:, None]
        load_d = None if self.load is None else self.load[:, None, d]
        # the static dual equations K_dd h + K_dl q_l + f_d(q_l, h) = load_d, pointwise
        for j in range(DUAL_ITERATIONS + 1):
            q = self._full(ql, hd)
            f, Kn = self._stiffness(q)
            T = Kl[..., d, :][..., d] + Kn[..., d, :][..., d]
            if j == DUAL_ITERATIONS:
                break
            s = (Kl[..., d, :] @ q[..., None])[..., 0] + f[..., d]
            if load_d is not None:
                s = s - load_d
            hd = hd - torch.linalg.solve(T, s[..., None])[..., 0]
        Tdd = T
        C0 = hb.C0[:, None]
        lu = torch.linalg.lu_factor(Tdd)
        # the dynamic corrections: chord steps of the dual rows with their quasi-static
        # tangent, M_dd q̈_d + C q̇ + ... = 0 (a Neumann series in the duals' inertia and
        # damping, ratio max((kω/ω_d)², kω c_d/k_d) on harmonic k)
        qd = hd
        sizes = []
        for j in range(FAST_ITERATIONS + 1):
            dqd = self._derivative_samples(qd, omega, 1)
            ddqd = self._derivative_samples(qd, omega, 2)
            q = self._full(ql, qd)
            v = self._full(vl, dqd)
            last = j == FAST_ITERATIONS
            if last:
                f, Kn, Cn = hb.nonlinear_tangents(q, v)
            else:
                f = hb.nonlinear_force(q, v)
            lin_force = (Kl @ q[..., None])[..., 0] + (C0 @ v[..., None])[..., 0] + f
            r_dual = lin_force[..., d] + (self.Mdd[:, None] @ ddqd[..., None])[..., 0]
            if load_d is not None:
                r_dual = r_dual - load_d
            z = -torch.linalg.lu_solve(*lu, r_dual[..., None])[..., 0]
            sizes.append(z.abs().amax(dim=(1, 2)))
            if j < FAST_ITERATIONS:
                qd = qd + z
        # the slow rows: their linear part per harmonic (lag states exactly), the rest sampled
        slow_force = lin_force[..., l] - (Kl[..., l, :][..., l] @ ql[..., None])[..., 0] - (
            C0[..., l, :][..., l] @ vl[..., None])[..., 0]
        blocks = hb.linear_blocks(omega, derivative=False)
        Zll = blocks.Z[:, :, l][..., l]
        R = hb._apply_blocks(Zll, hb.Kl[:, l][:, :, l], Xr) + coefficients_from_samples(
            slow_force, self.K_R)
        if self.load is not None:
            R[:, 0] -= self.load[:, l]
        Xfull = coefficients_from_samples(q, self.K_R)
        return SlowState(q, v, Kl + Kn, C0 + Cn, R, z, Xfull, hd, torch.stack(sizes, 1))


# -- the condensed tangent and its harmonic-balance Jacobian --------------------------------------
def multiplication_operator(T: Tensor, K: int) -> Tensor:
    """(B, 2K+1, a, 2K+1, b): the real-coefficient matrix of q ↦ T(τ) q (harmonics 0..K on
    both sides) for a periodic matrix T with samples (B, N, a, b) at τ_j = 2πj/N (N > 4K):
    with T's complex coefficients c_p, column cos mτ maps to Re/−Im of c_{k−m} + c_{k+m} in
    the cos/sin rows of harmonic k, column sin mτ to Im/Re of c_{k−m} − c_{k+m} (row 0 half
    of the cos row's)."""
    B, N, a, b = T.shape
    c = torch.fft.fft(T, dim=1) / N  # c[p] = c_p, c[N − p] = c_{−p}
    k = torch.arange(K + 1, device=T.device)
    minus = c[:, (k[:, None] - k[None, :]) % N]  # (B, K+1, K+1, a, b)
    plus = c[:, (k[:, None] + k[None, :]) % N]
    A, D = minus + plus, minus - plus
    nh = 2 * K + 1
    J = T.new_zeros(B, nh, nh, a, b)
    ra = torch.cat([torch.zeros(1, dtype=torch.long, device=T.device), 2 * k[1:] - 1])
    rb = 2 * k[1:]  # the rows (columns) of a_0, a_1, ... and of b_1, b_2, ...
    half = torch.ones(K + 1, dtype=T.dtype, device=T.device)
    half[0] = 0.5
    h = half[None, :, None, None, None]
    J[:, ra[:, None], ra[None, :]] = h * A.real
    J[:, ra[:, None], rb[None, :]] = (h * D.imag)[:, :, 1:]
    J[:, rb[:, None], ra[None, :]] = -A.imag[:, 1:]
    J[:, rb[:, None], rb[None, :]] = D.real[:, 1:, 1:]
    return J.permute(0, 1, 3, 2, 4)


def condensed_tangents(slow: SlowSystem, state: SlowState, omega: Tensor
                       ) -> tuple[Tensor, Tensor, Tensor]:
    """(K̃, C̃, M̃) samples (B, N, nl, nl): the tangent of the slow rows with the dual
    coordinates condensed (their quasi-static response and its first corrections for their
    damping and inertia, as :func:`~.floquet._condensed_matrices`, in time derivatives):

        δd = (S + Q S̈ − T_dd⁻¹ C_dd Ṡ) δl + (P + 2 Q Ṡ) δl̇ + Q S δl̈,
        S = −T_dd⁻¹ T_dl,  P = −T_dd⁻¹ (C_dl + C_dd S),  Q = −T_dd⁻¹ M_dd,

    M̃ = M_ll + T_ld Q S, C̃ = C_ll + C_ld S + T_ld (P + 2QṠ), K̃ = T_ll + C_ld Ṡ +
    T_ld (S + QS̈ − T_dd⁻¹ C_dd Ṡ)."""
    l, d = slow.lin, slow.duals
    Kt, Ct = state.Kt, state.Ct

    def part(T, rows, cols):
        return T[..., rows, :][..., cols]

    lu = torch.linalg.lu_factor(part(Kt, d, d))

    def solve(rhs):
        return torch.linalg.lu_solve(*lu, rhs)

    B, N = Kt.shape[:2]
    S = -solve(part(Kt, d, l))
    nd, nl = slow.nd, slow.nl
    dS = slow._derivative_samples(S.reshape(B, N, nd * nl), omega, 1).view(B, N, nd, nl)
    ddS = slow._derivative_samples(S.reshape(B, N, nd * nl), omega, 2).view(B, N, nd, nl)
    Cdd = part(Ct, d, d)
    Q = -solve(slow.Mdd[:, None].expand(-1, N, -1, -1))
    P = -solve(part(Ct, d, l) + Cdd @ S)
    Tld, Cld = part(Kt, l, d), part(Ct, l, d)
    M = slow.hb.Mt[:, None][..., l, :][..., l] + Tld @ (Q @ S)
    C = part(Ct, l, l) + Cld @ S + Tld @ (P + 2 * Q @ dS)
    Kc = part(Kt, l, l) + Cld @ dS + Tld @ (S + Q @ ddS - solve(Cdd @ dS))
    return Kc, C, M, S, part(Kt, l, l) + Tld @ S


def slow_jacobian(slow: SlowSystem, state: SlowState, X: Tensor, omega: Tensor, K: int
                  ) -> tuple[Tensor, Tensor]:
    """(J (B, (2K+1)·nl, (2K+1)·nl), R_ω (B, 2K+1, nl)): the harmonic-balance Jacobian of the
    slow residual at harmonics 0..K from the condensed tangent (:func:`condensed_tangents`),
    its linear slow part (lag states exactly) per harmonic; X the slow coefficients at K."""
    hb = slow.hb
    l = slow.lin
    Kc, Cc, Mc, _, _ = condensed_tangents(slow, state, omega)
    Mll = hb.Mt[:, l][:, :, l]
    Cll = hb.C0[:, l][:, :, l]
    Kll = hb.Kl[:, l][:, :, l]
    B, nl = X.shape[0], slow.nl
    nh = 2 * K + 1
    Dk = FourierBasis.build(K, device=X.device, dtype=X.dtype).D
    JK = multiplication_operator(Kc - Kll[:, None], K)
    JC = multiplication_operator(Cc - Cll[:, None], K)
    JM = multiplication_operator(Mc - Mll[:, None], K)
    w = omega[:, None, None, None, None]
    # q̇ ↦ ω D X, q̈ ↦ ω² D² X on the columns' harmonic index
    J = JK + w * torch.einsum("bkimj,ml->bkilj", JC, Dk) + w ** 2 * torch.einsum(
        "bkimj,ml->bkilj", JM, Dk @ Dk)
    Xk = resize_harmonics(X, K)
    R_w = (torch.einsum("bkimj,ml,blj->bki", JC, Dk, Xk)
           + 2 * omega[:, None, None] * torch.einsum("bkimj,ml,blj->bki", JM, Dk @ Dk, Xk))
    sub = HarmonicBalance(slow.system, K)
    blocks = sub.linear_blocks(omega, derivative=True)
    Z, dZ = blocks.Z[:, :, l][..., l], blocks.dZ_domega[:, :, l][..., l]
    R_w = R_w + sub._apply_blocks(dZ, torch.zeros_like(Kll), Xk)
    J[:, 0, :, 0, :] += Kll
    for k in range(1, K + 1):
        a, b = 2 * k - 1, 2 * k
        J[:, a, :, a, :] += Z[:, k - 1].real
        J[:, a, :, b, :] += Z[:, k - 1].imag
        J[:, b, :, a, :] -= Z[:, k - 1].imag
        J[:, b, :, b, :] += Z[:, k - 1].real
    return J.reshape(B, nh * nl, nh * nl), R_w


def bordered_lu(J: Tensor, R_w: Tensor, phase_row: Tensor, nl: int):
    """The factors of [[J, R_ω], [phase, 0]] (the phase condition r·b₁ = 0 on the slow
    coordinates)."""
    B, m = J.shape[0], J.shape[1]
    A = J.new_zeros(B, m + 1, m + 1)
    A[:, :m, :m] = J
    A[:, :m, m] = R_w.reshape(B, -1)
    A[:, m, 2 * nl: 3 * nl] = phase_row
    return equilibrated_lu(A)


def bordered_solve(lu, R: Tensor, X: Tensor, phase_row: Tensor) -> tuple[Tensor, Tensor, Tensor]:
    """(δX, δω, ok) from the bordered factors for residual R (B, 2K+1, nl)."""
    B = R.shape[0]
    rhs = torch.cat([R.reshape(B, -1), (X[:, 2] @ phase_row)[:, None]], dim=1)
    sol, ok = lu.solve(rhs)
    return sol[:, :-1].view_as(R), sol[:, -1], ok


def phase_angle(X: Tensor, phase_row: Tensor) -> Tensor:
    """(B,) the phase φ at which the output r·q of coefficients X (B, 2K+1, m) has its
    harmonic 1 at its maximum (r = ``phase_row``)."""
    return torch.atan2(X[:, 2] @ phase_row, X[:, 1] @ phase_row)


def rotated(X: Tensor, phi: Tensor) -> Tensor:
    """The coefficients of q(τ + φ) for q's X (B, 2K+1, m), φ (B,)."""
    K = (X.shape[1] - 1) // 2
    k = torch.arange(1, K + 1, dtype=X.dtype, device=X.device)
    c, s = torch.cos(k * phi[:, None])[..., None], torch.sin(k * phi[:, None])[..., None]
    out = X.clone()
    out[:, 1::2] = X[:, 1::2] * c + X[:, 2::2] * s
    out[:, 2::2] = X[:, 2::2] * c - X[:, 1::2] * s
    return out


@dataclass
class SlowOrbit:
    """The slow system's orbit: slow coefficients X (B, 2K+1, nl), ω (B,), the duals' samples
    ``h`` of its static part (a start for later evaluations), Newton's last scaled step and
    whether it converged."""

    X: Tensor
    omega: Tensor
    h: Tensor
    step: Tensor
    converged: Tensor


def solve_slow(system: CaseSystem, X: Tensor, omega: Tensor, K: int, phase_row: Tensor,
               iterations: int = SLOW_NEWTON_ITERATIONS, dynamic: int | None = None
               ) -> SlowOrbit:
    """The slow system's orbit at K harmonics by Newton from the full orbits X (B, 2H+1, n),
    ω (B,) (their slow part, rotated to the phase condition on the slow part of
    ``phase_row`` (n,))."""
    slow = SlowSystem(system, K, K, dynamic=dynamic)
    l, d = slow.lin, slow.duals
    r = phase_row[l]
    Xf = resize_harmonics(X, K)
    Xf = rotated(Xf, phase_angle(Xf[..., l], r))
    Xl = Xf[..., l].contiguous()
    h = slow.basis.E @ Xf[..., d]
    step = torch.full_like(omega, math.inf)
    for _ in range(iterations):
        state = slow.evaluate(Xl, omega, h)
        h = state.h
        J, R_w = slow_jacobian(slow, state, Xl, omega, K)
        dX, dw, ok = bordered_solve(bordered_lu(J, R_w, r, slow.nl), state.R, Xl, r)
        Xl, omega = Xl - dX, omega - dw
        size = Xl.abs().amax(dim=(1, 2))
        step = torch.maximum(dX.abs().amax(dim=(1, 2)) / size, (dw / omega).abs())
        step = torch.where(ok, step, torch.full_like(step, math.inf))
        if bool((step < SLOW_NEWTON_TOL).all()):
            break
    return SlowOrbit(Xl, omega, h, step, step < SLOW_NEWTON_TOL * 100)


# -- the certificate ------------------------------------------------------------------------------
class SlowInverse:
    """The approximate inverse of the slow equations' Jacobian at an orbit (module docstring):
    the bordered condensed-tangent Jacobian on harmonics 0..K (factored once), the mean
    condensed dynamic stiffness Z̃_k(ω) per harmonic above (lag states exactly)."""

    def __init__(self, slow: SlowSystem, state: SlowState, X: Tensor, omega: Tensor, K: int,
                 phase_row: Tensor, top: int):
        self.K, self.nh, self.r = K, 2 * K + 1, phase_row
        J, R_w = slow_jacobian(slow, state, X, omega, K)
        self.lu = bordered_lu(J, R_w, phase_row, slow.nl)
        Kc, Cc, Mc, S, Kqs = condensed_tangents(slow, state, omega)
        self.S = S
        l = slow.lin
        hb = HarmonicBalance(slow.system, top)
        blocks = hb.linear_blocks(omega, derivative=False)
        k = torch.arange(K + 1, top + 1, dtype=X.dtype, device=X.device)
        kw = (omega[:, None] * k)[:, :, None, None]
        # the mean condensed stiffness; above the duals' dynamic harmonics the map holds them
        # quasi-static, and so does the block (its Schur complement alone)
        dyn = (k <= slow.dynamic)[None, :, None, None]
        dK = torch.where(dyn, (Kc.mean(1) - hb.Kl[:, l][:, :, l])[:, None],
                         (Kqs.mean(1) - hb.Kl[:, l][:, :, l])[:, None])
        dC = torch.where(dyn, (Cc.mean(1) - hb.C0[:, l][:, :, l])[:, None],
                         torch.zeros_like(dK))
        dM = torch.where(dyn, (Mc.mean(1) - hb.Mt[:, l][:, :, l])[:, None],
                         torch.zeros_like(dK))
        self.Z = blocks.Z[:, K:, l][..., l] + torch.complex(dK - kw ** 2 * dM, kw * dC)

    def apply(self, R: Tensor, X: Tensor, phase: Tensor | None = None
              ) -> tuple[Tensor, Tensor, Tensor]:
        """(δX (B, 2K'+1, nl), δω (B,), ok) for the residual R (B, 2K'+1, nl) at the orbit X
        (its phase condition's residual; or that residual ``phase`` (B,) itself)."""
        B = R.shape[0]
        rhs = torch.cat([R[:, : self.nh].reshape(B, -1),
                         ((X[:, 2] @ self.r) if phase is None else phase)[:, None]], dim=1)
        sol, ok = self.lu.solve(rhs)
        low, dw = sol[:, :-1].view_as(R[:, : self.nh]), sol[:, -1]
        if R.shape[1] == self.nh:
            return low, dw, ok
        top = (R.shape[1] - 1) // 2
        Z = self.Z[:, : top - self.K]
        W = torch.complex(R[:, self.nh::2], -R[:, self.nh + 1::2])
        dQ = torch.linalg.solve(Z, W[..., None])[..., 0]
        high = R.new_empty(R.shape[0], R.shape[1] - self.nh, R.shape[2])
        high[:, 0::2], high[:, 1::2] = dQ.real, -dQ.imag
        return torch.cat([low, high], dim=1), dw, ok


@dataclass
class SlowBound:
    """Per orbit (B,) of :func:`slow_bound` (module docstring): the corrected orbit's outputs'
    amplitudes (B, O) and their bounds, its frequency (Hz) and its relative bound, the
    contraction κ, the neglected fast dynamics' share of the bound, whether certified (κ ≤
    1/4, the fast series contracting, every number finite), and the corrected full orbit
    (coefficients (B, 2K_R+1, n), ω)."""

    amplitude: np.ndarray
    amplitude_error: np.ndarray
    frequency_hz: np.ndarray
    frequency_error: np.ndarray
    contraction: np.ndarray
    fast: np.ndarray
    fast_ratio: np.ndarray
    converged: np.ndarray
    X: Tensor
    omega: Tensor
    eta: np.ndarray
    rest: np.ndarray


def slow_bound(system: CaseSystem, orbit: SlowOrbit, phase_row: Tensor, rows: Tensor,
               K_R: int | None = None, K_2: int | None = None, coupled: int | None = None,
               dynamic: int | None = None) -> SlowBound:
    """The bounds of the slow orbit ``orbit`` (K harmonics) to the continuous-time orbit of
    ``system`` (module docstring); ``rows`` (O, n) the outputs."""
    X, omega = orbit.X, orbit.omega
    K = (X.shape[1] - 1) // 2
    K1 = K_R or COUPLED * K
    K2 = K_2 or SECOND * K
    Kc = coupled or K1
    dynamic = dynamic or DYNAMIC * K
    first = SlowSystem(system, K, K1, dynamic=dynamic)
    second = SlowSystem(system, K, K2, dynamic=dynamic)
    l, d = first.lin, first.duals
    r = phase_row[l]
    s0 = first.evaluate(X, omega, _resampled(orbit.h, first.N))
    A = SlowInverse(first, s0, resize_harmonics(X, Kc), omega, Kc, r, K2)
    XK1 = resize_harmonics(X, K1)
    d0, dw0, ok0 = A.apply(s0.R, XK1)
    X1 = XK1 - d0
    w1 = omega - dw0
    s1 = second.evaluate(X1, w1, _resampled(s0.h, second.N))
    d1, dw1, ok1 = A.apply(s1.R, resize_harmonics(X1, K2))
    size = X.abs().amax(dim=(1, 2))
    # below the rounding floor the two steps are rounding, not a contraction's measure
    eta0 = torch.maximum(state_norm(d0) + size * (dw0 / omega).abs(), ROUNDING * size)
    kappa = (state_norm(d1) + size * (dw1 / omega).abs()) / eta0
    # the neglected fast dynamics: the next dual correction z, its effect on the slow rows
    # through their tangent, T_ld z + C_ld ż, through the approximate inverse; the remainder
    # of the series beyond z bounded by the measured ratio of its last two terms
    ratio = s0.corrections[:, -1] / s0.corrections[:, -2].clamp_min(1e-300)
    factor = 1.0 / (1.0 - ratio.clamp(max=0.5))
    z = s0.neglected
    dz = first._derivative_samples(z, omega, 1)
    Kt, Ct = s0.Kt, s0.Ct
    p = (Kt[..., l, :][..., d] @ z[..., None])[..., 0] + (Ct[..., l, :][..., d] @ dz[..., None])[
        ..., 0]
    # above the duals' dynamic harmonics the map holds them quasi-static: their response there
    # taken as the quasi-static one amplified by the mean dual operator's gain per harmonic,
    # ‖(T̄ − (kω)² M + i kω C̄)⁻¹ T̄‖ + 1 (the corrected orbit's duals, harmonics up to 3K)
    z_high = _above_dynamic(second, s1, w1)
    p_high = (s1.Kt[..., l, :][..., d] @ z_high[..., None])[..., 0]
    P = resize_harmonics(coefficients_from_samples(p, K1), K2) + coefficients_from_samples(
        p_high, K2)
    dp, dwp, okp = A.apply(P, resize_harmonics(X, K2), torch.zeros_like(omega))
    fast = factor * (state_norm(dp) + size * (dwp / omega).abs())
    eta = eta0 + fast
    rest = eta * kantorovich_excess(kappa.clamp(max=MAX_CONTRACTION)) + fast
    # the outputs of the corrected full orbit; their distance to the true orbit's: the slow
    # error through the slow manifold (c_l + Sᵀ c_d), the duals' own through the remainder
    C = rows
    Y1 = coefficients_from_samples(s1.q @ C.T, K2)
    low, sampling = sampled_amplitude(Y1, AMPLITUDE_SAMPLES)
    y = FourierBasis.build(K2, AMPLITUDE_SAMPLES, Y1.device, Y1.dtype).E @ Y1
    fine = 0.5 * (parabolic_extreme(y, 1.0)[1] - parabolic_extreme(y, -1.0)[1])
    cl, cd = C[:, l], C[:, d]
    lip = (cl[None, None] + torch.einsum("od,bndl->bnol", cd, A.S)).norm(dim=-1).amax(1)
    fast_out = factor[:, None] * ((z @ cd.T).abs().amax(1) + (z_high @ cd.T).abs().amax(1))
    # the sampled amplitude Â ≤ A ≤ Â + e (:func:`~.fourier_certificate.sampled_amplitude`);
    # reported: the parabola-refined extremes' (Â's own refinement), kept inside that enclosure
    amp = torch.minimum(torch.maximum(fine, low), low + sampling)
    enclosure = torch.maximum(amp - low, low + sampling - amp)
    err = enclosure + lip * rest[:, None] + fast_out
    freq_err = rest / size
    finite = torch.isfinite(err).all(1) & torch.isfinite(kappa) & torch.isfinite(rest)
    converged = ok0 & ok1 & okp & finite & (kappa <= MAX_CONTRACTION) & (ratio <= 0.5)
    return SlowBound(amp.cpu().numpy(), err.cpu().numpy(), (w1 / (2 * math.pi)).cpu().numpy(),
                     freq_err.cpu().numpy(), kappa.cpu().numpy(), fast.cpu().numpy(),
                     ratio.cpu().numpy(), converged.cpu().numpy(), s1.Xfull, w1,
                     eta.cpu().numpy(), rest.cpu().numpy())


def _above_dynamic(slow: SlowSystem, state: SlowState, omega: Tensor) -> Tensor:
    """(B, N, nd) samples of the duals' neglected response above the dynamic harmonics
    (:func:`slow_bound`): each harmonic k of the quasi-static duals h there scaled by
    ‖(T̄_dd − (kω)² M_dd + i kω C̄_dd)⁻¹ T̄_dd‖₂ + 1 (the mean tangents along the orbit)."""
    if slow.dynamic >= slow.K_R:
        return torch.zeros_like(state.h)
    d = slow.duals
    H = coefficients_from_samples(state.h, slow.K_R)
    T = state.Kt[..., d, :][..., d].mean(1)
    Cd = state.Ct[..., d, :][..., d].mean(1)
    k = torch.arange(slow.dynamic + 1, slow.K_R + 1, dtype=H.dtype, device=H.device)
    kw = (omega[:, None] * k)[:, :, None, None]
    Z = torch.complex(T[:, None] - kw ** 2 * slow.Mdd[:, None], kw * Cd[:, None])
    gain = torch.linalg.matrix_norm(torch.linalg.solve(
        Z, T[:, None].to(Z.dtype).expand_as(Z)), ord=2) + 1.0  # (B, k)
    high = torch.zeros_like(H)
    rows = slice(2 * slow.dynamic + 1, None)
    high[:, rows] = H[:, rows] * gain.repeat_interleave(2, dim=1)[..., None]
    return slow.basis.E @ high


def fast_limit(system: CaseSystem, X: Tensor, omega: Tensor) -> Tensor:
    """(B,) the highest harmonic k* on which the duals' dynamic corrections converge with
    ratio ≤ :data:`RHO_MAX` along the orbits X (B, 2H+1, n): ρ_k = (kω)² a + kω c with a, c
    the largest ‖T_dd⁻¹ M_dd‖₂, ‖T_dd⁻¹ C_dd‖₂ over the orbit's AFT samples (T, C the dual
    block of the tangents)."""
    H = (X.shape[1] - 1) // 2
    hb = HarmonicBalance(system, H)
    _, Kn, Cn = hb.nonlinear_tangents(*hb.samples(X, omega))
    d = dual_coordinates(system)
    T = (hb.Kl[:, None] + Kn)[..., d, :][..., d]
    Cd = (hb.C0[:, None] + Cn)[..., d, :][..., d]
    M = hb.Mt[:, d][:, :, d][:, None].expand_as(T)
    a = torch.linalg.matrix_norm(torch.linalg.solve(T, M), ord=2).amax(1)
    c = torch.linalg.matrix_norm(torch.linalg.solve(T, Cd), ord=2).amax(1)
    kw = (-c + torch.sqrt(c ** 2 + 4 * a * RHO_MAX)) / (2 * a)
    return torch.floor(kw / omega).to(torch.long)


def _resampled(y: Tensor, N: int) -> Tensor:
    """Periodic samples y (B, N', m) at N equally spaced phases (trigonometric
    interpolation)."""
    if y.shape[1] == N:
        return y
    Kp = (y.shape[1] - 1) // 2
    c = coefficients_from_samples(y, Kp)
    return FourierBasis.build(Kp, N, y.device, y.dtype).E @ c


@dataclass
class SlowCertificate:
    """Per orbit (B,) of :func:`slow_certificate`: the corrected orbit's outputs' amplitudes
    (B, O) and their bounds (output units), its frequency (Hz) and relative bound, κ, the
    neglected fast dynamics' share of η, the harmonics K of the slow orbit (0: refused, the
    duals' corrections do not converge on enough harmonics), whether the bound converged
    (:class:`SlowBound`), the Floquet verdict of the corrected orbit (True, False or None:
    not resolved), its critical multiplier's modulus (the slow state's or the dual
    coordinates' own, the larger), the monodromy's accuracy (its trivial multiplier's error),
    Newton's last scaled step and the corrected orbit's state at τ = 0 (q, q̇, ξ)."""

    amplitude: np.ndarray
    amplitude_error: np.ndarray
    frequency_hz: np.ndarray
    frequency_error: np.ndarray
    contraction: np.ndarray
    fast: np.ndarray
    harmonics: np.ndarray
    converged: np.ndarray
    stable: np.ndarray
    critical: np.ndarray
    trivial_error: np.ndarray
    newton_step: np.ndarray
    state: tuple[np.ndarray, np.ndarray, np.ndarray]

    @property
    def certified(self) -> np.ndarray:
        """κ ≤ 1/4, the fast series contracting, Newton converged, the verdict known."""
        known = np.array([s is not None for s in self.stable], dtype=bool)
        return self.converged & known & (self.newton_step < SLOW_NEWTON_ACCEPT)


def applies(system: CaseSystem, omega: Tensor) -> bool:
    """Whether the slow certificate applies to the cases of ``system`` at ω: their dual
    coordinates condense (:func:`~.floquet.condensable`: no mass, lag or added coupling,
    the slowest at least ten times 2ω)."""
    from .floquet import condensable
    return condensable(system, omega, dual_coordinates(system))


def slow_certificate(system: CaseSystem, X: Tensor, omega: Tensor, phase_row, rows,
                     max_harmonics: int = SLOW_HARMONICS) -> SlowCertificate:
    """The slow certificate of the orbits X (B, 2H+1, n), ω (B,) rad/s of ``system`` (float64;
    module docstring). Per orbit the duals' dynamic harmonics k* (:func:`fast_limit`) set the
    slow orbit's K = min(``max_harmonics``, k*/2) (fewer than :data:`MIN_SLOW_HARMONICS`:
    refused); the orbit is solved at K by Newton from X, bounded by :func:`slow_bound`
    (residuals at 2K and 3K harmonics, the condensed Jacobian on 2K, the dynamic corrections
    on min(k*, 3K)) and its stability decided by :mod:`.floquet` on the corrected orbit.
    ``phase_row`` (n,): the decision output's row; ``rows`` (O, n): the outputs."""
    from .floquet import condensed_multiplier, floquet
    from .solve import orbit_state

    system = system.to(dtype=torch.float64)
    f64 = {"dtype": torch.float64, "device": system.device}
    X, omega = X.to(**f64), omega.to(**f64)
    r = torch.as_tensor(np.asarray(phase_row, dtype=float), **f64).reshape(-1)
    C = torch.as_tensor(np.asarray(rows, dtype=float), **f64).reshape(-1, system.n)
    B, O, n, na = X.shape[0], C.shape[0], system.n, system.n_lag
    limit = fast_limit(system, X, omega).cpu().numpy()
    Ks = np.minimum(max_harmonics, limit // 2)
    nan = np.full(B, np.nan)
    out = SlowCertificate(np.full((B, O), np.nan), np.full((B, O), np.nan), nan.copy(),
                          nan.copy(), nan.copy(), nan.copy(), np.where(
                              Ks >= MIN_SLOW_HARMONICS, Ks, 0), np.zeros(B, dtype=bool),
                          np.full(B, None, dtype=object), nan.copy(), nan.copy(),
                          np.full(B, np.inf), (np.zeros((B, n)), np.zeros((B, n)),
                                               np.zeros((B, na))))
    for K in np.unique(out.harmonics[out.harmonics > 0]):
        j = np.flatnonzero(out.harmonics == K)
        t = torch.as_tensor(j, device=system.device)
        sub = system.select(t)
        K = int(K)
        dynamic = int(min(limit[j].min(), 3 * K))
        orbit = solve_slow(sub, X[t], omega[t], K, r, dynamic=min(dynamic, K))
        bound = slow_bound(sub, orbit, r, C, K_R=2 * K, K_2=3 * K, coupled=2 * K,
                           dynamic=dynamic)
        Xf = resize_harmonics(bound.X, K)
        fl = floquet(sub, Xf, bound.omega)
        crit = np.maximum(np.abs(fl.critical), condensed_multiplier(sub, Xf, bound.omega))
        out.stable[j] = [None if v is None else bool(c < 1.0 + max(STABILITY_TOL, e))
                         for v, c, e in zip(fl.stable, crit, fl.trivial_error)]
        out.critical[j], out.trivial_error[j] = crit, fl.trivial_error
        out.amplitude[j], out.amplitude_error[j] = bound.amplitude, bound.amplitude_error
        out.frequency_hz[j], out.frequency_error[j] = bound.frequency_hz, bound.frequency_error
        out.contraction[j], out.fast[j] = bound.contraction, bound.fast
        out.converged[j] = bound.converged
        out.newton_step[j] = orbit.step.cpu().numpy()
        for dst, src in zip(out.state, orbit_state(sub, bound.X, bound.omega)):
            dst[j] = src
    return out
