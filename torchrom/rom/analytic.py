"""Built-in analytic ROMs with known answers (hand-written): demos and independent tests.

- :func:`van_der_pol_duffing`: n generalized Van der Pol–Duffing oscillators
      q̈_m + (c1_m + d2_m q_m + d3_m q_m²) q̇_m + Σ_k K_mk q_k + k3_m q_m³ = 0     (γ = 1, α = 0)
  with M = I, K1 = diag(ω²) + coupling, D̄1 = diag(c1) (negative: self-excited), D̄2_mmm = d2,
  D̄3_mmmm = d3, K3_mmmm = k3. For one mode and c1 < 0 < d3 first-order averaging gives a stable
  LCO of amplitude 2√(−c1/d3) at ω (1 + 3 k3 A²/(8 ω²)) (REFERENCE Sec. 4). With the per-case
  parameters of Eq. 54 the coefficients become α + γ c1, γ d2, γ d3 and s·k3.
- :func:`touze_two_mode`: the two-mode system of REFERENCE Sec. 5 (Touzé; NLvib example 06):
  strains e_k = q_k + (q1² + q2²)/2 with stiffness ω_k², so its quadratic/cubic stiffness is
  exact and a Kelvin–Voigt dashpot γ ω_k² on ė_k gives exact nonlinear damping tensors.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import torch

from ..errors import InputError
from .model import NonlinearROM


def _vector(x, n: int, name: str) -> np.ndarray:
    arr = np.asarray(x, dtype=float).reshape(-1)
    if arr.size == 1:
        arr = np.full(n, float(arr[0]))
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise InputError(f"{name}: expected {n} finite values (one per mode) or one value, got "
                         f"{np.asarray(x).tolist()}")
    return arr


def van_der_pol_duffing(frequencies_hz: Sequence[float] | float = 1.0, c1=0.0, d2=0.0, d3=1.0,
                        k3=0.0, coupling=None,
                        outputs: Mapping[str, Sequence[float]] | None = None) -> NonlinearROM:
    """n generalized Van der Pol–Duffing modes (see the module docstring).

    Args:
        frequencies_hz: linear natural frequency of each mode (Hz) before coupling.
        c1: linear damping of each mode at γ = 1 (1/s); negative values feed energy in.
        d2, d3: quadratic / cubic damping coefficients at γ = 1 (per unit of q, q²).
        k3: cubic stiffness of each mode (1/s² per unit of q²).
        coupling: symmetric (n, n) linear stiffness coupling added to diag(ω²), or None.
        outputs: output rows; default {"sum": all ones} (the sum of the coordinates).
    """
    f = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    n = f.size
    if n == 0 or not np.all(f > 0):
        raise InputError(f"frequencies_hz: expected positive frequencies, got {f.tolist()}")
    w2 = (2 * math.pi * f) ** 2
    c1, d2, d3, k3 = (_vector(x, n, name) for x, name in ((c1, "c1"), (d2, "d2"), (d3, "d3"),
                                                           (k3, "k3")))
    K1 = np.diag(w2)
    if coupling is not None:
        cpl = np.asarray(coupling, dtype=float)
        if cpl.shape != (n, n) or not np.allclose(cpl, cpl.T):
            raise InputError(f"coupling: expected a symmetric ({n}, {n}) matrix, got shape "
                             f"{cpl.shape}")
        K1 = K1 + cpl
    i = np.arange(n)
    D2 = np.zeros((n, n, n))
    D2[i, i, i] = d2
    D3 = np.zeros((n, n, n, n))
    D3[i, i, i, i] = d3
    K3 = np.zeros((n, n, n, n))
    K3[i, i, i, i] = k3
    return NonlinearROM(
        np.eye(n), K1, None, K3, np.diag(c1), D2, D3,
        mode_kinds=["linear"] * n,
        outputs=dict(outputs) if outputs is not None else {"sum": np.ones(n)},
        metadata={"model": "van_der_pol_duffing", "frequencies_hz": f.tolist(),
                  "c1": c1.tolist(), "d2": d2.tolist(), "d3": d3.tolist(), "k3": k3.tolist()},
    )


def touze_two_mode(w1: float = 1.13, w2: float = 2.0) -> NonlinearROM:
    """REFERENCE Sec. 5: M = I, strains e_k = q_k + r/2 (r = q1² + q2²), stiffness ω_k².

    The ROM stores γ = 1 tensors: with per-case γ = η the damping force is the Kelvin–Voigt dashpot
    η ω_k² on ė_k, dissipating η Σ_k ω_k² ė_k².
    """
    C = torch.diag(torch.tensor([w1**2, w2**2], dtype=torch.float64))
    e = torch.eye(2, dtype=torch.float64)
    h = torch.zeros(2, 2, 2, dtype=torch.float64)
    h[:, 0, 0] = 0.5
    h[:, 1, 1] = 0.5
    K1 = e.T @ C @ e
    G = torch.einsum("am,ab,bnl->mnl", e, C, h)
    H = torch.einsum("ams,ab,bnl->msnl", h, C, h)
    return NonlinearROM.from_gram(torch.eye(2, dtype=torch.float64), K1, G, H,
                                  metadata={"model": "touze_two_mode", "w1": w1, "w2": w2})


#: built-in models by name (the ``builtin`` key of a sweep configuration)
BUILTIN = {"van_der_pol_duffing": van_der_pol_duffing, "touze_two_mode": touze_two_mode}
