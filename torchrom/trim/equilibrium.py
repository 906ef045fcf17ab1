"""Static aeroelastic equilibrium of an FE model under the steady aerodynamic loads, continued
in speed: K u = F_α(q) + F_K(q) u (linear, Nastran's SOL 144 for a restrained wing at a given
root incidence), and f(u) = F_α(q) + F_K(q) u with the co-rotational internal force
(geometrically nonlinear, the loads on the undeformed boxes).

Written here (no library solves this coupling): the aerodynamic stiffness is the low-rank
Tₛᵀ Q_ss Tₛ of :mod:`.operators`, never assembled; the linear solve is K's factorisation with
the Sherman–Morrison–Woodbury correction of rank 6 n_s. A speed at or past the static
divergence makes the corrected matrix singular and is reported as diverged, not solved.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError
from .operators import SteadyAeroOperator


@dataclass
class Equilibrium:
    """One speed's equilibrium: ``velocity`` and ``dynamic_pressure`` (the model's units),
    ``u`` free-DOF displacements (None when not reached), ``converged``, ``message``,
    ``iterations`` (nonlinear: residual evaluations)."""

    velocity: float
    dynamic_pressure: float
    u: np.ndarray | None
    converged: bool
    message: str = ""
    iterations: int = 0


class LinearSolver:
    """(K + q Tₛᵀ Q_ss Tₛ) u = b for any q by one factorisation of K and one of the 6 n_s
    influence columns Z = K⁻¹ Tₛᵀ: u = y − Z (I + q Q_ss Tₛ Z)⁻¹ q Q_ss Tₛ y, y = K⁻¹ b."""

    def __init__(self, K_factor, op: SteadyAeroOperator):
        self.factor, self.op = K_factor, op
        Z = K_factor.solve(np.asarray(op.T_s.T.todense()))
        self.Z = np.asarray(Z).reshape(op.T_s.shape[1], -1)
        self.TZ = np.asarray(op.T_s @ self.Z)

    def solve(self, q: float, b: np.ndarray) -> np.ndarray:
        y = self.factor.solve(b)
        C = q * self.op.Q_ss
        small = np.eye(len(C)) + C @ self.TZ
        if np.linalg.cond(small) > 1e12:
            raise ConvergenceError(f"static aeroelastic: singular at q = {q:.6g} (at or "
                                   "past the static divergence)")
        return y - self.Z @ np.linalg.solve(small, C @ (self.op.T_s @ y))

    def divergence_pressure(self) -> float | None:
        """The lowest positive q with K + q Tₛᵀ Q_ss Tₛ singular: the eigenvalues μ of
        −Q_ss Tₛ Z give q = 1/μ for the real positive μ (None when there is none)."""
        mu = np.linalg.eigvals(-self.op.Q_ss @ self.TZ)
        real = mu[(np.abs(mu.imag) <= 1e-9 * np.abs(mu).max()) & (mu.real > 0)].real
        return float(1.0 / real.max()) if len(real) else None


def linear_sweep(fe, op: SteadyAeroOperator, velocities, density: float, aoa_rad: float,
                 K_factor=None) -> list[Equilibrium]:
    """SOL 144-style linear equilibria at each speed (``density`` and speeds in the model's
    units, ``aoa_rad`` the rigid root incidence)."""
    from ..fe.solvers import factor_symmetric

    solver = LinearSolver(K_factor or factor_symmetric(fe.stiffness_matrix()), op)
    out = []
    for V in velocities:
        q = 0.5 * density * V**2
        try:
            u = solver.solve(q, op.incidence_load(q, aoa_rad))
            out.append(Equilibrium(float(V), q, u, True))
        except ConvergenceError as exc:
            out.append(Equilibrium(float(V), q, None, False, str(exc)))
    return out


def aero_load(fe, op: SteadyAeroOperator, q: float, aoa_rad: float, u: np.ndarray) -> np.ndarray:
    """The steady load at the state ``u`` as a dead load on the spline grids' DOFs (forces and
    moments of the undeformed boxes' pressures: their generalized force follows the rotations
    as :mod:`torchrom.fe.dead_load`'s)."""
    f_all = np.zeros(fe.n_all)
    f_all[op.dofs] = -q * (op.Q_ss @ (op.T_s @ u) + op.Q_sa * aoa_rad)
    return fe.generalized_load(u, f_all)


#: a speed whose Newton iteration fails is approached through this many halvings at most
MAX_HALVINGS = 8


def nonlinear_sweep(fe, op: SteadyAeroOperator, velocities, density: float, aoa_rad: float,
                    *, tol: float = 1e-7, max_iter: int = 30, progress=None
                    ) -> list[Equilibrium]:
    """Geometrically nonlinear equilibria f(u) = F(q, u), continued through ``velocities`` (in
    the order given) from the unloaded wing: modified Newton on (K_T(u) + q Tₛᵀ Q_ss Tₛ) with
    the tangent refactorised when the residual falls by less than half; a speed not reached in
    ``max_iter`` iterations is approached through the midpoint in dynamic pressure from the
    last one (up to :data:`MAX_HALVINGS` times), else reported as not converged and the sweep
    goes on from the last equilibrium. Converged when ‖f(u) − F‖ ≤ ``tol`` ‖F‖."""
    from ..fe.solvers import factor_symmetric

    u = np.zeros(fe.n_dof)
    q_last = 0.0
    out = []
    solver = None  # the last tangent's factorisation, reused from speed to speed
    for V in velocities:
        q_target = 0.5 * density * V**2
        targets, its_total, halvings, message = [q_target], 0, 0, ""
        while targets:
            q = targets[-1]
            ok, u_new, its, solver = _newton(fe, op, q, aoa_rad, u, tol, max_iter, solver,
                                             factor_symmetric)
            its_total += its
            if ok:
                u, q_last = u_new, targets.pop()
                continue
            halvings += 1
            solver = None
            if halvings > MAX_HALVINGS:
                message = (f"no equilibrium at q = {q:.6g} after {MAX_HALVINGS} halvings of the "
                           f"step from q = {q_last:.6g}")
                break
            targets.append(0.5 * (q_last + q))
        converged = not targets
        out.append(Equilibrium(float(V), q_target, u.copy() if converged else None, converged,
                               message, its_total))
        if progress is not None:
            progress(out[-1])
    return out


def _newton(fe, op, q, aoa_rad, u0, tol, max_iter, solver, factor_symmetric):
    u = u0.copy()
    prev = np.inf
    for it in range(1, max_iter + 1):
        F = aero_load(fe, op, q, aoa_rad, u)
        r = fe.internal_force(u) - F
        res = float(np.linalg.norm(r))
        if not np.isfinite(res):
            return False, u0, it, None
        if res <= tol * max(float(np.linalg.norm(F)), 1e-300):
            return True, u, it, solver
        if solver is None or res > 0.5 * prev:
            solver = LinearSolver(factor_symmetric(fe.tangent_stiffness(u)), op)
        prev = res
        try:
            u = u - solver.solve(q, r)
        except ConvergenceError:
            return False, u0, it, None
    return False, u0, max_iter, None
