"""Built-in analytic ROMs with known answers (hand-written): demos and independent tests.

- :func:`van_der_pol_duffing`: n generalized Van der Pol–Duffing oscillators
      q̈_m + (c1_m + d2_m q_m + d3_m q_m²) q̇_m + Σ_k K_mk q_k + k3_m q_m³ = 0     (γ = 1, α = 0)
  with M = I, K1 = diag(ω²) + coupling, D̄1 = diag(c1) (negative: self-excited), D̄2_mmm = d2,
  D̄3_mmmm = d3, K3_mmmm = k3. For one mode and c1 < 0 < d3 first-order averaging gives a stable
  LCO of amplitude 2√(−c1/d3) at ω (1 + 3 k3 A²/(8 ω²)) (REFERENCE Sec. 4). With the per-case
  parameters of Eq. 54 the coefficients become α + γ c1, γ d2, γ d3 and s·k3.
- :func:`quintic_damping_oscillator`: one oscillator whose damping c1 + d3 q² + κ d5 q⁴ is bounded
  at large amplitude by a quintic term, built from cubic ROM tensors through a fast slaved
  mode q2 ≈ −ε q1² (see the function). With c1 > 0 > d3 and d5 > 0 it has a subcritical Hopf
  bifurcation in the net linear damping: an unstable and a stable LCO, the roots A² = x of
  c1 + d3 x/4 + κ d5 x²/8 = 0 (first-order averaging), coexisting with the stable rest state.
- :func:`touze_two_mode`: the two-mode system of REFERENCE Sec. 5 (Touzé; NLvib example 06):
  strains e_k = q_k + (q1² + q2²)/2 with stiffness ω_k², so its quadratic/cubic stiffness is
  exact and a Kelvin–Voigt dashpot γ ω_k² on ė_k gives exact nonlinear damping tensors.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import torch

from ..checks import real_array
from ..errors import InputError
from .model import NonlinearROM


def _vector(x, n: int, name: str) -> np.ndarray:
    arr = real_array(name, x).reshape(-1)
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
    f = real_array("frequencies_hz", frequencies_hz).reshape(-1)
    n = f.size
    if n == 0 or not np.all(f > 0):
        raise InputError(f"frequencies_hz: expected positive frequencies, got {f.tolist()}")
    w2 = (2 * math.pi * f) ** 2
    c1, d2, d3, k3 = (_vector(x, n, name) for x, name in ((c1, "c1"), (d2, "d2"), (d3, "d3"),
                                                           (k3, "k3")))
    K1 = np.diag(w2)
    if coupling is not None:
        cpl = real_array("coupling", coupling)
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


def quintic_damping_oscillator(frequency_hz: float = 2.0, c1: float = 1.0, d3: float = -5.0,
                               d5: float = 2.0, slave_hz: float = 20.0,
                               slave_damping: float = 0.5,
                               slave_coupling: float = 0.05) -> NonlinearROM:
    """q̈1 + (c1 + d3 q1² + d5 q1⁴) q̇1 + ω² q1 = 0, realised with cubic ROM tensors (γ = 1).

    A ROM's forces are at most cubic, so the quintic damping goes through a second, fast mode
    driven by q1²: K2_211 = ε ω2² gives q̈2 + 2ζω2 q̇2 + ω2² (q2 + ε q1²) = 0, so q2 ≈ −ε q1²
    for ω2 ≫ 2ω, and D̄3_1221 = d5/ε² gives the force (d5/ε²) q2² q̇1 ≈ d5 q1⁴ q̇1 on mode 1 —
    the way membrane (dual) modes make a wing ROM's damping amplitude dependent. A small ε
    (``slave_coupling``) keeps the modified-Newton iteration contracting at large amplitudes;
    a well damped slave (ζ = 0.5) forgets within a few of its periods that a run starts off
    its slow manifold (q2 = 0 instead of −ε q1²). The slave follows q1² through
    H = 1/(1 − r² + 2iζr) = |H| e^{−iφ}, r = 2ω/ω2, which scales the averaged quintic
    coefficient by κ = 2 + |H|² − 2|H| cos φ (1.043 for the defaults; 1 for a quasi-static
    slave). Output "q1"; the slave is internal.
    This bounds large motions: the defaults (c1 = 1, d3 = −5, d5 = 2, i.e. c1 + d3 x/4 +
    d5 x²/8 ∝ (x − 1)(x − 4)) give an unstable LCO of amplitude 1 and a stable one of
    amplitude 2 beside the stable rest state — the bounded variant of the subcritical
    bifurcation test (a pure c1 > 0 > d3 oscillator has no stable large LCO and grows without
    bound).

    Args:
        frequency_hz: ω/2π of the oscillator; c1 (1/s), d3, d5: damping coefficients at γ = 1.
        slave_hz: ω2/2π of the slaved mode (≫ 2 frequency_hz); slave_damping: its ζ;
        slave_coupling: ε.
    """
    if not (frequency_hz > 0 and slave_hz > 2 * frequency_hz):
        raise InputError(f"slave_hz: expected a slaved mode much faster than 2 x "
                         f"frequency_hz = {2 * frequency_hz:g}, got {slave_hz:g}")
    if not slave_coupling > 0:
        raise InputError(f"slave_coupling: expected a positive number, got {slave_coupling}")
    w, w2, eps = 2 * math.pi * frequency_hz, 2 * math.pi * slave_hz, slave_coupling
    K2 = np.zeros((2, 2, 2))
    K2[1, 0, 0] = eps * w2**2
    D3 = np.zeros((2, 2, 2, 2))
    D3[0, 0, 0, 0] = d3
    D3[0, 1, 1, 0] = d5 / eps**2
    return NonlinearROM(
        np.eye(2), np.diag([w**2, w2**2]), K2, None, np.diag([c1, 2 * slave_damping * w2]),
        None, D3, mode_kinds=["linear", "dual"], outputs={"q1": np.array([1.0, 0.0])},
        metadata={"model": "quintic_damping_oscillator", "frequency_hz": frequency_hz,
                  "c1": c1, "d3": d3, "d5": d5, "slave_hz": slave_hz,
                  "slave_damping": slave_damping, "slave_coupling": slave_coupling})


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
BUILTIN = {"van_der_pol_duffing": van_der_pol_duffing, "touze_two_mode": touze_two_mode,
           "quintic_damping_oscillator": quintic_damping_oscillator}
