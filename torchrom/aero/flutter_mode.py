"""The flutter mode: the p-k eigenvector of the critical root at the flutter point.

At a flutter point (speed V, density ρ, from :func:`~torchrom.aero.flutter.flutter_altitude_pk`
or :func:`~torchrom.aero.flutter_speed.flutter_speed_pk_at_density`) the tracked root of branch
j is converged once more at exactly (V, ρ), starting from the sweep's sample of that branch
nearest in speed, and its displacement eigenvector v (modal coordinates of the aero modes) is
returned with the p-k equation's residual

    [M s² + (C + q (b/V) Q_I(k)/k) s + (K + q Q_R(k))] v = 0,   k = Im(s) b / V,  q = ½ ρ V²,

the same equation the sweep solves (Nastran's PK method). The vector is complex: its modulus is
each coordinate's share of the motion and its argument the phase lag between them.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConvergenceError, InputError
from .flutter import ModalStructure, ModeSweep, _pk_mode

#: relative change of k at which the p-k root counts as converged at the flutter point
PK_EPS = 1e-12


@dataclass
class FlutterMode:
    """The critical root and its eigenvector at a flutter point (module docstring).

    velocity (length/s), density (mass/length³), eigenvalue s (rad/s), frequency_hz = Im s / 2π,
    damping_g = 2 Re s / Im s, k = Im(s) b / V, vector (m,) complex modal coordinates
    (normalised: largest |v_i| = 1, real), mode: the 0-based p-k branch, residual: the relative
    residual of the p-k equation (module docstring) at (s, v)."""

    velocity: float
    density: float
    eigenvalue: complex
    k: float
    vector: np.ndarray
    mode: int
    residual: float

    @property
    def frequency_hz(self) -> float:
        return abs(self.eigenvalue.imag) / (2 * np.pi)

    @property
    def damping_g(self) -> float:
        return 2 * self.eigenvalue.real / abs(self.eigenvalue.imag)


def pk_matrices(structure: ModalStructure, aero, velocity: float, density: float, k: float
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(M, C_total, K_total) of the p-k equation at reduced frequency ``k`` (module docstring;
    below the table's lowest damping k, the quasi-steady rule of :func:`~.flutter._pk_mode`)."""
    b, q = aero.semichord, 0.5 * density * velocity**2
    if k < aero.k_damp:
        qk, qd, kd = aero(aero.k_min), aero(aero.k_damp), aero.k_damp
    else:
        qk = qd = aero(k)
        kd = k
    return structure.M, structure.C + q * (b / velocity) * qd.imag / kd, structure.K + q * qk.real


def pk_flutter_mode(structure: ModalStructure, aero, velocity: float, density: float,
                    sweep: ModeSweep, mode: int) -> FlutterMode:
    """The p-k root of branch ``mode`` (0-based) of ``sweep`` converged at (``velocity``,
    ``density``) with its eigenvector (module docstring); ConvergenceError when it does not
    converge."""
    if sweep.vectors is None:
        raise InputError("flutter mode: the sweep kept no eigenvectors (a p-k sweep keeps them)")
    if not 0 <= int(mode) < sweep.eigenvalues.shape[1]:
        raise InputError(f"flutter mode: branch {mode + 1} is not one of the sweep's "
                         f"{sweep.eigenvalues.shape[1]}")
    V = sweep.velocity_by_mode[:, mode]
    i = int(np.argmin(np.abs(V - velocity)))
    s, v, k, ok = _pk_mode(structure, aero, float(velocity), float(density),
                           sweep.eigenvalues[i, mode], sweep.vectors[i, :, mode], PK_EPS, 400)
    if not ok:
        raise ConvergenceError(f"flutter mode: p-k branch {mode + 1} did not converge at "
                               f"V = {velocity:.6g}, density {density:.6g}")
    v = np.asarray(v, dtype=complex)
    v = v / v[int(np.argmax(np.abs(v)))]
    M, C, K = pk_matrices(structure, aero, float(velocity), float(density), float(k))
    r = (M * s**2 + C * s + K) @ v
    scale = (np.abs(s) ** 2 * np.abs(M) + np.abs(s) * np.abs(C) + np.abs(K)) @ np.abs(v)
    return FlutterMode(float(velocity), float(density), complex(s), float(k), v, int(mode),
                       float(np.linalg.norm(r) / np.linalg.norm(scale)))
