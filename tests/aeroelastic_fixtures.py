"""A small aeroelastic model with a known flutter point, for the assembly, sweep and paper tests.

Hodges & Pierce's typical section (a = −1/5, x_α = 1/10, r_α² = 6/25, σ = 2/5, μ = 20; flutter
at U/(b ω_α) = 2.18391 with Theodorsen's function) scaled in ft and slug to flutter near
10,000 ft at Mach 0.5, as the ROM's two "linear modes" (plunge h, pitch α), plus one stiff
"dual" coordinate u coupled quadratically to the plunge (strain energy ½ k_u (u + c h²)²) that
gets no aerodynamic force, and a cubic hardening of the pitch spring (k_α α³/α_ref²) with a
matching cubic Kelvin–Voigt damping (γ k_α α² α̇/α_ref²), so that post-flutter responses settle
into LCOs. Its aerodynamics are the exact Theodorsen GAFs and a 4-lag minimum-state
RFA (state-space flutter within 0.3 % in speed of the exact value, see tests/test_aero_flutter).
"""

from __future__ import annotations

import numpy as np

from torchrom.aero.atmosphere import flight_condition
from torchrom.aero.dlm import GAF
from torchrom.aero.files import AeroData
from torchrom.aero.rfa import fit_minimum_state
from torchrom.aero.theodorsen import TypicalSection
from torchrom.rom import NonlinearROM
from torchrom.sim.aeroelastic import mode_outputs
from torchrom.study.models import AeroelasticModel

HP = dict(a=-0.2, x_alpha=0.1, r_alpha_sq=6 / 25, sigma=0.4, mu=20.0)
MACH = 0.5
SEMICHORD = 3.0


def typical_section():
    rho10 = float(flight_condition(MACH, 10000.0).density)
    m = HP["mu"] * np.pi * rho10 * SEMICHORD**2
    w_a = float(flight_condition(MACH, 10000.0).velocity) / (2.18391 * SEMICHORD)
    return TypicalSection(SEMICHORD, HP["a"], HP["x_alpha"], HP["r_alpha_sq"], m,
                          HP["sigma"] * w_a, w_a)


def section_rom(alpha_ref: float = 0.1, dual_ratio: float = 30.0) -> NonlinearROM:
    """ROM [h, α, u] (see the module docstring); α_ref (rad) sets the pitch nonlinearity."""
    ts = typical_section()
    M2, K2 = ts.mass_matrix(), ts.stiffness_matrix()
    m_u = ts.mass
    k_u = m_u * (dual_ratio * ts.omega_alpha) ** 2
    M = np.zeros((3, 3))
    K1 = np.zeros((3, 3))
    M[:2, :2], K1[:2, :2] = M2, K2
    M[2, 2], K1[2, 2] = m_u, k_u
    # strain e = u + c h², energy ½ k_u e²: f_u = k_u (u + c h²), f_h = 2 c k_u h (u + c h²)
    c = 1.0 / SEMICHORD
    Kq = np.zeros((3, 3, 3))
    Kq[2, 0, 0] = k_u * c          # f_u ∋ k_u c h²
    Kq[0, 0, 2] = Kq[0, 2, 0] = k_u * c  # f_h ∋ 2 k_u c h u (symmetric in the last two)
    Kc = np.zeros((3, 3, 3, 3))
    Kc[0, 0, 0, 0] = 2 * k_u * c * c  # f_h ∋ 2 k_u c² h³
    k3 = K2[1, 1] / alpha_ref**2
    Kc[1, 1, 1, 1] = k3               # pitch hardening k_α α³ / α_ref²
    D3 = np.zeros((3, 3, 3, 3))
    D3[1, 1, 1, 1] = k3               # d_α = γ k3 α² α̇
    return NonlinearROM(M, K1, Kq, Kc, D3=D3, mode_kinds=["linear", "linear", "dual"],
                        outputs={"A_Tz": [1.0, 0.0, 0.0], "A_Ty": [0.0, 0.0, 1.0]},
                        metadata={"span": 10.0})


def section_aero(rom: NonlinearROM, n_lags: int = 4) -> AeroData:
    ts = typical_section()
    k = np.r_[0.0, np.geomspace(0.005, 2.0, 40)]
    gaf = GAF(MACH, SEMICHORD, k, ts.gaf(k))
    rfa = fit_minimum_state(gaf, n_lags=n_lags)
    return AeroData(gaf, rfa, {"frequencies_hz": [float(f) for f in rom.frequencies_hz[:2]],
                               "mode_outputs": mode_outputs(rom, 2)})


def section_model(**kw) -> AeroelasticModel:
    """The typical-section aeroelastic model, baseline damping α = 0.05 1/s, γ = 1e-4 s."""
    rom = section_rom()
    return AeroelasticModel(rom, section_aero(rom), baseline_alpha=0.05, baseline_gamma=1e-4,
                            **kw)
