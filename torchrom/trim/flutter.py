"""Flutter about a deformed state with the full FE model's tangent ("SOL 400, then SOL 145 on
its modes"): at each speed the equilibrium u(V) (:mod:`.equilibrium`), the modes of K_T(u)
(:mod:`.modes`), and the p-k roots at that speed with the DLM on the undeformed boxes.

Written here: the GAFs are computed once, on the spline grids' DOFs (Q_ss(k), a unit
displacement of each), so that the GAFs of any modes are the projection Φₛᵀ Q_ss(k) Φₛ with
Φₛ = Tₛ Φ (exact: the box motion is linear in the spline DOFs); the p-k solution itself is
:func:`torchrom.aero.flutter.pk_sweep` at one flight condition. A boundary is a speed where
the largest damping of the oscillatory roots changes sign between two solved speeds (linear
interpolation) for a root followed by frequency, labelled onset (− to +) or offset (+ to −).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..aero.dlm import GAF, compute_gaf
from ..aero.flutter import AeroTable, ModalStructure, pk_sweep
from ..aero.nastran_flutter import NASTRAN_KERNEL, FlutterDeck
from .modes import tangent_modes
from .operators import SteadyAeroOperator, unit_spline_motion

#: reduced frequencies (k = ω b / V) when the deck has no MKAERO card
DEFAULT_K = (0.0, 0.001, 0.005, 0.01, 0.02, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5,
             2.0)


@dataclass
class SplineGAF:
    """Q_ss(k) (nk, n_s, n_s) of the spline DOFs (:class:`.operators.SteadyAeroOperator`'s
    order) at reduced frequencies ``k`` (ω b / V, b = ``semichord``) and ``mach``."""

    k: np.ndarray
    Q: np.ndarray
    semichord: float
    mach: float

    def modal_table(self, T_s, shapes: np.ndarray) -> AeroTable:
        """The GAF table of ``shapes`` (n_free, m)."""
        phi = np.asarray(T_s @ shapes)
        Q = np.einsum("ai,kab,bj->kij", phi, self.Q, phi)
        return AeroTable.from_gaf(GAF(self.mach, self.semichord, self.k, Q))


def spline_gaf(deck: FlutterDeck, op: SteadyAeroOperator, k_list=None,
               kernel: str = NASTRAN_KERNEL) -> SplineGAF:
    """The GAFs of the spline DOFs of ``op`` at ``k_list`` (default: the deck's MKAERO values at
    the nearest Mach number, else :data:`DEFAULT_K`; k = 0 always)."""
    if k_list is None:
        if deck.mkaero:
            near = min({m for m, _ in deck.mkaero}, key=lambda m: abs(m - op.mach))
            k_list = [k for m, k in deck.mkaero if m == near]
        else:
            k_list = DEFAULT_K
    k = np.array(sorted({0.0, *(float(x) for x in k_list)}))
    motion = unit_spline_motion(deck, op.grid_ids)
    gaf = compute_gaf(deck.aero_panels, motion, op.mach, k, deck.reference.semichord, kernel)
    return SplineGAF(gaf.k, gaf.Q, deck.reference.semichord, op.mach)


@dataclass
class StabilityPoint:
    """The p-k roots at one equilibrium: ``velocity``, ``damping`` g and ``frequency_hz`` (m,)
    of the tangent modes' roots, the modes' ``natural_hz``, and the largest damping of the
    oscillatory roots ``critical`` with its frequency."""

    velocity: float
    damping: np.ndarray
    frequency_hz: np.ndarray
    natural_hz: np.ndarray

    @property
    def oscillatory(self) -> np.ndarray:
        return self.frequency_hz > 1e-6

    @property
    def critical(self) -> tuple[float, float]:
        g = np.where(self.oscillatory, self.damping, -np.inf)
        j = int(np.argmax(g))
        return float(g[j]), float(self.frequency_hz[j])


def stability_at(fe, op: SteadyAeroOperator, gaf: SplineGAF, u: np.ndarray, velocity: float,
                 density: float, n_modes: int) -> StabilityPoint:
    """The p-k roots at ``velocity`` of the ``n_modes`` lowest modes of K_T(u) (u = 0: the
    undeformed wing's), without structural damping."""
    modes = tangent_modes(fe, u, n_modes)
    omega = 2 * np.pi * modes.frequencies_hz
    structure = ModalStructure(np.eye(len(omega)), np.diag(omega**2))
    sweep = pk_sweep(structure, gaf.modal_table(op.T_s, modes.shapes), [velocity], density,
                     mach=gaf.mach, eps=1e-5)
    return StabilityPoint(float(velocity), np.asarray(sweep.damping[0]),
                          np.asarray(sweep.frequency_hz[0]), modes.frequencies_hz)


@dataclass
class Boundary:
    """A sign change of the critical damping between two solved speeds: ``kind`` "onset" or
    "offset", ``velocity`` and ``frequency_hz`` interpolated, ``index`` of the speed before."""

    kind: str
    velocity: float
    frequency_hz: float
    index: int


#: a damping within this of zero is neutral, not a crossing (an aerodynamically unloaded mode's
#: g wanders within ~1e-7 of zero)
NEUTRAL_DAMPING = 1e-4


def _tracked(prev: StabilityPoint, cur: StabilityPoint) -> np.ndarray:
    """For each root of ``prev`` its continuation in ``cur``: a one-to-one pairing by nearest
    frequency (the two speeds' modal bases differ, so indices do not carry over; the state
    space's count of oscillatory roots may change between speeds)."""
    from scipy.optimize import linear_sum_assignment

    cost = np.abs(prev.frequency_hz[:, None] - cur.frequency_hz[None, :])
    rows, cols = linear_sum_assignment(cost)
    out = np.full(len(prev.frequency_hz), -1)  # -1: a root with no partner (it turned real)
    out[rows] = cols
    return out


def boundaries(points: list[StabilityPoint], tol: float = NEUTRAL_DAMPING) -> list[Boundary]:
    """Onsets and offsets along ``points`` (ascending speeds): an oscillatory root, followed
    from one speed to the next by frequency, whose damping changes sign from − to + (onset) or
    back (offset), one of the two beyond ``tol`` (a root within ±``tol`` at both speeds is
    neutral, not crossing); speed and frequency interpolated linearly."""
    out = []
    for i in range(len(points) - 1):
        a, b = points[i], points[i + 1]
        for j, jj in enumerate(_tracked(a, b)):
            if jj < 0:
                continue
            g0, g1 = a.damping[j], b.damping[jj]
            f0, f1 = a.frequency_hz[j], b.frequency_hz[jj]
            if min(f0, f1) <= 1e-6 or not np.isfinite(g0 + g1):
                continue
            if max(abs(g0), abs(g1)) <= tol or g0 * g1 > 0 or g0 == g1:
                continue  # no sign change, or a neutral root's rounding
            kind = "onset" if g1 > g0 else "offset"
            t = -g0 / (g1 - g0)
            out.append(Boundary(kind, float(a.velocity + t * (b.velocity - a.velocity)),
                                float(f0 + t * (f1 - f0)), i))
    return sorted(out, key=lambda x: x.velocity)
