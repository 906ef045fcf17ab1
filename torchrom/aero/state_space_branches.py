"""The state-space roots along a flight path followed as branches, one per structural mode.

:func:`torchrom.aero.flutter.state_space_sweep` keeps every root of the state matrix
(paper Eqs. 49-50) in the eigensolver's order, which is arbitrary and changes between BLAS
kernels. A V-g table (an F06 FLUTTER SUMMARY, :mod:`torchrom.aero.f06_summary`) needs one row
per mode and flight condition, so the roots are ordered by physics here, as the p-k method
orders its own (:func:`torchrom.aero.flutter._pk_mode`):

* at the first condition, branch j starts from in-vacuo mode j (ascending frequency,
  :func:`torchrom.aero.flutter.in_vacuo_modes`);
* at each next condition, each branch takes the root of the upper half plane (Im s >= 0,
  real roots included) that continues it best: score = MAC(q, q_prev) - ½ |s - s_prev| / |s_prev|
  (q: the root's structural part of the state vector x = [q, q̇, ξ]), the branches assigned
  together (Hungarian assignment, so that no two take one root).

The RFA's lag roots (real, Re s ~ -V/b γ_i) are rarely taken: their q part is small and their
distance large. Branches are followed between the given conditions only: on a coarse path two
close roots may trade branches, as Nastran's summaries can.
"""

from __future__ import annotations

import numpy as np
import scipy.optimize

from .flutter import ModalStructure, ModeSweep, in_vacuo_modes, pk_damping, state_space_matrix
from .rfa import RFA

#: weight of the eigenvalue distance in the branch score (that of the p-k root choice)
DISTANCE_WEIGHT = 0.5


def _macs(candidates: np.ndarray, previous: np.ndarray) -> np.ndarray:
    """MAC of each previous shape (columns of ``previous``, m × n_b) with each candidate
    (columns of ``candidates``, m × n_c): n_b × n_c."""
    num = np.abs(previous.conj().T @ candidates) ** 2
    den = np.outer(np.einsum("ij,ij->j", previous.conj(), previous).real,
                   np.einsum("ij,ij->j", candidates.conj(), candidates).real)
    return np.divide(num, den, out=np.zeros_like(num), where=den > 0)


def state_space_branches(structure: ModalStructure, rfa: RFA, velocities, densities,
                         altitudes=None, mach: float | None = None) -> ModeSweep:
    """The state-space roots at each (V, ρ) of a path, one branch per structural mode
    (module docstring): a :class:`~torchrom.aero.flutter.ModeSweep` with method
    "state-space", eigenvalues s (n_points × m, 1/s), damping g = 2 Re s / |Im s| (Nastran's
    finite value for a real root, :func:`~torchrom.aero.flutter.pk_damping`), reduced
    frequency k = |Im s| b / V and the structural shapes q (n_points × m × m)."""
    V = np.asarray(velocities, dtype=float).reshape(-1)
    rho = np.broadcast_to(np.asarray(densities, dtype=float), V.shape)
    m, b = structure.n_modes, rfa.semichord
    f0, phi = in_vacuo_modes(structure)
    s_prev = 2j * np.pi * f0
    q_prev = phi.astype(complex)
    eig = np.empty((len(V), m), complex)
    vecs = np.empty((len(V), m, m), complex)
    for i, (v, r) in enumerate(zip(V, rho)):
        s, x = np.linalg.eig(state_space_matrix(structure, rfa, v, r))
        upper = np.flatnonzero(s.imag >= -1e-12 * np.abs(s).max())
        s, q = s[upper], x[:m, upper]
        scale = np.maximum(np.abs(s_prev), 1e-6 * max(np.abs(s).max(), 1e-12))
        score = (_macs(q, q_prev)
                 - DISTANCE_WEIGHT * np.abs(s[None, :] - s_prev[:, None]) / scale[:, None])
        rows, cols = scipy.optimize.linear_sum_assignment(-score)
        order = cols[np.argsort(rows)]
        eig[i], vecs[i] = s[order], q[:, order]
        s_prev, q_prev = eig[i], vecs[i]
    eig = np.where(np.abs(eig.imag) <= 1e-12 * np.abs(eig), eig.real + 0j, eig)
    with np.errstate(divide="ignore", invalid="ignore"):
        k = np.abs(eig.imag) * b / V[:, None]
    g = pk_damping(eig, V, b, "nastran")
    return ModeSweep("state-space", V, np.asarray(rho, float), eig, k, g,
                     None if altitudes is None else np.asarray(altitudes, float), mach, b,
                     vecs)
