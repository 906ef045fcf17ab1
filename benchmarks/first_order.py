"""One case of a batched :class:`~torchrom.sim.CaseSystem` as a first-order ODE for SciPy.

    x = [q, q̇, ξ],   ẋ = [q̇,  M_T⁻¹ (−C q̇ − K q − f_nl(q, q̇) − lag_D ξ),  lag_E q̇ + lag_R ξ]

with M_T = M + M_add, C = αM + γD̄1 + C_add, K = K1 + K_add and the analytic Jacobian from
``NonlinearROM.tangents`` (paper Eq. 54). The nonlinear force is evaluated in numpy (float64)
with the same compact monomial coefficients as torchrom's batched kernel
(:class:`torchrom.sim.forces.NonlinearForces`), so that SciPy pays no torch dispatch per call.
Used by the SciPy rows of ``bench_integrator.py`` and ``bench_goland.py`` (not by the tests).
"""

from __future__ import annotations

import time

import numpy as np
import torch

from torchrom.sim.forces import NonlinearForces
from torchrom.sim.metrics import history_metrics


def _np(t):
    return None if t is None else t.detach().double().cpu().numpy()


class FirstOrderCase:
    """Case ``i`` of ``system`` as ẋ = F(x) with Jacobian (numpy float64)."""

    def __init__(self, system, i: int = 0):
        rom = system.rom
        self.rom, self.n = rom, rom.n
        self.alpha = float(system.alpha[i])
        self.gamma = float(system.gamma[i])
        self.s = float(system.stiffness_nl[i])
        self.d = float(system.damping_nl[i])
        n = self.n
        zero = np.zeros((n, n))

        def add(t):
            return zero if t is None else _np(t[i])

        M = _np(rom.M)
        self.Minv = np.linalg.inv(M + add(system.M_add))
        self.C = self.alpha * M + self.gamma * _np(rom.D1) + add(system.C_add)
        self.K = _np(rom.K1) + add(system.K_add)
        self.Kadd, self.Cadd = add(system.K_add), add(system.C_add)
        self.D = np.zeros((n, 0)) if system.lag_D is None else _np(system.lag_D[i])
        self.na = self.D.shape[1]
        self.E = np.zeros((0, n)) if system.lag_E is None else _np(system.lag_E[i])
        self.R = np.zeros((0, 0)) if system.lag_R is None else _np(system.lag_R[i])
        f = NonlinearForces(rom)
        self.pi, self.pj = _np(f.pair_i).astype(int), _np(f.pair_j).astype(int)
        self.W = _np(f.W)
        self.nd = f.n_damping_rows
        self.expand = None if f.expand is None else _np(f.expand).astype(int)
        self.K3 = _np(f.K3_gathered)
        self.p3, self.k3 = _np(f.m3_pair).astype(int), _np(f.m3_k).astype(int)
        self.has_k2, self.has_damping = f.has_k2, f.has_damping
        self.nfev = 0

    def nonlinear(self, q, v):
        """s·[K2(q,q) + K3(q,q,q)] + γ d·[D̄2(q) + D̄3(q,q)] q̇ (the kernel's summation order)."""
        n = self.n
        m2 = q[self.pi] * q[self.pj]
        U = self.W @ np.concatenate([q, m2]) if self.W is not None else np.zeros(0)
        f = np.zeros(n)
        if self.has_damping:
            Dm = U[: self.nd]
            if self.expand is not None:
                Dm = Dm[self.expand]
            f += self.gamma * self.d * (v @ Dm.reshape(n, n))  # rows (p, m): Σ_p D[p, m] q̇_p
        fK = U[self.nd: self.nd + n] if self.has_k2 else np.zeros(n)
        if self.K3 is not None:
            fK = fK + self.K3 @ (m2[self.p3] * q[self.k3])
        return f + self.s * fK

    def rhs(self, t, x):
        self.nfev += 1
        n = self.n
        q, v, xi = x[:n], x[n:2 * n], x[2 * n:]
        acc = -self.Minv @ (self.C @ v + self.K @ q + self.nonlinear(q, v) + self.D @ xi)
        return np.concatenate([v, acc, self.E @ v + self.R @ xi])

    def jac(self, t, x):
        n, na = self.n, self.na
        q, v = x[:n], x[n:2 * n]
        Kt, Ct = self.rom.tangents(torch.as_tensor(q), torch.as_tensor(v), self.alpha,
                                   self.gamma, self.s, self.d)
        Kt, Ct = Kt.numpy() + self.Kadd, Ct.numpy() + self.Cadd
        J = np.zeros((2 * n + na, 2 * n + na))
        J[:n, n:2 * n] = np.eye(n)
        J[n:2 * n, :n] = -self.Minv @ Kt
        J[n:2 * n, n:2 * n] = -self.Minv @ Ct
        J[n:2 * n, 2 * n:] = -self.Minv @ self.D
        J[2 * n:, n:2 * n] = self.E
        J[2 * n:, 2 * n:] = self.R
        return J


def scipy_amplitude(case: FirstOrderCase, x0, T: float, rtol: float, window: float, dt: float,
                    output: str = "A_Tz", cycles: int = 4):
    """Radau (analytic Jacobian) from x0 over [0, T]; the half peak-to-peak amplitude of
    ``output`` over the last ``window`` seconds (sampled at ``dt`` from the dense output),
    the wall time and the number of right-hand-side evaluations."""
    from scipy.integrate import solve_ivp

    case.nfev = 0
    t0 = time.perf_counter()
    sol = solve_ivp(case.rhs, (0.0, T), x0, method="Radau", jac=case.jac, rtol=rtol,
                    atol=rtol * 1e-3, dense_output=True)
    wall = time.perf_counter() - t0
    t = np.arange(T - window, T, dt)
    y = np.asarray(case.rom.outputs[output], dtype=float) @ sol.sol(t)[: case.n]
    return history_metrics(t, y, cycles=cycles)["amplitude"], wall, case.nfev
