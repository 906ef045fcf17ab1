"""Periodic orbits of the discrete Newmark map by shooting, with the step's own monodromy.

For the Newmark step (β, γ; the paper's average acceleration by default) of a
:class:`~torchrom.sim.CaseSystem` at h = T/N, an LCO of the simulator is a fixed point of the
N-step map x0 ↦ Φ_N(x0; T) on the state x = (q, q̇, ξ) — the acceleration follows from the
equations of motion (Eq. 54 with the aerodynamic additions of Eqs. 49–50), the lag states are
stepped by the same rule as in :mod:`torchrom.sim.newmark`. Newton solves, per case,

    Φ_N(x0; T) − x0 = 0,      c · q̇0 = 0        (c: the decision output; y(0) at its maximum)

for (x0, T). Its Jacobian is [[∂Φ_N/∂x0 − I, ∂Φ_N/∂T], [0, c, 0 | 0]]: the monodromy ∂Φ_N/∂x0
is propagated through every step's linearisation, which reuses the inverse of the step's
own Newton matrix J = M_t + γh (C + D W + C_n) + βh² (K + K_n) (the inverse the step needs
anyway), and ∂Φ_N/∂T is the step-size sensitivity carried as one more column (h = T/N).
Corrections are limited to a fraction of the orbit's size per state component (the stiff dual
coordinates), and cases leave the batch as they converge.

The eigenvalues of the converged monodromy are the Floquet multipliers of the discrete orbit
(the stability of record). The trivial multiplier is the one whose eigenvector is most nearly
parallel to the flow ẋ(0) = (q̇, q̈, ξ̇) in the orbit-scaled metric (not merely the one
closest to 1: near a fold another approaches 1); its distance from 1 (O(h²) for the discrete
map) is reported and must be small for a verdict.

Written here: no library integrates this model's discrete map with its monodromy in torch.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

import numpy as np
import torch

from ..checks import integer, real
from ..errors import InputError
from ..sim.schemes import SchemeParameters
from ..sim.system import CaseSystem
from .balance import DampedRows, HarmonicBalance, damping_force, force_tangents
from .fourier import band_limited_extreme, parabolic_extreme

Tensor = torch.Tensor

#: largest |μ_trivial − 1| for which a stability verdict is given
TRIVIAL_TOL = 1e-2


@dataclass(frozen=True)
class ShootingOptions:
    """Settings of :func:`shoot`.

    Attributes:
        dt: the target time step (s); each case takes N = round(T/dt) steps of h = T/N.
        tol: convergence: the scaled Newton correction (each state component relative to its
            largest magnitude on the orbit; T relative) below this.
        max_iterations: Newton iterations per case (0: one evaluation, the certificate of
            the start: its correction and the monodromy there).
        max_step: largest scaled correction of one Newton step (larger ones are shortened).
            The orbit's small, lightly damped coordinates take corrections a few times their
            own size that are nearly linear: a tighter limit (0.3) slowed the finishes of the
            Goland γ = 0 orbits to linear convergence without making any converge.
        accept: with a start amplitude (:attr:`OrbitStart.amplitude`), a case whose first
            evaluation puts the discrete orbit's amplitude within this (relative) of it (with
            :attr:`OrbitStart.coarse_amplitude`: its Richardson extrapolation), with its
            stability resolved, is accepted as it is and not iterated (the certificate's
            evaluation and its finish in one pass); None: every case is iterated.
        relax_periods: a case whose first correction is larger than ``relax_above`` is not
            corrected but moved this many periods along its own trajectory first (the first
            one is the evaluation's own end state, free): a start from a truncated Fourier
            series or a transient carries fast, strongly damped errors in the small
            coordinates that put it outside Newton's quadratic basin, and two periods shrink
            them several-fold (the Goland γ = 0 finishes from H = 9 orbits: 31 → 24 Newton
            passes), while the slow error along the weakly attracting orbit is left to Newton.
            0: Newton from the start.
        relax_above: the first scaled correction above which a case is relaxed.
        step_iterations: Newton iterations of the implicit equation in each time step (with
            the Jacobian refreshed at every one: from the extrapolated predictor three leave an
            error far below the orbit tolerance).
        scheme: 'newmark' with ``beta``, ``gamma`` (default the average acceleration rule).
    """

    dt: float = 1e-3
    tol: float = 1e-9
    max_iterations: int = 20
    max_step: float = 1.0
    accept: float | None = None
    relax_periods: int = 2
    relax_above: float = 0.1
    step_iterations: int = 3
    beta: float = 0.25
    gamma: float = 0.5

    def __post_init__(self):
        real("shooting.dt", self.dt, positive=True)
        real("shooting.tol", self.tol, positive=True)
        real("shooting.max_step", self.max_step, positive=True)
        if self.accept is not None:
            real("shooting.accept", self.accept, positive=True)
        integer("shooting.max_iterations", self.max_iterations, minimum=0)
        integer("shooting.step_iterations", self.step_iterations, minimum=1)
        integer("shooting.relax_periods", self.relax_periods, minimum=0)
        real("shooting.relax_above", self.relax_above, positive=True)
        if not (0 < self.beta <= 0.5 and 0.5 <= self.gamma <= 1.0):
            raise InputError(f"shooting.beta, gamma: expected an implicit Newmark rule "
                             f"(0 < β ≤ ½, ½ ≤ γ ≤ 1), got {self.beta}, {self.gamma}")

    @classmethod
    def of_scheme(cls, params: SchemeParameters, **kw) -> ShootingOptions:
        """The options for a simulator's scheme (Newmark family only: the generalised-α
        schemes carry force history the fixed-point state does not hold)."""
        if not params.is_newmark:
            raise InputError("shooting: expected a Newmark scheme (αm = αf = 0); HHT-α and "
                             "generalised-α orbits are not supported")
        return cls(beta=params.beta, gamma=params.gamma, **kw)


@dataclass
class OrbitStart:
    """Initial guesses of B orbits: the state at t = 0 and the period."""

    q: Tensor  # (B, n)
    v: Tensor  # (B, n)
    xi: Tensor  # (B, na)
    period: Tensor  # (B,) s
    #: (B,) the amplitude the method reports for each orbit (what ``accept`` compares with)
    amplitude: Tensor | None = None
    #: (B,) the discrete orbit's amplitude at twice the step near this start: with it,
    #: ``accept`` compares ``amplitude`` with the Richardson extrapolation of the discrete
    #: orbits at h and 2h, (4 A(h) − A(2h))/3 (a continuous-time orbit's certificate)
    coarse_amplitude: Tensor | None = None


@dataclass
class ShootingResult:
    """B discrete periodic orbits and their certificates (NaN where not converged).

    Attributes:
        q, v, xi: the state at t = 0 (on the section through the start, see :func:`shoot`).
        period: T (s); ``steps``: N, the steps per period (h = T/N).
        converged: (B,) bool; ``iterations``: Newton iterations used; ``accepted``: (B,)
            bool, the starts accepted by ``options.accept`` (not iterated; their multipliers
            are the start's).
        first_correction: (B,) scaled size of the first Newton correction — how far the start
            was from the discrete orbit (state components relative to their orbit maxima).
        first_amplitude_correction: (B,) the first Newton correction of the decision output's
            amplitude, relative and signed (the start's amplitude × (1 + this) is the discrete
            orbit's, to first order); ``start_amplitude``: (B,) that start's amplitude (the
            decision output over the first pass's N steps).
        relaxed: (B,) bool, the starts moved along their trajectories before Newton
            (``options.relax_periods``).
        correction: (B,) the last scaled correction; ``amplitude_correction``: (B,) the last
            relative amplitude correction (signed).
        amplitude: (B, O) half peak-to-peak of each output over the orbit's N samples.
        start_amplitudes, first_amplitude_corrections, amplitude_corrections: (B, O) the same
            for every output of ``rows``: the start's amplitudes, the first and the last
            Newton corrections' relative changes of them (signed).
        first_period_correction, period_correction: (B,) the first and the last Newton
            corrections of the period, relative (ΔT/T, signed).
        multipliers: (B, 2n + na) complex Floquet multipliers of the discrete map.
        trivial_error: |μ_trivial − 1|; ``critical_multiplier``: the largest other |μ|;
        stable: True / False, None where the trivial multiplier is not resolved.
    """

    q: Tensor
    v: Tensor
    xi: Tensor
    period: Tensor
    steps: np.ndarray
    converged: np.ndarray
    iterations: np.ndarray
    first_correction: np.ndarray
    first_amplitude_correction: np.ndarray
    start_amplitude: np.ndarray
    correction: np.ndarray
    amplitude_correction: np.ndarray
    amplitude: np.ndarray
    multipliers: np.ndarray
    trivial_error: np.ndarray
    critical_multiplier: np.ndarray
    stable: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object))
    accepted: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    relaxed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    start_amplitudes: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    first_amplitude_corrections: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    amplitude_corrections: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    first_period_correction: np.ndarray = field(default_factory=lambda: np.zeros(0))
    period_correction: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def first_order_amplitudes(self) -> np.ndarray:
        """(B, O) every output's amplitude on the discrete orbit near the start, to second
        order in the start's distance (the start's amplitudes moved by the first Newton
        correction)."""
        return self.start_amplitudes * (1.0 + self.first_amplitude_corrections)

    def first_order_period(self, start_period) -> np.ndarray:
        """(B,) the discrete orbit's period near the start (s), to second order in the start's
        distance (``start_period`` (B,): the start's)."""
        return np.asarray(start_period, dtype=float) * (1.0 + self.first_period_correction)

    @property
    def frequency_hz(self) -> np.ndarray:
        return 1.0 / self.period.cpu().numpy()

    def start(self) -> OrbitStart:
        return OrbitStart(self.q, self.v, self.xi, self.period)


# ---------------------------------------------------------------------------------------------
# the step and its linearisation
# ---------------------------------------------------------------------------------------------
def _step_inverse(J: Tensor) -> Tensor:
    """J⁻¹ (B, n, n) of the steps' Newton matrices J = M_t + γh C + βh² K (mass-dominated,
    well conditioned): each step applies it to 3 + (m + 1) right-hand sides, and a factor with
    those products costs ~15 % less than an LU factor with its solves (B = 1–512)."""
    return torch.linalg.inv_ex(J)[0]


class _Map:
    """The N-step Newmark map of B cases with per-case steps h (B,), and its derivatives."""

    def __init__(self, system: CaseSystem, options: ShootingOptions):
        self.system = system
        self.o = options
        # the per-case linear matrices and force kernels (symmetric ones as upper triangles)
        self.hb = HarmonicBalance(system, 1, symmetric_kernels=True)
        self.n, self.na, self.B = system.n, system.n_lag, system.batch_size
        self.nonlinear = self.hb.has_stiffness or self.hb.has_damping
        # (B, 1) force factors (the stiffness's, where not all 1, and the damping's)
        s = self.hb.s[:, None]
        self.s = None if bool((s == 1).all()) else s
        self.damped = DampedRows.of(self.hb.g)
        k = self.hb.kernels
        # the kernels' quadratic monomials as positions in the outer product: m2 = (q ⊗ q)[pairs]
        # (one gather instead of two)
        self.pairs = k.pair_i * self.n + k.pair_j

    def _pairs(self, q: Tensor) -> Tensor:
        """m2 (B, P): the kernels' quadratic monomials q_i q_j (CompactForces.monomials)."""
        return torch.index_select((q[:, :, None] * q[:, None, :]).flatten(1), 1, self.pairs)

    def _scaled(self, t: Tensor) -> Tensor:
        """A stiffness term (B, ...) times the cases' stiffness factors."""
        return t if self.s is None else self.s.view(-1, *[1] * (t.dim() - 1)) * t

    def nonlinear_force(self, q: Tensor, v: Tensor) -> Tensor:
        """f_nl (B, n) at (q, q̇): :meth:`HarmonicBalance.nonlinear_force` without its sample
        axis (the kernels' monomial GEMMs; the damping kernel only when a case has nonlinear
        damping)."""
        hb, k = self.hb, self.hb.kernels
        m2 = self._pairs(q)
        # the stiffness force by Euler's theorem from the tangent's coefficients: no cubic
        # monomials to gather, as fast as they at B ≤ 10 and twice as fast at B = 512
        f = (self._scaled(k.stiffness_nl_by_tangent(q, m2)) if hb.has_stiffness
             else torch.zeros_like(q))
        if self.damped is not None:
            fd, _ = damping_force(k, q, v, m2, self.damped)
            f = self.damped.add(f, fd)
        return f

    def nonlinear_tangents(self, q: Tensor, v: Tensor) -> tuple[Tensor, Tensor, Tensor | None]:
        """(f_nl, K_n, C_n) at (q, q̇): the force (B, n) and its derivatives in q and q̇
        (B, n, n) (:func:`~.balance.force_tangents` without a sample axis); C_n is None
        without nonlinear damping."""
        hb = self.hb
        s = (1.0 if self.s is None else self.s) if hb.has_stiffness else None
        return force_tangents(hb.kernels, q, v, self._pairs(q), s, self.damped)

    def forces(self, q: Tensor, v: Tensor, tangent: bool = True):
        """f_nl, and with ``tangent`` the full tangents (K_t, C_t), linear parts included."""
        hb = self.hb
        if not self.nonlinear:
            return (torch.zeros_like(q), hb.Kl, hb.C0) if tangent else torch.zeros_like(q)
        if not tangent:
            return self.nonlinear_force(q, v)
        f, Kn, Cn = self.nonlinear_tangents(q, v)
        return f, hb.Kl + Kn, hb.C0 if Cn is None else hb.C0 + Cn

    def acceleration(self, q, v, xi) -> tuple[Tensor, Tensor, Tensor]:
        """a from the equations of motion, and the tangents (K_t, C_t) at (q, v)."""
        hb, sys = self.hb, self.system
        f, Kt, Ct = self.forces(q, v)
        rhs = -(hb.C0 @ v[..., None])[..., 0] - (hb.Kl @ q[..., None])[..., 0] - f
        if self.na:
            rhs = rhs - (sys.lag_D @ xi[..., None])[..., 0]
        if sys.load is not None:
            rhs = rhs + sys.load
        return torch.linalg.solve(hb.Mt, rhs), Kt, Ct

    def _lag_step(self, h3: Tensor) -> dict:
        """The lag states' implicit update at γh (B, 1, 1): ξ1 = P⁻¹ ξ̂ + W q̇1 with
        P = I − γh R, W = γh P⁻¹ E, so that their force on the structure is D P⁻¹ ξ̂ + D W q̇1
        (the damping C_eff = C0 + D W). ``PD``: [P⁻¹; D P⁻¹] (B, na + n, na), both images of
        the predictor ξ̂ in one product."""
        sys, hb = self.system, self.hb
        eye = torch.eye(self.na, dtype=hb.Mt.dtype, device=hb.Mt.device)
        Pinv = torch.linalg.inv(eye - self.o.gamma * h3 * sys.lag_R)
        W = self.o.gamma * h3 * Pinv @ sys.lag_E
        return {"Pinv": Pinv, "W": W, "Ceff": hb.C0 + sys.lag_D @ W,
                "PD": torch.cat([Pinv, sys.lag_D @ Pinv], dim=1)}

    def run_periods(self, x0: tuple[Tensor, Tensor, Tensor], period: Tensor, N: Tensor,
                    periods: int) -> tuple[Tensor, Tensor, Tensor]:
        """The state (q, q̇, ξ) after ``periods`` × N (B,) steps of h = T/N from x0 (no
        monodromy)."""
        rows = torch.zeros(1, self.n, dtype=self.hb.Mt.dtype, device=self.hb.Mt.device)
        for _ in range(periods):
            out = self.propagate(x0, period, N, rows, tangent=False)
            x0 = (out["q"], out["v"], out["xi"])
        return x0

    def propagate(self, x0: tuple[Tensor, Tensor, Tensor], period: Tensor, N: Tensor,
                  rows: Tensor, tangent: bool) -> dict:
        """Integrate N (B,) steps of h = T/N from x0 = (q, v, ξ); with ``tangent``, also the
        monodromy (B, m, m), ∂x_N/∂T (B, m), m = 2n + na, and the outputs' sensitivities
        ∂y_k/∂(x0, T) (B, max N, O, m + 1). Returns the final state, the output samples y
        (B, max N, O), the orbit scales (B, m) and the step residual (the largest last
        correction of a step's iterations relative to the largest |a|).

        Each step solves G(a1) = M_t a1 + C_eff q̇1 + K_l q1 + f_nl(q1, q̇1) + D P⁻¹ ξ̂ − load = 0
        with q1 = q̂ + βh² a1, q̇1 = v̂ + γh a1 (the Newmark predictors q̂, v̂, ξ̂): its linear
        part is S a1 + G0 with S = M_t + γh C_eff + βh² K_l (per case, fixed) and G0 from the
        predictors (per step), so an iteration costs one product, the force and a solve."""
        o, hb, sys = self.o, self.hb, self.system
        n, na, B = self.n, self.na, self.B
        dtype, dev = hb.Mt.dtype, hb.Mt.device
        be, ga = o.beta, o.gamma
        Nf = N.to(dtype).view(B, 1)
        h = period.view(B, 1) / Nf
        h3 = h.view(B, 1, 1)
        # Newmark's coefficients per case: q1 = q̂ + cq a1, q̇1 = v̂ + cv a1, and the predictors'
        # q̂ = q + h q̇ + ca a, v̂ = q̇ + cb a (ξ̂ alike with ξ̇)
        cq, cv, ca, cb = be * h * h, ga * h, (0.5 - be) * h * h, (1.0 - ga) * h
        cq3, cv3, ca3, cb3 = (c.view(B, 1, 1) for c in (cq, cv, ca, cb))
        # ∂/∂T of the predictors through h = T/N: ∂q̂/∂T = (q̇ + ta a + ta1 a1)/N...,
        # ∂v̂/∂T = (tb a + tb1 a1)/N (ξ̂ alike with ξ̇), the 1/N folded in
        inv_N = 1.0 / Nf
        ta, ta1 = 2.0 * (0.5 - be) * h * inv_N, 2.0 * be * h * inv_N
        tb, tb1 = (1.0 - ga) * inv_N, ga * inv_N
        q, v, xi = (t.clone() for t in x0)
        a, Kt, Ct = self.acceleration(q, v, xi)
        if na:
            lag = self._lag_step(h3)
            Ceff = lag["Ceff"]
            xid = (sys.lag_E @ v[..., None] + sys.lag_R @ xi[..., None])[..., 0]
            linear = torch.cat([Ceff, hb.Kl, lag["PD"][:, na:]], dim=2)  # G0's [C_eff K_l DP⁻¹]
        else:
            Ceff, xid = hb.C0, xi
            linear = torch.cat([Ceff, hb.Kl], dim=2)
        S = hb.Mt + cv3 * Ceff + cq3 * hb.Kl
        Cn = Ct - hb.C0  # the nonlinear damping tangent (zero without it)
        m = 2 * n + na
        if tangent:
            # columns: perturbations of (q0, v0, ξ0), then d/dT
            cols = m + 1
            I = torch.eye(m, cols, dtype=dtype, device=dev).expand(B, m, cols)
            dq, dv, dxi = I[:, :n].clone(), I[:, n:2 * n].clone(), I[:, 2 * n:].clone()
            rhs = Kt @ dq + Ct @ dv
            if na:
                rhs = rhs + sys.lag_D @ dxi
            da = -torch.linalg.solve(hb.Mt, rhs)
            dxid = sys.lag_E @ dv + sys.lag_R @ dxi if na else dxi
        # the step's Newton matrix at the current state (see the step below)
        Jinv = _step_inverse(S + cv3 * Cn + cq3 * (Kt - hb.Kl))
        Nmax, Nmin = int(N.max()), int(N.min())
        O = rows.shape[0]
        y = torch.empty(B, Nmax, O, dtype=dtype, device=dev)
        if tangent:
            yt = torch.empty(B, Nmax, O, cols, dtype=dtype, device=dev)  # ∂y_k/∂(x0, T)
        scale = torch.cat([q.abs(), v.abs(), xi.abs()], dim=1)
        # the last iteration's correction and the acceleration, largest |·| per component
        last_corr, a_max = torch.zeros_like(q), a.abs()
        load = sys.load
        a_prev = a
        for k in range(Nmax):
            y[:, k] = q @ rows.T
            if tangent:
                yt[:, k] = rows @ dq
            qh = torch.addcmul(torch.addcmul(q, h, v), ca, a)
            vh = torch.addcmul(v, cb, a)
            a1 = 2.0 * a - a_prev  # linear extrapolation
            if na:
                xih = torch.addcmul(xi, cb, xid)
                lag_images = (lag["PD"] @ xih[..., None])[..., 0]
                xi_base = lag_images[:, :na]
                G0 = (linear @ torch.cat([vh, qh, xih], 1)[..., None])[..., 0]
            else:
                G0 = (linear @ torch.cat([vh, qh], 1)[..., None])[..., 0]
            if load is not None:
                G0 = G0 - load
            # modified Newton on the step's equation with the Jacobian of the last step's
            # solution (O(h) away, so the iterations contract by O(h²)). The monodromy needs
            # the tangent at this step's solution (at a predictor's, the trivial multiplier of
            # the Goland orbits moves by ~1e-2): it is taken with the force of the last
            # iteration, one correction short of the solution (the predictor's error after
            # two contractions by O(h²)): one force evaluation fewer per step, for
            # |μ_trivial − 1| of ~1e-6 instead of ~4e-7 on the finished γ = 0 orbits, four
            # orders below TRIVIAL_TOL. It is also the next step's iteration matrix
            last = o.step_iterations - 1
            for i in range(o.step_iterations):
                q1, v1 = torch.addcmul(qh, cq, a1), torch.addcmul(vh, cv, a1)
                if not self.nonlinear:
                    f = 0.0
                elif i < last:
                    f = self.nonlinear_force(q1, v1)
                else:
                    f, Kn, Cn_new = self.nonlinear_tangents(q1, v1)
                G = torch.baddbmm(G0[..., None], S, a1[..., None])[..., 0] + f
                corr = (Jinv @ G[..., None])[..., 0]
                a1 = a1 - corr
            last_corr = torch.maximum(last_corr, corr.abs())
            a_max = torch.maximum(a_max, a1.abs())
            q1, v1 = torch.addcmul(qh, cq, a1), torch.addcmul(vh, cv, a1)
            if self.nonlinear:
                Kt = hb.Kl + Kn
                Cn = Cn if Cn_new is None else Cn_new
                Jinv = _step_inverse(S + cv3 * Cn + cq3 * Kn)
            if na:
                xi1 = xi_base + (lag["W"] @ v1[..., None])[..., 0]
                xid1 = (sys.lag_E @ v1[..., None] + sys.lag_R @ xi1[..., None])[..., 0]
            if tangent:
                # linearised step (module docstring): J da1 = −[(C_eff + C_n) r_v + K_t r_q
                # + D r_ξ], r the predictors' perturbations; only the last column (d/dT) has
                # the step-size terms (dh/dT = 1/N)
                # (in place on the step's own new tensors: at large B each (B, n, m + 1)
                # allocation costs as much as the arithmetic)
                rq = torch.addcmul(dq, h3, dv).addcmul_(ca3, da)
                rv = torch.addcmul(dv, cb3, da)
                rq[..., -1] += torch.addcmul(torch.addcmul(v * inv_N, ta, a), ta1, a1)
                rv[..., -1] += torch.addcmul(tb * a, tb1, a1)
                rhs = torch.bmm(Kt, rq).baddbmm_(Ceff + Cn, rv)
                if na:
                    dxih = torch.addcmul(dxi, cb3, dxid)
                    dxih[..., -1] += torch.addcmul(tb * xid, tb1, xid1)
                    images = lag["PD"] @ dxih
                    rxi = images[:, :na]
                    rhs += images[:, na:]
                da1 = torch.bmm(Jinv, rhs).neg_()
                dq1 = rq.addcmul_(cq3, da1)
                dv1 = rv.addcmul_(cv3, da1)
                if na:
                    dxi1 = torch.baddbmm(rxi, lag["W"], dv1)
                    dxid1 = torch.bmm(sys.lag_E, dv1).baddbmm_(sys.lag_R, dxi1)
            if k < Nmin:  # every case still stepping: no masks
                a_prev, q, v, a = a, q1, v1, a1
                if na:
                    xi, xid = xi1, xid1
                if tangent:
                    dq, dv, da = dq1, dv1, da1
                    if na:
                        dxi, dxid = dxi1, dxid1
            else:
                live = (k < N).view(B, 1)
                live3 = live.view(B, 1, 1)
                a_prev = torch.where(live, a, a_prev)
                q, v, a = (torch.where(live, new, old)
                           for new, old in ((q1, q), (v1, v), (a1, a)))
                if na:
                    xi, xid = torch.where(live, xi1, xi), torch.where(live, xid1, xid)
                if tangent:
                    dq, dv, da = (torch.where(live3, new, old)
                                  for new, old in ((dq1, dq), (dv1, dv), (da1, da)))
                    if na:
                        dxi, dxid = (torch.where(live3, new, old)
                                     for new, old in ((dxi1, dxi), (dxid1, dxid)))
            scale = torch.maximum(scale, torch.cat([q, v, xi], dim=1).abs())
        step_error = last_corr.amax(1) / a_max.amax(1).clamp_min(torch.finfo(dtype).tiny)
        out = {"q": q, "v": v, "xi": xi, "y": y, "scale": scale, "step_error": step_error}
        if tangent:
            full = torch.cat([dq, dv, dxi], dim=1)  # (B, m, m + 1)
            out["monodromy"], out["dT"], out["yt"] = full[:, :, :m], full[:, :, m], yt
        return out


# ---------------------------------------------------------------------------------------------
def amplitude_of_samples(y: Tensor, N: np.ndarray) -> np.ndarray:
    """(B, O) half peak-to-peak of periodic samples y (B, ≥N, O), the first N[b] of case b:
    the extremes of their trigonometric interpolant (:func:`~.fourier.band_limited_extreme`;
    a parabola's reading error, ~(2π/N)⁴/8, would enter the Richardson evaluations at 2h and
    4h as an h⁴ term of its own)."""
    out = np.full((y.shape[0], y.shape[2]), np.nan)
    for steps in np.unique(N):
        idx = np.flatnonzero(N == steps)
        ys = y[torch.as_tensor(idx), : int(steps)]
        amp = 0.5 * (band_limited_extreme(ys, 1.0)[1] - band_limited_extreme(ys, -1.0)[1])
        out[idx] = amp.cpu().numpy()
    return out


def _scale_floor(scale: Tensor, n: int, na: int) -> Tensor:
    """Orbit scales with a floor per group (q, q̇, ξ): a component that stays near zero on the
    orbit is measured against its group's largest, not against its own rounding."""
    parts = torch.split(scale, [n, n, na], dim=1)
    floored = [p.clamp_min(1e-6 * p.amax(1, keepdim=True).clamp_min(1e-300)) if p.shape[1]
               else p for p in parts]
    return torch.cat(floored, dim=1)


def multipliers(monodromy: Tensor, flow: Tensor, scale: Tensor, mask: Tensor
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(μ (B, m), |μ_trivial − 1|, critical |μ|, stable) from monodromy matrices (B, m, m).

    The trivial multiplier is the one whose eigenvector is most nearly parallel to the flow
    ẋ(0) (B, m), compared in the metric scaled by the orbit (B, m) on the state components
    ``mask`` (m,) selects; stable is None where it is farther than :data:`TRIVIAL_TOL` from
    1."""
    Ms = monodromy / scale[:, :, None] * scale[:, None, :]
    mu, vec = torch.linalg.eig(Ms)
    f = (flow / scale)[:, mask].to(vec.dtype)
    f = f / f.norm(dim=1, keepdim=True).clamp_min(1e-300)
    vm = vec[:, mask]
    vn = vm / vm.norm(dim=1, keepdim=True).clamp_min(1e-300)
    align = (vn.conj() * f[:, :, None]).sum(1).abs()  # (B, m)
    triv = align.argmax(1)
    B = mu.shape[0]
    mu_np = mu.cpu().numpy()
    t = triv.cpu().numpy()
    trivial_error = np.abs(mu_np[np.arange(B), t] - 1.0)
    others = np.abs(mu_np).copy()
    others[np.arange(B), t] = -np.inf
    critical = others.max(1) if mu_np.shape[1] > 1 else np.zeros(B)
    stable = np.array([None if not (e <= TRIVIAL_TOL) or not np.isfinite(c) else bool(c < 1.0)
                       for e, c in zip(trivial_error, critical)], dtype=object)
    return mu_np, trivial_error, critical, stable


def flow(system: CaseSystem, q: Tensor, v: Tensor, xi: Tensor) -> Tensor:
    """ẋ = (q̇, q̈, ξ̇) (B, 2n + na) of the B cases at the states (q, q̇, ξ)."""
    a, _, _ = _Map(system, ShootingOptions()).acceleration(q, v, xi)
    xid = ((system.lag_E @ v[..., None] + system.lag_R @ xi[..., None])[..., 0]
           if system.n_lag else xi)
    return torch.cat([v, a, xid], 1)


#: bytes of the outputs' sensitivities ∂y_k/∂(x0, T) a pass may hold (B × N × O × (m + 1)
#: doubles): a larger batch is shot in groups of cases (at the batch widths where the group
#: is this large the integrator's cost per case no longer falls with B)
SENSITIVITY_BYTES = 256 * 2 ** 20


def shoot(system: CaseSystem, start: OrbitStart, decision_row, rows=None,
          options: ShootingOptions | None = None) -> ShootingResult:
    """The discrete periodic orbits near ``start`` of the B cases of ``system`` (module
    docstring); ``decision_row`` (n,): the output whose amplitude certifies the orbit;
    ``rows`` (O, n): the outputs whose amplitudes are reported (default the decision row).

    Phase condition: x0 stays on a section through the start transversal to the flow (see
    the code), so any point of an orbit is a valid start."""
    o = options or ShootingOptions()
    B = system.batch_size
    outputs = 1 + (1 if rows is None else np.asarray(rows).reshape(-1, system.n).shape[0])
    steps = float(torch.nan_to_num(start.period.detach().double(), nan=0.0,
                                   posinf=0.0).max()) / o.dt + 1
    per_case = 8.0 * steps * outputs * (2 * system.n + system.n_lag + 1)
    group = max(1, int(SENSITIVITY_BYTES // max(per_case, 1.0)))
    if B <= group:
        return _shoot(system, start, decision_row, rows, o)
    parts = [_shoot(system.select(torch.arange(i, min(i + group, B))),
                    _start_rows(start, slice(i, i + group)), decision_row, rows, o)
             for i in range(0, B, group)]
    return ShootingResult(**{f.name: (torch.cat if isinstance(getattr(parts[0], f.name),
                                                              Tensor) else np.concatenate)(
        [getattr(p, f.name) for p in parts]) for f in fields(ShootingResult)})


def _start_rows(start: OrbitStart, rows: slice) -> OrbitStart:
    """The starts ``rows`` of ``start``."""
    return OrbitStart(*(None if t is None else t[rows] for t in (
        start.q, start.v, start.xi, start.period, start.amplitude, start.coarse_amplitude)))


def _shoot(system: CaseSystem, start: OrbitStart, decision_row, rows,
           o: ShootingOptions) -> ShootingResult:
    """:func:`shoot` on one group of cases."""
    sys64 = system.to(dtype=torch.float64)
    dev = sys64.device
    f64 = {"dtype": torch.float64, "device": dev}
    c = torch.as_tensor(np.asarray(decision_row, dtype=float), **f64).reshape(-1)
    R = c[None] if rows is None else torch.as_tensor(np.asarray(rows, dtype=float), **f64)
    n, na, B = sys64.n, sys64.n_lag, sys64.batch_size
    m = 2 * n + na
    x = torch.cat([start.q.to(**f64).reshape(B, n), start.v.to(**f64).reshape(B, n),
                   start.xi.to(**f64).reshape(B, na)], 1).clone()
    T = start.period.to(**f64).reshape(B).clone()
    ok = torch.isfinite(T) & (T > 0) & torch.isfinite(x).all(1)
    N = torch.where(ok, torch.round(T / o.dt), torch.ones_like(T)).clamp_min(8).long()
    x_ref = x.clone()
    # the flow's components compared with the trivial eigenvector: all but the accelerations
    # of the dual coordinates, which a start off the orbit (a truncated Fourier series, a
    # transient) has far from the orbit's: their stiff restoring forces amplify the offset
    compared = torch.ones(m, dtype=torch.bool, device=dev)
    kinds = list(getattr(sys64.rom, "mode_kinds", None) or [])
    compared[n:2 * n] = torch.as_tensor([k != "dual" for k in kinds] if len(kinds) == n
                                        else [True] * n, device=dev)
    section = torch.zeros(B, m, **f64)  # the phase condition's row, set on the first pass
    scale = torch.ones(B, m, **f64)
    converged = np.zeros(B, dtype=bool)
    accepted = np.zeros(B, dtype=bool)
    relaxed = np.zeros(B, dtype=bool)
    reported = (None if start.amplitude is None or o.accept is None
                else np.asarray(start.amplitude.detach().cpu(), dtype=float).reshape(B))
    coarse = (None if start.coarse_amplitude is None
              else np.asarray(start.coarse_amplitude.detach().cpu(), dtype=float).reshape(B))
    failed = ~ok.cpu().numpy()
    iterations = np.zeros(B, dtype=np.int64)
    nan = np.full(B, np.nan)
    first, first_amp, last = nan.copy(), nan.copy(), nan.copy()
    start_amp, last_amp = nan.copy(), nan.copy()
    first_period, last_period = nan.copy(), nan.copy()
    amp = np.full((B, R.shape[0]), np.nan)
    start_amps, first_amps, last_amps = amp.copy(), amp.copy(), amp.copy()
    mu = np.full((B, m), np.nan + 0j)
    triv, crit = nan.copy(), nan.copy()
    stable = np.full(B, None, dtype=object)
    for it in range(o.max_iterations + 1):
        active = np.flatnonzero(~converged & ~failed & ~accepted)
        if active.size == 0:
            break
        idx = torch.as_tensor(active, device=dev)
        sub = sys64.select(idx)
        x0, Ts, Ns = x[idx], T[idx], N[idx]
        out = _Map(sub, o).propagate((x0[:, :n], x0[:, n:2 * n], x0[:, 2 * n:]), Ts, Ns,
                                     torch.cat([c[None], R]), tangent=True)
        # a start's scales and section from its own first pass: every case's on the first,
        # a relaxed start's on the next (relaxation happens only after the first)
        f = np.arange(active.size) if it == 0 else np.flatnonzero(relaxed[active] & (it == 1))
        if f.size:
            tf = torch.as_tensor(f, device=dev)
            gf, xf = idx[tf], x0[tf]
            scale[gf] = _scale_floor(out["scale"][tf], n, na)
            # the section through the start whose normal, in the plane of the decision output
            # (y, ẏ/ω), is the flow there: ẏ (y − y_ref) + (ÿ/ω²)(ẏ − ẏ_ref) = 0 (ẏ = 0 when
            # the start is at a peak); the output, not the whole state, because a start's
            # stiff coordinates carry a fast transient that the orbit does not have
            fl = flow(sub.select(tf), xf[:, :n], xf[:, n:2 * n], xf[:, 2 * n:])
            w2 = (2 * math.pi / Ts[tf]) ** 2
            section[gf, :n] = (xf[:, n:2 * n] @ c)[:, None] * c
            section[gf, n:2 * n] = ((fl[:, n:2 * n] @ c) / w2)[:, None] * c
        sc, p = scale[idx], section[idx]
        res = torch.cat([out["q"], out["v"], out["xi"]], 1) - x0
        Bm = len(active)
        A = torch.zeros(Bm, m + 1, m + 1, **f64)
        A[:, :m, :m] = out["monodromy"] - torch.eye(m, **f64)
        A[:, :m, m] = out["dT"]
        A[:, m, :m] = p
        rhs = torch.cat([-res, -((x0 - x_ref[idx]) * p).sum(1, keepdim=True)], 1)
        # scaled unknowns Δx/scale, ΔT/T; equations scaled alike (the phase row by |p|·scale)
        colscale = torch.cat([sc, Ts[:, None]], 1)
        rowscale = torch.cat([sc, (p.abs() * sc).sum(1, keepdim=True).clamp_min(1e-300)], 1)
        As = A * colscale[:, None, :] / rowscale[:, :, None]
        dz, info = torch.linalg.solve_ex(As, (rhs / rowscale)[..., None])
        dz = dz[..., 0]
        good = ((info == 0) & torch.isfinite(dz).all(1) & torch.isfinite(res).all(1)).cpu().numpy()
        size = dz.abs().amax(1)
        size_np = size.cpu().numpy()
        steps_np = Ns.cpu().numpy()
        # every output's amplitude (the decision output first) and that of the first-order
        # samples of the corrected orbit, y_k + ∂y_k/∂(x0, T) Δz; the relative change of each
        # and of the period (ΔT/T: the scaled unknown) is how far the pass's orbit is from
        # the discrete one
        a_now_all = amplitude_of_samples(out["y"], steps_np)
        dy = torch.einsum("bkoc,bc->bko", out["yt"], dz * colscale)
        with np.errstate(invalid="ignore", divide="ignore"):
            change = amplitude_of_samples(out["y"] + dy, steps_np) / a_now_all - 1.0
        a_now = a_now_all[:, 0]
        a_new = a_now * (1.0 + change[:, 0])
        dT = dz[:, m].cpu().numpy()
        if it == 0:
            first[active] = size_np
            first_amp[active], first_amps[active] = change[:, 0], change[:, 1:]
            start_amp[active], start_amps[active] = a_now, a_now_all[:, 1:]
            first_period[active] = dT
        last[active] = size_np
        last_amp[active], last_amps[active] = change[:, 0], change[:, 1:]
        last_period[active] = dT
        amp[active] = a_now_all[:, 1:]
        done = (size_np <= o.tol) & good
        candidate = np.zeros_like(done)
        if it == 0 and reported is not None:
            # the start is accepted where the discrete orbit's amplitude (to second order in
            # the start's distance), or its Richardson extrapolation with the coarse one, is
            # within ``accept`` of the reported one
            target = a_new if coarse is None else a_new + (a_new - coarse[active]) / 3.0
            with np.errstate(invalid="ignore", divide="ignore"):
                candidate = good & ~done & (np.abs(reported[active] / target - 1.0) <= o.accept)
        final = done | candidate | (good & (it == o.max_iterations))
        if final.any():
            # the stability of the converged orbit (or, on the last pass, of the orbit nearest
            # the start that was reached: the certificate's monodromy)
            d = np.flatnonzero(final)
            td = torch.as_tensor(d, device=dev)
            sd = sub.select(td)
            fl = flow(sd, x0[td, :n], x0[td, n:2 * n], x0[td, 2 * n:])
            mus, te, cm, st = multipliers(out["monodromy"][td], fl, sc[td], compared)
            gi = active[d]
            mu[gi], triv[gi], crit[gi], stable[gi] = mus, te, cm, st
            converged[active[done]] = True
        take = candidate & np.array([s is not None for s in stable[active]], dtype=bool)
        accepted[active[take]] = True
        failed[active[~good]] = True
        step = ~done & ~take & good
        if it == o.max_iterations or not step.any():
            continue
        # far from the orbit on the first pass: relaxed along the trajectory (the options)
        relax = step & (size_np > o.relax_above) & (it == 0 and o.relax_periods > 0)
        if relax.any():
            sel = torch.as_tensor(np.flatnonzero(relax), device=dev)
            end = tuple(out[k][sel] for k in ("q", "v", "xi"))
            if o.relax_periods > 1:
                end = _Map(sub.select(sel), o).run_periods(end, Ts[sel], Ns[sel],
                                                           o.relax_periods - 1)
            x[idx[sel]] = torch.cat(end, 1)
            x_ref[idx[sel]] = x[idx[sel]]
            relaxed[active[relax]] = True
        step = step & ~relax
        # limit the step to max_step of the orbit's size in every scaled component
        factor = (o.max_step / size.clamp_min(1e-300)).clamp(max=1.0)
        dzs = dz * factor[:, None]
        sel = torch.as_tensor(np.flatnonzero(step), device=dev)
        gsel = idx[sel]
        x[gsel] = x[gsel] + dzs[sel, :m] * sc[sel]
        T[gsel] = T[gsel] * (1.0 + dzs[sel, m])
        iterations[active[step | relax]] += 1
    amp[~(converged | accepted)] = np.nan
    return ShootingResult(q=x[:, :n], v=x[:, n:2 * n], xi=x[:, 2 * n:], period=T,
                          steps=N.cpu().numpy(), converged=converged, iterations=iterations,
                          first_correction=first, first_amplitude_correction=first_amp,
                          start_amplitude=start_amp, correction=last,
                          amplitude_correction=last_amp, amplitude=amp, multipliers=mu,
                          start_amplitudes=start_amps, first_amplitude_corrections=first_amps,
                          amplitude_corrections=last_amps,
                          first_period_correction=first_period,
                          period_correction=last_period,
                          trivial_error=triv,
                          critical_multiplier=crit, stable=stable, accepted=accepted,
                          relaxed=relaxed)


def start_from_fourier(system: CaseSystem, X: Tensor, omega: Tensor, decision_row,
                       n_points: int = 1024) -> OrbitStart:
    """Shooting starts from Fourier orbits X (B, 2H+1, n), ω (B,): the state where the decision
    output is largest (phase-shifted coefficients, lag states from their harmonics)."""
    from .fourier import synthesis_matrix
    from .solve import orbit_state

    X = X.to(torch.float64)
    omega = omega.to(torch.float64)
    H = (X.shape[1] - 1) // 2
    r = torch.as_tensor(np.asarray(decision_row, dtype=float), dtype=X.dtype).reshape(-1)
    y = synthesis_matrix(H, n_points, X.device, X.dtype) @ (X @ r)[..., None]  # (B, P, 1)
    pos, _ = parabolic_extreme(y, 1.0)
    tau = 2 * math.pi * pos[:, 0] / n_points
    k = torch.arange(1, H + 1, dtype=X.dtype)
    ck, sk = torch.cos(k[None] * tau[:, None])[..., None], torch.sin(k[None] * tau[:, None])[
        ..., None]
    a, b = X[:, 1::2], X[:, 2::2]
    Xs = X.clone()
    Xs[:, 1::2] = a * ck + b * sk
    Xs[:, 2::2] = b * ck - a * sk
    q, v, xi = orbit_state(system.to(dtype=torch.float64), Xs, omega)
    return OrbitStart(torch.as_tensor(q), torch.as_tensor(v), torch.as_tensor(xi),
                      2 * math.pi / omega)
