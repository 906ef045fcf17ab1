"""A certificate for harmonic-balance orbits without time integration: a bound on the distance
from the truncated Fourier orbit to the continuous-time orbit itself.

An HB orbit X (harmonics 0..H, :mod:`.fourier`) with frequency ω solves the balance equations
G(X, ω) = 0 of :mod:`.balance` in harmonics 0..H only. The continuous-time orbit X* solves them
in every harmonic. The ROM force is a cubic polynomial in (q, q̇), so the residual of X lives in
harmonics 0..3H, and the full residual is computed exactly (no aliasing) by the AFT of
:class:`~.balance.HarmonicBalance` at 3H harmonics, whose 12H + 1 samples resolve a cubic of a
3H-harmonic series on harmonics ≤ 3H.

The bound is a Newton–Kantorovich-type estimate with an approximate inverse A of the
Jacobian of the untruncated equations: the HB Jacobian at H + :data:`EXTRA_HARMONICS` on those
harmonics (bordered by the phase condition r·b₁ = 0 of :mod:`.newton`, ω unknown, the
fictitious damping held at zero; factored once for both steps), the linear dynamic stiffness
Z_k(ω)⁻¹ (lag states eliminated exactly, :meth:`~.balance.HarmonicBalance.linear_blocks`) on
each harmonic above those, applied block by block (Gauss–Seidel: the tail first, then the low
harmonics from the residual with the tail included, so that the tail's pull on the
low harmonics is part of the first correction). Two chord steps:

    δ₀ = A G(X),             X₁ = X − δ₀      (harmonics 0..K, K = max(3H, H + extra)),
    δ₁ = A G(X₁)                             (harmonics 0..3K: every harmonic of G(X₁)).

Their ratio κ = ‖δ₁‖/‖δ₀‖ estimates the Kantorovich quantity h = βγη ≈ 2κ (η = ‖δ₀‖: the
second chord step is quadratic in the first); with h ≤ 1/2 (κ ≤ 1/4, checked) the orbit X*
lies within r* = η (1 − sqrt(1 − 2h))/h of X, and within r* − η of X₁ (the majorant
sequence), so

    ‖X − X*‖ ≤ ‖δ₀‖ + (r* − η),        r* − η ≈ (κ + 2κ²) η for small κ.

Assumptions (checked where cheap): the Lipschitz constant of the Jacobian near X is the one its
first two steps show (κ measured, κ ≤ 1/4 required); the tail above 3K of X* is below what δ₁
shows (the residual of X₁ has no harmonic above 3K; its image under A is δ₁, the part above K
included). The norm is a sup-in-time one: for an output y = c·q, sup_t |y*(t) − y(t)| ≤ Σ_k
|c·δQ_k| (|·| the magnitude of harmonic k), so the half peak-to-peak amplitude of every output
moves by at most that much; the frequency by |δω₀| + (r* − η)/max|X| (ω in the norm relative,
at the orbit's size); a ratio of two amplitudes by the sum of their relative bounds (to first
order). These are distances to the continuous-time orbit: there is no time step and no
dt_error.

The amplitudes the row reports get a second, tighter bound through the corrected orbit X₁:
the half peak-to-peak amplitude A is 1-Lipschitz in the sup norm, so

    |A(y) − A(y*)| ≤ |A(y) − A(y₁)| + ‖c‖₂ (r* − η),

with A(y₁) of the trigonometric polynomial y₁ = c·x₁ (degree K) enclosed by its samples at P
phases: the best sample lies within π/P of each extreme, where y' = 0, so
0 ≤ A(y₁) − Â_P(y₁) ≤ ½ (π/P)² Σ_k k² |Y₁ₖ| (:func:`sampled_amplitude`). The first term is
the amplitude the first chord step moves, not the sup of δ₀: the tail harmonics that δ₀ solves
(each through its exact linear block Z_k⁻¹ above the coupled ones) and a shift of phase move
the sup-distance far more than the amplitude. The smaller of the two bounds is the row's
(:meth:`FourierBound.amplitude_error`). Measured on the ``bench_lco --quick`` orbits: the
10,000 ft, γ = 0 row (H = 7, κ = 0.07) had the sup bound 1.04e-3 on A_Tz (refused at tol
1e-3) and now 4.2e-4, within tol, against an error of 7e-5 from the shooting reference and
8.1e-5 from the RK4 ODE orbit (tests/test_certificate_truth_goland.py; the row is
Fourier-certified since the condensed monodromy of :mod:`.floquet` carries the dual
coordinates' inertia: its trivial multiplier was 0.08 off, now 1.3e-3); the
γ = 1e-3 rows' bounds are 1.4–2.4 times tighter on A_Tz and 2.5–4.1 on A_Tx.

Why the γ = 0 Goland rows at 4,000–8,500 ft stay refused (measured on the H = 9 and the
re-solved H = 29 orbits of ``bench_lco --quick``): their tail is not dominated by the linear
operator. The orbit modulates the tangent stiffness by 21–35 % of ‖K_l‖ (max over τ of
‖K_n(τ) − K̄_n‖₂; the dual coordinates' 2K2(q,·) and 3K3(q,q,·)), and at 8,500 ft
‖Z_k⁻¹ (K_n(0) − K̄_n)‖₂ is 2.0–41 on every fourth harmonic from 31 to 127 (not only near the
lightly damped modes at 33, 60, 111, 125, where the smallest singular value of Z_k is
1e3–7e3 against 2.4e7 for the largest). So the block-diagonal tail does not contract: chord
steps with the orbit kept at 96 harmonics diverge on all five rows (‖δ‖ grows 7 to 4e18
times in six steps), three block Gauss–Seidel sweeps per step diverge faster, and the mean
tangent K̄_n added to Z_k raises κ from 0.29–4.3 to 3.3–37. With the exact Jacobian at 87
and 261 harmonics (matrix-free; GMRES preconditioned by this module's approximate inverse)
κ is still 0.24–0.63 on the H = 29 orbits, and GMRES did not reach 1e-8 in 1,000 iterations
on 3 (first step) and 4 (second) of the 5: the periodic problem itself is ill-conditioned
there (Kantorovich's h > 1/2), not only its preconditioner. Those rows keep the shooting
certificate.

Where κ > 1/4 comes from (issue 48, measured on the ``bench_lco --quick`` γ = 0 orbits against
the RK4 ODE orbit of tests/ode_reference.py): two distinct causes. (1) At the method's H = 9
the orbit is outside Kantorovich's ball: the first step moves it by 1–8 % of its size at
4,000–7,000 ft (the amplitude is 1.8 % off the ODE's at 4,000 ft), the second step is larger (κ
= 98, 6.4, 9.3), and it lies in harmonic 1 of the slow coordinates, not in the tail; 16, 18 or
30 coupled harmonics above H leave κ at 35–46 (4,000 ft) and 8.0–8.5 (7,000 ft). (2) Re-solved
at K = 15, 21, 27 harmonics (the 4,000 ft amplitude then 1.1e-3 and 3e-4 off the ODE's) the
residual reaches harmonics 3K–9K, where the approximate inverse is wrong twice over: the slow
modes at 22.8–28.7 Hz sit at harmonics 12–15, and in raw coordinates the orbit's tangent on
them is 800–5,700 times their linear stiffness (‖K_ll^{-1/2} K_n(τ) K_ll^{-1/2}‖₂; the dual
coordinates' quadratic coupling, which only their Schur complement cancels), and the dual modes
from 63 Hz (harmonic 32) up are frequency-modulated by the orbit (their diagonal stiffness by
up to 14–35 %, ‖K_dd^{-1/2} ΔK_dd K_dd^{-1/2}‖₂ = 0.33–0.72), so across harmonics their Hill
operator couples about εΩ_d/(2ω) neighbours (an estimate: 5 to 40 from 63 to 782 Hz) — no
per-harmonic block, linear or with the mean tangent, inverts it. κ at K = 15/21/27 is then
0.3–8 without a trend in K (the 10,000 ft row: 0.07 at H = 7, 5.0 at K = 15, 0.32 at 27); the
mean tangent added to the tail blocks raises it on 6 of those 9 orbits (up to 180).

Written here: the certificate composes this project's harmonic balance.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import torch

from ..sim.system import CaseSystem
from .balance import HarmonicBalance, LinearBlocks
from .fourier import synthesis_matrix
from .newton import equilibrated_lu
from .solve import fixed_parameter_condition

Tensor = torch.Tensor

#: largest measured contraction κ = ‖δ₁‖/‖δ₀‖ of a certified orbit: Kantorovich's condition
#: h = βγη ≤ 1/2 with βγη estimated as 2κ (:func:`kantorovich_excess`). A geometric bound
#: ‖δ₀‖ + 2‖δ₁‖ at κ ≤ 1/2 was measured to fall short: on the Van der Pol–Duffing orbits
#: scaled by 1.5, κ = 0.24 and that bound was 3 % below the true distance
MAX_CONTRACTION = 0.25
#: the residual of a K-harmonic orbit has harmonics up to 3K (the force is cubic)
FIRST_EXTENSION = 3
#: harmonics above H that the approximate inverse couples through the HB Jacobian (the
#: tangent's harmonic-1 content, 2K2(q,·), couples harmonic k to k ± 1 strongly: the stiff dual
#: coordinates' quadratic response). Measured on the Goland γ = 1e-3 orbits at H = 7–9: a
#: block-diagonal Z_k⁻¹ right above H made the chord steps diverge (κ = 20–200); 2 more
#: harmonics gave κ = 0.27–11, 4: 0.15–0.27, 8: 0.05–0.09 (bounds 2–4 times tighter than at
#: 4, for 20 % more CPU)
EXTRA_HARMONICS = 8
#: phases at which a corrected orbit's outputs are sampled for their amplitude enclosure
#: (:func:`sampled_amplitude`): ½ (π/P)² = 2.9e-7 times Σ k²|Y_k|, far below any tolerance
AMPLITUDE_SAMPLES = 4096


def coupled_harmonics(H: int) -> int:
    """The harmonics of the approximate inverse's Jacobian for an H-harmonic orbit."""
    return H + EXTRA_HARMONICS


