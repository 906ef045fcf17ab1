"""The FE's own answer for a condensed ROM about a deformed state: its static aeroelastic
equilibrium and tangent by *exact* implicit condensation at that state, the check on the
ROM's fitted cubic terms (:mod:`torchrom.identify.condensation`, :mod:`.reduced`).

The structure the condensation solves (the wing, or its skeleton when a foil skin is kept
linear) carries the load K Φ p; its solution u(p) has the coordinates q = A⁻¹ Φᵀ K u with
A = Φᵀ K Φ. The ROM's structural force at q is then exactly D q + A p(q), D = K1 − A the
part of the ROM's linear stiffness the solved structure lacks (the skin's; zero without one),
and the steady aeroelastic equilibrium on the ROM's coordinates is

    R(p) = D q(p) + A p + q∞ Q(0) q(p) + q∞ Q_α α = 0,

solved by Newton on p (each step one nonlinear FE solve, continued from the last), with
dq/dp = A⁻¹ S, S = (KΦ)ᵀ K_T(u)⁻¹ (KΦ). The condensed tangent stiffness there is

    K_c = D + A S⁻¹ A,

the FE's tangent with every DOF but the ROM's coordinates relaxed statically. Written here:
no library condenses an FE tangent onto a ROM basis.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError
from .reduced import SteadyModalAero


@dataclass
class CondensedState:
    """One condensed equilibrium: ``q`` the ROM coordinates, ``p`` the solved structure's modal
    load, ``u`` its displacements, ``S`` = (KΦ)ᵀ K_T⁻¹ (KΦ), ``iterations`` (FE solves)."""

    q: np.ndarray
    p: np.ndarray
    u: np.ndarray
    S: np.ndarray
    iterations: int


class CondensedModel:
    """The exact condensation of ``backend`` (an :class:`~torchrom.identify.FEBackend` that
    solves statics) on ``Phi`` (its DOFs × n), with the ROM's linear stiffness ``K1`` (n, n)."""

    def __init__(self, backend, Phi: np.ndarray, K1: np.ndarray):
        from ..identify.backend import project

        self.backend, self.Phi = backend, np.asarray(Phi)
        K = backend.stiffness_matrix()
        self.KPhi = np.asarray(K @ self.Phi)
        self.A = project(K, self.Phi)
        self.D = np.asarray(K1, dtype=float) - self.A

    def solve(self, p: np.ndarray, u0: np.ndarray | None) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
        """(u, q, S) of the load K Φ p."""
        from ..identify.condensation import tangent_gram

        u = self.backend.static_solve(self.KPhi @ p, u0=u0).u
        q = np.linalg.solve(self.A, self.KPhi.T @ u)
        return u, q, tangent_gram(self.backend, u, self.KPhi)

    def equilibrium(self, aero: SteadyModalAero, dynamic_pressure: float, aoa_rad: float,
                    p0: np.ndarray, u0: np.ndarray | None = None, rtol: float = 1e-9,
                    max_iter: int = 12) -> CondensedState:
        """Newton on p from ``p0`` (e.g. the ROM's own equilibrium's p = q + A⁻¹ N(q)) until
        ‖R‖ ≤ ``rtol`` of the incidence load (ConvergenceError otherwise)."""
        n = len(self.A)
        Q0, inc = aero.Q0[:n, :n], aero.incidence[:n]
        load = dynamic_pressure * aoa_rad * inc
        scale = max(np.linalg.norm(load), np.finfo(float).tiny)
        p, u = np.asarray(p0, dtype=float).copy(), u0
        for it in range(1, max_iter + 1):
            u, q, S = self.solve(p, u)
            R = (self.D + dynamic_pressure * Q0) @ q + self.A @ p + load
            if np.linalg.norm(R) <= rtol * scale:
                return CondensedState(q, p, u, S, it)
            J = (self.D + dynamic_pressure * Q0) @ np.linalg.solve(self.A, S) + self.A
            p = p - np.linalg.solve(J, R)
        raise ConvergenceError(f"condensed equilibrium: not converged in {max_iter} FE solves "
                               f"(residual {np.linalg.norm(R) / scale:.1e} of the load)")

    def tangent(self, state: CondensedState) -> np.ndarray:
        """K_c = D + A S⁻¹ A at ``state`` (module docstring)."""
        Kc = self.D + self.A @ np.linalg.solve(state.S, self.A)
        return 0.5 * (Kc + Kc.T)


def deck_condensation(fe, Phi: np.ndarray, K1: np.ndarray, linear_skin=()) -> CondensedModel:
    """The exact condensation of FE model ``fe`` on its modes ``Phi`` (free DOFs × n) with the
    ROM's linear stiffness ``K1``: solved on the model itself, or with ``linear_skin`` (PSHELL
    IDs) on the model without those shells, the skin's linear stiffness D = K1 − ΦᵀK_sΦ kept
    on the coordinates (as ``torchrom identify --linear-skin`` builds its ROM)."""
    from ..fe.bdf_read import from_pynastran
    from ..identify.build import as_backend
    from ..identify.condensation import skeleton_of

    if not linear_skin:
        return CondensedModel(as_backend(fe), Phi, K1)
    skel = from_pynastran(fe.bdf, source=fe.source, name=fe.name,
                          without_properties=list(linear_skin))
    backend = as_backend(skel)
    rows = skeleton_of(fe, skel, backend, "skeleton").rows
    return CondensedModel(backend, np.asarray(Phi)[rows], K1)
