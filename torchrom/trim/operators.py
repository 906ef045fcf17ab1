"""The steady aerodynamic load on an FE model: F(u) = −q∞ Tₛᵀ (Q_ss Tₛ u + Q_sα α).

The deck's splines (SPLINE1/2/4/5 on their SET1 grids) carry the boxes' k = 0 pressures to the
spline grids' six DOFs s; Q_ss is the steady generalized force of a unit displacement of each
DOF on each (the aerodynamic stiffness, not symmetric), Q_sα that of a unit root incidence
(:mod:`torchrom.aero.steady`). Tₛ = the rows of the FE model's constraint map T for those DOFs
(a spline grid may be an RBE3's dependent grid, as the Pazy wing's reference axis), so the
operator stays the low-rank product Tₛᵀ Q Tₛ and is never assembled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..aero.nastran_flutter import NASTRAN_KERNEL, FlutterDeck
from ..aero.steady import incidence_motion, stack_motions, steady_gaf
from ..errors import InputError


@dataclass
class SteadyAeroOperator:
    """Steady aerodynamics on the FE model's free DOFs (module docstring): ``grid_ids`` the
    spline grids, ``dofs`` (6 n_s,) their all-grid DOF indices and ``T_s`` (6 n_s, n_free) those
    DOFs from the free ones, ``Q_ss`` (6 n_s, 6 n_s) and ``Q_sa`` (6 n_s,) per unit dynamic
    pressure, ``mach`` and the box count."""

    grid_ids: np.ndarray
    dofs: np.ndarray
    T_s: sp.csr_matrix
    Q_ss: np.ndarray
    Q_sa: np.ndarray
    mach: float
    n_boxes: int

    def incidence_load(self, q: float, aoa_rad: float) -> np.ndarray:
        """Free-DOF load of the rigid incidence ``aoa_rad`` at dynamic pressure ``q``."""
        return -q * aoa_rad * (self.T_s.T @ self.Q_sa)

    def stiffness_load(self, q: float, u: np.ndarray) -> np.ndarray:
        """Free-DOF load of the deflection ``u`` (the aerodynamic stiffness) at ``q``."""
        return -q * (self.T_s.T @ (self.Q_ss @ (self.T_s @ u)))

    def load(self, q: float, aoa_rad: float, u: np.ndarray) -> np.ndarray:
        return self.incidence_load(q, aoa_rad) + self.stiffness_load(q, u)


def spline_grids(deck: FlutterDeck) -> np.ndarray:
    """The structural grids of the deck's splines, in first-use order."""
    seen: dict[int, None] = {}
    for sp_def in deck.splines:
        for g in sp_def.grid_ids:
            seen.setdefault(int(g), None)
    return np.array(list(seen), dtype=int)


def unit_spline_motion(deck: FlutterDeck, grids: np.ndarray):
    """The box motion of a unit displacement of each of the ``grids``' six DOFs (6 n rows,
    grid by grid, T1 … R3 in basic)."""
    n = 6 * len(grids)
    unit = np.zeros((n, len(grids), 6))
    unit[np.arange(n), np.repeat(np.arange(len(grids)), 6), np.tile(np.arange(6), len(grids))] \
        = 1.0
    return deck.box_motion(grids, unit)


def steady_operator(fe, deck: FlutterDeck, mach: float = 0.0,
                    kernel: str = NASTRAN_KERNEL) -> SteadyAeroOperator:
    """The :class:`SteadyAeroOperator` of FE model ``fe`` with ``deck``'s panels and splines at
    ``mach`` (a unit displacement of each spline-grid DOF, and a unit incidence, through
    :func:`~torchrom.aero.steady.steady_gaf`)."""
    grids = spline_grids(deck)
    if not len(grids):
        raise InputError(f"{deck.path}: steady aerodynamics: no SPLINE connects the boxes to "
                         "the structure")
    rows = fe.mesh.grid_row()
    missing = [int(g) for g in grids if int(g) not in rows]
    if missing:
        raise InputError(f"{deck.path}: steady aerodynamics: spline grid {missing[0]} is not a "
                         "grid of the structural model")
    n = 6 * len(grids)
    panels = deck.aero_panels
    motion = stack_motions(unit_spline_motion(deck, grids), incidence_motion(panels))
    Q = steady_gaf(panels, motion, mach, deck.reference.semichord, kernel)
    dofs = np.array([rows[int(g)] * 6 + c for g in grids for c in range(6)])
    return SteadyAeroOperator(grids, dofs, sp.csr_matrix(fe.T)[dofs], Q[:n, :n], Q[:n, n],
                              float(mach), int(panels.n))