@dataclass
class FourierBound:
    """Per orbit (B,): the distances of :func:`fourier_bound` (module docstring).

    Attributes:
        output_error: (B, O) bound on sup_t |y*(t) − y(t)| of each output row (output units):
            the largest change of its half peak-to-peak amplitude.
        frequency_error: (B,) bound on |ω* − ω| / ω.
        coordinate_error: (B, n) the same bound as ``output_error`` for each coordinate q_i.
        contraction: (B,) κ = ‖δ₁‖/‖δ₀‖ (state norm Σ_k ‖δQ_k‖₂ with ω relative).
        tail: (B,) ‖δ₀‖ of the harmonics above H relative to ‖X‖ (the truncation's share).
        converged: (B,) κ ≤ :data:`MAX_CONTRACTION` and every number finite.
        corrected_amplitude: (B, O) Â_P of each output of the corrected orbit X₁ (output
            units; a lower bound of its amplitude, :func:`sampled_amplitude`).
        corrected_error: (B, O) the sampling enclosure of that amplitude plus ‖c‖₂ (r* − η):
            A(y*) lies within [Â_P − ‖c‖(r* − η), Â_P + this].
    """

    output_error: np.ndarray
    frequency_error: np.ndarray
    coordinate_error: np.ndarray
    contraction: np.ndarray
    tail: np.ndarray
    converged: np.ndarray
    corrected_amplitude: np.ndarray
    corrected_error: np.ndarray

    def amplitude_error(self, reported: np.ndarray) -> np.ndarray:
        """(B, O) bound on |reported − A(y*)| of each output's reported amplitude (output
        units): the smaller of ``output_error`` and the corrected orbit's
        |reported − Â_P(y₁)| + ``corrected_error`` (module docstring)."""
        via = np.abs(np.asarray(reported, dtype=float) - self.corrected_amplitude) \
            + self.corrected_error
        return np.fmin(self.output_error, via)


