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

import numpy as np

from ..identify.condensation import CondensedState, ExactCondensation, ModalLoadLaw
from .reduced import SteadyModalAero

__all__ = ["CondensedModel", "CondensedState", "deck_condensation", "steady_load_law"]


class CondensedModel(ExactCondensation):
    """The exact condensation (:class:`~torchrom.identify.condensation.ExactCondensation`) of
    ``backend`` on ``Phi`` with the ROM's linear stiffness ``K1``, in its steady aerodynamic
    equilibrium."""

    def equilibrium(self, aero: SteadyModalAero, dynamic_pressure: float, aoa_rad: float,
                    p0: np.ndarray, u0: np.ndarray | None = None, rtol: float = 1e-9,
                    max_iter: int = 12) -> CondensedState:
        """Newton on p from ``p0`` (e.g. the ROM's own equilibrium's p = q + A⁻¹ N(q)) until
        ‖R‖ ≤ ``rtol`` of the incidence load (ConvergenceError otherwise)."""
        return self.equilibrium_under(steady_load_law(aero, dynamic_pressure, aoa_rad,
                                                      len(self.A)), p0, u0, rtol, max_iter)


def steady_load_law(aero: SteadyModalAero, dynamic_pressure: float, aoa_rad: float, n: int,
                    condition: dict | None = None) -> ModalLoadLaw:
    """The steady aerodynamic load −q∞ (Q_α α + Q(0) q) on the first n coordinates as a
    :class:`~torchrom.identify.condensation.ModalLoadLaw`."""
    return ModalLoadLaw(-dynamic_pressure * aoa_rad * aero.incidence[:n],
                        dynamic_pressure * aero.Q0[:n, :n], dict(condition or {}))


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
