"""An independent continuous-time reference for LCO certificates: shooting on the ODE of a
:class:`~torchrom.sim.CaseSystem` with scipy's DOP853 (rtol 1e-10) and the variational
monodromy, none of torchrom's solvers, kernels or Fourier machinery.

The right-hand side is written here from the ROM's dense tensors (DESIGN "Conventions": K2
symmetric in its last two indices, K3 in its last three, D3 in its middle two):

    M_t q̈ = load − (C_0 q̇ + K_l q + s[K2(q,q) + K3(q,q,q)] + g[D2(q) + D3(q,q)] q̇ + D ξ),
    ξ̇ = E q̇ + R ξ,

with the per-case matrices of the system (M_t = M + M_add, C_0 = αM + γD̄1 + C_add,
K_l = K1 + K_add, g = γ·d). Newton on (x0, T) for Φ(x0, T) − x0 = 0 with the phase condition
c·q̇(0) = 0 (c: the decision output; y(0) at an extreme), its Jacobian from the monodromy
∂Φ/∂x0 integrated with the orbit and ∂Φ/∂T = f(Φ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

RTOL = 1e-10


@dataclass
class ODEOrbit:
    """The reference orbit of one case: its state at t = 0, period (s), the outputs'
    half peak-to-peak amplitudes (O,), the frequency (Hz), the Floquet multipliers and the
    largest one other than the trivial one (modulus), and the last Newton correction."""

    x0: np.ndarray
    period: float
    amplitude: np.ndarray
    frequency_hz: float
    multipliers: np.ndarray
    critical: float
    correction: float


class CaseODE:
    """The first-order ODE of case ``i`` of ``system`` (module docstring), numpy float64."""

    def __init__(self, system, i: int):
        rom = system.rom

        def case(t):
            return None if t is None else t[i].detach().cpu().double().numpy()

        def add(base, extra):
            return base if extra is None else base + case(extra)

        M, K1, D1 = (getattr(rom, k).double().numpy() for k in ("M", "K1", "D1"))
        self.K2, self.K3, self.D2, self.D3 = (getattr(rom, k).double().numpy()
                                              for k in ("K2", "K3", "D2", "D3"))
        a, gam = float(system.alpha[i]), float(system.gamma[i])
        self.s = float(system.stiffness_nl[i])
        self.g = gam * float(system.damping_nl[i])
        self.Mt = add(M, system.M_add)
        self.C0 = add(a * M + gam * D1, system.C_add)
        self.Kl = add(K1, system.K_add)
        self.Minv = np.linalg.inv(self.Mt)
        self.n = n = M.shape[0]
        self.na = system.n_lag
        self.D = case(system.lag_D) if self.na else np.zeros((n, 0))
        self.E = case(system.lag_E) if self.na else np.zeros((0, n))
        self.R = case(system.lag_R) if self.na else np.zeros((0, 0))
        self.load = case(system.load) if system.load is not None else np.zeros(n)

    @property
    def size(self) -> int:
        return 2 * self.n + self.na

    def split(self, x):
        n = self.n
        return x[:n], x[n:2 * n], x[2 * n:]

    def rhs(self, x):
        q, v, xi = self.split(x)
        f = self.C0 @ v + self.Kl @ q + self.D @ xi - self.load
        f = f + self.s * (np.einsum("mnl,n,l->m", self.K2, q, q)
                          + np.einsum("mnlp,n,l,p->m", self.K3, q, q, q))
        f = f + self.g * (np.einsum("mln,l,n->m", self.D2, q, v)
                          + np.einsum("mlpn,l,p,n->m", self.D3, q, q, v))
        return np.concatenate([v, -self.Minv @ f, self.E @ v + self.R @ xi])

    def jacobian(self, x):
        """∂f/∂x (size, size)."""
        q, v, xi = self.split(x)
        n, na = self.n, self.na
        Kq = self.Kl + self.s * (2 * np.einsum("mnl,l->mn", self.K2, q)
                                 + 3 * np.einsum("mnlp,l,p->mn", self.K3, q, q))
        Kq = Kq + self.g * (np.einsum("mjn,n->mj", self.D2, v)
                            + 2 * np.einsum("mjpn,p,n->mj", self.D3, q, v))
        Cv = self.C0 + self.g * (np.einsum("mln,l->mn", self.D2, q)
                                 + np.einsum("mlpn,l,p->mn", self.D3, q, q))
        A = np.zeros((self.size, self.size))
        A[:n, n:2 * n] = np.eye(n)
        A[n:2 * n, :n] = -self.Minv @ Kq
        A[n:2 * n, n:2 * n] = -self.Minv @ Cv
        if na:
            A[n:2 * n, 2 * n:] = -self.Minv @ self.D
            A[2 * n:, n:2 * n] = self.E
            A[2 * n:, 2 * n:] = self.R
        return A

    def flow(self, x0, period: float, rows: np.ndarray | None = None, monodromy: bool = True,
             samples: int = 2048):
        """(x(T), Φ (or None), outputs on ``samples`` points of [0, T] (P, O) or None)."""
        m = self.size

        def f(_t, z):
            x = z[:m]
            dx = self.rhs(x)
            if not monodromy:
                return dx
            P = z[m:].reshape(m, m)
            return np.concatenate([dx, (self.jacobian(x) @ P).ravel()])

        z0 = np.concatenate([x0, np.eye(m).ravel()]) if monodromy else x0
        t_eval = np.linspace(0.0, period, samples + 1) if rows is not None else None
        sol = solve_ivp(f, (0.0, period), z0, method="DOP853", rtol=RTOL, atol=RTOL * 1e-3,
                        t_eval=t_eval)
        if not sol.success:
            raise RuntimeError(f"solve_ivp: {sol.message}")
        zT = sol.y[:, -1]
        y = None if rows is None else (rows @ sol.y[: self.n, :-1]).T
        return zT[:m], (zT[m:].reshape(m, m) if monodromy else None), y


def shoot_ode(ode: CaseODE, x0, period: float, decision_row, rows, iterations: int = 8,
              tol: float = 1e-9) -> ODEOrbit:
    """The periodic orbit of ``ode`` near (x0, period) by Newton on (x0, T) (module
    docstring); amplitudes of ``rows`` (O, n) from 2048 samples of the converged period,
    refined by a parabola at each extreme."""
    return _shoot(ode, ode.flow, x0, period, decision_row, rows, iterations, tol)


def _shoot(ode, flow, x0, period: float, decision_row, rows, iterations: int,
           tol: float) -> ODEOrbit:
    """Newton on (x0, T) with ``flow(x, T, rows=None)`` -> (x(T), monodromy, samples)."""
    n, m = ode.n, ode.size
    c = np.asarray(decision_row, dtype=float)
    x, T = np.asarray(x0, dtype=float).copy(), float(period)
    scale = np.maximum(np.abs(x), 1e-12 * np.abs(x).max())
    step = np.inf
    for _ in range(iterations):
        xT, Phi, _ = flow(x, T)
        G = np.concatenate([xT - x, [c @ x[n:2 * n]]])
        J = np.zeros((m + 1, m + 1))
        J[:m, :m] = Phi - np.eye(m)
        J[:m, m] = ode.rhs(xT)
        J[m, n:2 * n] = c
        d = np.linalg.lstsq(J, -G, rcond=None)[0]
        x, T = x + d[:m], T + d[m]
        step = max(np.max(np.abs(d[:m]) / scale.max()), abs(d[m]) / T)
        if step < tol:
            break
    _, Phi, y = flow(x, T, rows=np.atleast_2d(rows))
    mu = np.linalg.eigvals(Phi)
    trivial = np.argmin(np.abs(mu - 1.0))
    critical = float(np.max(np.abs(np.delete(mu, trivial))))
    return ODEOrbit(x, T, _half_range(y), 1.0 / T, mu, critical, float(step))


def _half_range(y: np.ndarray) -> np.ndarray:
    """(O,) half peak-to-peak of periodic samples y (P, O), each extreme refined by the
    parabola through it and its two neighbours."""
    def extreme(z):
        i = np.argmax(z, axis=0)
        P = z.shape[0]
        cols = np.arange(z.shape[1])
        a, b, cc = z[(i - 1) % P, cols], z[i, cols], z[(i + 1) % P, cols]
        den = a - 2 * b + cc
        return np.where(den != 0, b - 0.125 * (a - cc) ** 2 / np.where(den != 0, den, 1), b)
    return 0.5 * (extreme(y) + extreme(-y))


class StiffCaseODE(CaseODE):
    """The same ODE with its nonlinear tensors flattened for matrix-vector products (K2 as
    (n, n²), K3 as (n, n³), ...): the right-hand side and Jacobian of :class:`CaseODE`, cheap
    enough for the ~10⁵ fixed steps of :func:`shoot_ode_rk4` on a ROM with stiff dual modes."""

    def __init__(self, system, i: int):
        super().__init__(system, i)
        n = self.n
        self.K2f = self.K2.reshape(n, n * n)
        self.K3f = self.K3.reshape(n, n ** 3)
        self.K3j = self.K3.reshape(n * n, n * n)  # [(m, n), (l, p)]
        self.D2j = self.D2.reshape(n, n * n)  # [m, (l, n)]
        self.D3j = self.D3.reshape(n, n ** 3)  # [m, (l, p, n)]
        # the damping's tangents: ∂/∂q of D3(q,q) q̇ takes [(m, j), (p, n)], ∂/∂q̇ of D2(q) q̇
        # and D3(q,q) q̇ take [m, n, l] and [(m, n), (l, p)]
        self.D3q = self.D3.reshape(n * n, n * n)
        self.D2v = np.ascontiguousarray(self.D2.transpose(0, 2, 1))
        self.D3v = np.ascontiguousarray(self.D3.transpose(0, 3, 1, 2)).reshape(n * n, n * n)

    def _forces(self, q, v):
        qq = np.outer(q, q).ravel()
        f = self.C0 @ v + self.Kl @ q
        f = f + self.s * (self.K2f @ qq + self.K3f @ np.outer(qq, q).ravel())
        if self.g:
            f = f + self.g * (self.D2j @ np.outer(q, v).ravel()
                              + self.D3j @ np.outer(qq, v).ravel())
        return f

    def rhs(self, x):
        q, v, xi = self.split(x)
        f = self._forces(q, v) + self.D @ xi - self.load
        return np.concatenate([v, -self.Minv @ f, self.E @ v + self.R @ xi])

    def jacobian(self, x):
        q, v, xi = self.split(x)
        n = self.n
        qq = np.outer(q, q).ravel()
        # K3 symmetric in its last three indices: ∂K3(q,q,q)/∂q = 3 K3(·,q,q)
        Kq = self.Kl + self.s * (2 * (self.K2 @ q) + 3 * (self.K3j @ qq).reshape(n, n))
        Cv = self.C0.copy()
        if self.g:  # D2(q) q̇ = Σ D2[m,l,n] q_l v_n, D3(q,q) q̇ = Σ D3[m,l,p,n] q_l q_p v_n
            Kq = Kq + self.g * (self.D2 @ v
                                + 2 * (self.D3q @ np.outer(q, v).ravel()).reshape(n, n))
            Cv = Cv + self.g * (self.D2v @ q + (self.D3v @ qq).reshape(n, n))
        A = np.zeros((self.size, self.size))
        A[:n, n:2 * n] = np.eye(n)
        A[n:2 * n, :n] = -self.Minv @ Kq
        A[n:2 * n, n:2 * n] = -self.Minv @ Cv
        if self.na:
            A[n:2 * n, 2 * n:] = -self.Minv @ self.D
            A[2 * n:, n:2 * n] = self.E
            A[2 * n:, 2 * n:] = self.R
        return A

    def flow_rk4(self, x0, period: float, steps: int, rows=None, monodromy: bool = True):
        """(x(T), Φ or None, outputs at every step (steps, O) or None): classical RK4 with
        ``steps`` equal steps, the variational equation Ṗ = J(x) P integrated with the same
        stages (the monodromy of the discrete map, the ODE's to O(h⁴))."""
        h = period / steps
        x = np.asarray(x0, dtype=float).copy()
        m = self.size
        P = np.eye(m) if monodromy else None
        y = [] if rows is not None else None
        for _ in range(steps):
            if y is not None:
                y.append(rows @ x[: self.n])
            k1 = self.rhs(x)
            x2 = x + 0.5 * h * k1
            k2 = self.rhs(x2)
            x3 = x + 0.5 * h * k2
            k3 = self.rhs(x3)
            x4 = x + h * k3
            k4 = self.rhs(x4)
            if monodromy:
                L1 = self.jacobian(x) @ P
                L2 = self.jacobian(x2) @ (P + 0.5 * h * L1)
                L3 = self.jacobian(x3) @ (P + 0.5 * h * L2)
                L4 = self.jacobian(x4) @ (P + h * L3)
                P = P + h / 6.0 * (L1 + 2 * L2 + 2 * L3 + L4)
            x = x + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        return x, P, (None if y is None else np.array(y))


def shoot_ode_rk4(ode: StiffCaseODE, x0, period: float, decision_row, rows, steps: int,
                  iterations: int = 8, tol: float = 1e-10) -> ODEOrbit:
    """:func:`shoot_ode` with the fixed-step RK4 flow of :meth:`StiffCaseODE.flow_rk4`
    (``steps`` per period; the step scales with the period during Newton, so the discrete
    map is smooth in T). Its own accuracy: run it at two step counts (RK4 is fourth order:
    the error at the finer is ~1/15 of their difference)."""
    return _shoot(ode, lambda x, T, rows=None: ode.flow_rk4(x, T, steps, rows=rows), x0, period,
                  decision_row, rows, iterations, tol)


#: the Goland ROM outputs the certificate-truth tests compare
GOLAND_OUTPUTS = ["A_Tz", "A_Tx", "A_Ty", "max_mode1"]


def goland_hb_rows(tmp_path, altitudes_gammas):
    """The paper's full Goland model (built in ``tmp_path``), its batched system at each
    (altitude ft, γ s) with matched α, and harmonic balance's LCOs there:
    (model, system, C of :data:`GOLAND_OUTPUTS`, result)."""
    import torch

    from torchrom.paper.pipeline import goland_pipeline
    from torchrom.paper.study import FULL_PIPELINE
    from torchrom.periodic import HarmonicBalanceMethod
    from torchrom.sim import LCOCriteria
    from torchrom.study.cases import case_system

    model = goland_pipeline(FULL_PIPELINE, tmp_path, log=lambda _m: None).model
    cases = [{"altitude_ft": a, "gamma": g, "alpha": "matched"} for a, g in altitudes_gammas]
    system = case_system(model, cases, dtype=torch.float64)[0]
    C = np.stack([model.rom.outputs[o] for o in GOLAND_OUTPUTS])
    res = HarmonicBalanceMethod().run(system, outputs=GOLAND_OUTPUTS,
                                      lco=LCOCriteria(rtol=1e-3, cycles=4, max_amplitude=10.0))
    return model, system, C, res