def kantorovich_excess(kappa: Tensor) -> Tensor:
    """(r* − η)/η of the Newton–Kantorovich theorem with h = 2κ (the second step of a chord
    iteration is ‖δ₁‖ ≈ (βγ/2)‖δ₀‖², so βγη ≈ 2κ): r* = η (1 − sqrt(1 − 2h))/h, valid for
    h ≤ 1/2, i.e. κ ≤ 1/4; ≈ κ + 2κ² for small κ."""
    h = 2.0 * kappa
    safe = torch.where(h > 0, h, torch.ones_like(h))
    return torch.where(h > 0, (1.0 - torch.sqrt(1.0 - 2.0 * h)) / safe - 1.0,
                       torch.zeros_like(h))


def harmonic_sizes(X: Tensor) -> Tensor:
    """(B, H+1, ...) the magnitude of each harmonic of coefficients X (B, 2H+1, ...):
    |a₀|, then sqrt(a_k² + b_k²) — the largest value harmonic k takes in time."""
    return torch.cat([X[:, :1].abs(), torch.sqrt(X[:, 1::2] ** 2 + X[:, 2::2] ** 2)], dim=1)


def sup_norm_bound(dX: Tensor, rows: Tensor) -> Tensor:
    """(B, O) Σ_k |c·δQ_k| for each row c of ``rows`` (O, n): a bound on sup_t |c·δq(t)| of
    the correction δq with coefficients dX (B, 2K+1, n)."""
    return harmonic_sizes(dX @ rows.T).sum(dim=1)


def sampled_amplitude(Y: Tensor, samples: int = AMPLITUDE_SAMPLES) -> tuple[Tensor, Tensor]:
    """(Â, e) each (B, O) for outputs with coefficients Y (B, 2K+1, O): Â the half
    peak-to-peak of the samples at ``samples`` phases, e = ½ (π/P)² Σ_k k² |Y_k|; the true
    amplitude A satisfies Â ≤ A ≤ Â + e (the best sample is within π/P of each extreme, where
    y' = 0 and |y''| ≤ Σ k²|Y_k|)."""
    K = (Y.shape[1] - 1) // 2
    y = synthesis_matrix(K, samples, Y.device, Y.dtype) @ Y  # (B, P, O)
    amp = 0.5 * (y.amax(dim=1) - y.amin(dim=1))
    k2 = torch.arange(K + 1, device=Y.device, dtype=Y.dtype) ** 2
    curvature = (k2[None, :, None] * harmonic_sizes(Y)).sum(dim=1)
    return amp, 0.5 * (math.pi / samples) ** 2 * curvature


def state_norm(dX: Tensor) -> Tensor:
    """(B,) Σ_k ‖δQ_k‖₂: bounds sup_t ‖δq(t)‖₂."""
    return harmonic_sizes(dX).norm(dim=2).sum(dim=1)


class _ChordStep:
    """The approximate inverse A of the module docstring for the orbits X (harmonics ≤ H) of
    ``system``: the bordered HB Jacobian at ``coupled`` ≥ H harmonics at (X, ω), factored once,
    then Z_k(ω)⁻¹ on every harmonic above it."""

    def __init__(self, system: CaseSystem, X: Tensor, omega: Tensor, phase_row: Tensor,
                 coupled: int):
        self.system, self.omega, self.phase_row = system, omega, phase_row
        self.H = coupled
        self.nh = nh = 2 * coupled + 1
        self.n = n = X.shape[2]
        B = X.shape[0]
        _, J, R_w, R_c = HarmonicBalance(system, coupled).jacobian(_padded(X, coupled), omega)
        m = nh * n
        # the Newton system of :mod:`.newton` with μ = c held at zero (a physical orbit)
        A = X.new_zeros(B, m + 2, m + 2)
        A[:, :m, :m] = J
        A[:, :m, -2] = R_w.reshape(B, -1)
        A[:, :m, -1] = R_c.reshape(B, -1)
        A[:, -2, 2 * n: 3 * n] = phase_row
        A[:, -1] = fixed_parameter_condition(B, nh, n, X.new_zeros(B))[0]
        self.lu = equilibrated_lu(A)

    def low(self, R: Tensor, X: Tensor) -> tuple[Tensor, Tensor, Tensor]:
        """(δX (B, nh, n), δω (B,), ok (B,)): A on the coupled harmonics of residual R, with
        the phase condition's residual of X."""
        B = R.shape[0]
        rhs = torch.cat([R[:, : self.nh].reshape(B, -1), (X[:, 2] @ self.phase_row)[:, None],
                         R.new_zeros(B, 1)], dim=1)
        sol, ok = self.lu.solve(rhs)
        return sol[:, : self.nh * self.n].view(B, self.nh, self.n), sol[:, -2], ok

    def high(self, blocks: LinearBlocks, R: Tensor) -> Tensor:
        """Z_k(ω)⁻¹ R_k for the harmonics above the coupled ones, k = H+1..K, of residual R
        (B, 2K+1, n) of equations at K harmonics whose linear blocks at ω are ``blocks``:
        (B, 2(K−H), n) in the coefficient layout."""
        Z = blocks.Z[:, self.H:]  # (B, K − H, n, n)
        # cos row Re(W), sin row −Im(W) of W = Z Q + F (:mod:`.balance`)
        W = torch.complex(R[:, self.nh::2], -R[:, self.nh + 1::2])
        dQ = torch.linalg.solve(Z, W[..., None])[..., 0]
        out = R.new_empty(R.shape[0], R.shape[1] - self.nh, self.n)
        out[:, 0::2], out[:, 1::2] = dQ.real, -dQ.imag
        return out

    def correction(self, X: Tensor, extension: int) -> tuple[Tensor, Tensor, Tensor]:
        """(δX (B, 2K+1, n), δω, ok) of one chord step from X, its residual taken at
        K = ``extension`` ≥ H harmonics (every harmonic it has when X has at most K/3): the
        tail above the coupled harmonics first, then those from the residual with the
        corrected tail (Gauss–Seidel on the two blocks)."""
        hb = HarmonicBalance(self.system, extension, stiffness_by_tangent=True)
        # the linear blocks at ω once, for both residuals and the tail's solves
        blocks = hb.linear_blocks(self.omega, derivative=False)
        Xe = _padded(X, extension)
        R = hb.residual(Xe, self.omega, blocks=blocks)
        if extension == self.H:
            d_low, d_omega, ok = self.low(R, Xe)
            return d_low, d_omega, ok
        d_high = self.high(blocks, R)
        Xg = Xe.clone()
        Xg[:, self.nh:] -= d_high
        d_low, d_omega, ok = self.low(hb.residual(Xg, self.omega, blocks=blocks), Xg)
        return torch.cat([d_low, d_high], dim=1), d_omega, ok


def _padded(X: Tensor, K: int) -> Tensor:
    """X (B, 2H+1, n) zero-padded to K ≥ H harmonics."""
    pad = X.new_zeros(X.shape[0], 2 * K + 1 - X.shape[1], X.shape[2])
    return torch.cat([X, pad], dim=1)


def fourier_bound(system: CaseSystem, X: Tensor, omega: Tensor, phase_row, rows
                  ) -> FourierBound:
    """The distance bounds of the orbits X (B, 2H+1, n) at ω (B,) rad/s (one H for all,
    float64) to the continuous-time orbits of ``system`` (module docstring); ``phase_row``
    (n,): the output row of the orbits' phase condition (the decision output); ``rows``
    (O, n): the reported outputs."""
    system = system.to(dtype=torch.float64)
    f64 = {"dtype": torch.float64, "device": system.device}
    X, omega = X.to(**f64), omega.to(**f64)
    r = torch.as_tensor(np.asarray(phase_row, dtype=float), **f64).reshape(-1)
    C = torch.as_tensor(np.asarray(rows, dtype=float), **f64).reshape(-1, system.n)
    H = (X.shape[1] - 1) // 2
    coupled = coupled_harmonics(H)
    step = _ChordStep(system, X, omega, r, coupled)
    first = max(coupled, FIRST_EXTENSION * H)
    d0, dw0, ok0 = step.correction(X, first)
    X1 = _padded(X, first) - d0
    step.omega = omega - dw0
    d1, dw1, ok1 = step.correction(X1, FIRST_EXTENSION * first)
    size = X.abs().amax(dim=(1, 2))  # ω enters the norm relative, at the orbit's size
    eta = state_norm(d0) + size * (dw0 / omega).abs()
    kappa = (state_norm(d1) + size * (dw1 / omega).abs()) / eta.clamp_min(
        torch.finfo(X.dtype).tiny)
    # beyond the first step: ‖X* − X₁‖ ≤ r* − η (Kantorovich's majorant), the per-output part
    # through the state norm (|c·δQ_k| ≤ ‖c‖₂ ‖δQ_k‖₂)
    rest = eta * kantorovich_excess(kappa.clamp(max=MAX_CONTRACTION))
    out = sup_norm_bound(d0, C) + C.norm(dim=1)[None, :] * rest[:, None]
    eye = torch.eye(system.n, **f64)
    coord = sup_norm_bound(d0, eye) + rest[:, None]
    freq = (dw0 / omega).abs() + rest / size.clamp_min(torch.finfo(X.dtype).tiny)
    high = d0.clone()
    high[:, : X.shape[1]] = 0.0
    tail = state_norm(high) / state_norm(X).clamp_min(torch.finfo(X.dtype).tiny)
    # the corrected orbit's amplitudes, enclosed by their samples, and the majorant beyond it
    amp1, sampling = sampled_amplitude(X1 @ C.T)
    corrected = sampling + C.norm(dim=1)[None, :] * rest[:, None]
    finite = torch.isfinite(out).all(dim=1) & torch.isfinite(freq) & torch.isfinite(kappa)
    converged = ok0 & ok1 & finite & (kappa <= MAX_CONTRACTION)
    return FourierBound(out.cpu().numpy(), freq.cpu().numpy(), coord.cpu().numpy(),
                        kappa.cpu().numpy(), tail.cpu().numpy(), converged.cpu().numpy(),
                        amp1.cpu().numpy(), corrected.cpu().numpy())
