"""Aeroelastic assembly: a structural ROM + an RFA + per-case flight conditions -> CaseSystem.

The aerodynamic forces of the paper's Eqs. 49–50 on the first m linear modes,

    F_aero = −q∞ (b²/V²) A2 q̈ − q∞ (b/V) A1 q̇ − q∞ A0 q − q∞ D ξ,    ξ̇ = E q̇ + (V/b) R ξ,

(b = the RFA's reference semichord, V = M a(h), q∞ = ½ ρ(h) V², USSA-76 at geometric altitude
through :mod:`torchrom.aero.atmosphere`) become the per-case linear additions of
:class:`~torchrom.sim.CaseSystem`:

    M_add = q∞ b²/V² A2,  C_add = q∞ b/V A1,  K_add = q∞ A0,  lag_D = q∞ D,  lag_E = E,
    lag_R = (V/b) R,

zero-padded from the m aerodynamic modes to the n basis functions (dual modes carry no
aerodynamic force, DESIGN "Conventions"). Together with α, γ and the nonlinearity switches
(Eq. 54) this is the whole post-flutter model of paper Sec. IV.

The GAFs must have been computed on exactly the ROM's first m basis functions (same shapes, signs
and mass normalisation): :func:`check_aero_matches_rom` compares the linear frequencies and,
when the aero file records them (``metadata["mode_outputs"]``, written by
:func:`mode_outputs`), the modal values at the ROM's output points, which catch a flipped or
rescaled mode. The linear part of the assembled system can be written as a first-order matrix
(:func:`linear_state_matrix`) and integrated from its critical eigenvector
(:func:`critical_mode_state`) to measure the simulator's own growth rate
(:func:`growth_rate`), the check that the batched simulator reproduces the flutter analysis.

Written here (numpy/torch); the atmosphere is ``ambiance``'s through torchrom.aero.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ..aero.atmosphere import flight_condition
from ..errors import InputError
from ..rom import NonlinearROM
from ..rom.reference import reference_load
from .system import CaseSystem

#: relative tolerance of the ROM/aero frequency and mode-value consistency checks
CONSISTENCY_RTOL = 1e-6


# -- consistency of the aerodynamic modes with the ROM basis ------------------------------------
def mode_outputs(rom: NonlinearROM, m: int) -> dict[str, list[float]]:
    """The values of the first ``m`` basis functions at the ROM's output points (name -> m
    numbers): a fingerprint of the modes' shapes, signs and normalisation, to be stored in the
    aero file's metadata when the GAFs are computed on the ROM's basis."""
    return {name: [float(v) for v in np.asarray(row)[:m]] for name, row in rom.outputs.items()}


def check_aero_matches_rom(rom: NonlinearROM, aero, rtol: float = CONSISTENCY_RTOL) -> None:
    """InputError unless the aero data's m modes are the ROM's first m basis functions.

    Checked: m ≤ n; the first m basis functions are linear modes (when the ROM knows its mode
    kinds); the linear frequencies agree (when both record them); the modal values at the
    output points agree (when the aero metadata records ``mode_outputs``), which detects a mode
    of opposite sign or another normalisation.
    """
    m = int(aero.n_modes)
    if m > rom.n:
        raise InputError(f"aeroelastic: the aero data has {m} modes, the ROM only {rom.n} "
                         f"basis functions")
    kinds = list(getattr(rom, "mode_kinds", None) or [])
    if kinds and any(k != "linear" for k in kinds[:m]):
        raise InputError(f"aeroelastic: the ROM's first {m} basis functions must be linear modes "
                         f"(the aerodynamic modes), got kinds {kinds[:m]}")
    f_aero = np.asarray(aero.metadata.get("frequencies_hz", []), dtype=float)[:m]
    f_rom = np.asarray(rom.frequencies_hz, dtype=float)[:m]
    if len(f_aero) == m and len(f_rom) == m and np.all(np.isfinite(f_rom)):
        bad = np.flatnonzero(np.abs(f_aero - f_rom) > rtol * np.abs(f_rom).max())
        if len(bad):
            j = int(bad[0])
            raise InputError(f"aeroelastic: mode {j + 1}: the aero data was computed on a mode "
                             f"of {f_aero[j]:.6g} Hz, the ROM's basis function {j + 1} has "
                             f"{f_rom[j]:.6g} Hz (GAFs must be built on the ROM's modes)")
    recorded = aero.metadata.get("mode_outputs") or {}
    for name, values in recorded.items():
        if name not in rom.outputs:
            continue
        a = np.asarray(values, dtype=float)[:m]
        r = np.asarray(rom.outputs[name], dtype=float)[:m]
        scale = max(np.abs(r).max(), np.abs(a).max(), np.finfo(float).tiny)
        bad = np.flatnonzero(np.abs(a - r) > rtol * scale + 1e-12 * scale)
        if len(bad):
            j = int(bad[0])
            raise InputError(f"aeroelastic: mode {j + 1}: output {name} is {a[j]:.6g} in the "
                             f"aero data's mode and {r[j]:.6g} in the ROM's basis function "
                             f"(a flipped or rescaled mode: build the GAFs on the ROM's basis)")


# -- assembly -------------------------------------------------------------------------------------
def aero_additions(aero, velocity, dynamic_pressure, n: int) -> dict[str, np.ndarray]:
    """Per-case aerodynamic additions (Eqs. 49–50) zero-padded to n: dict of float64 arrays
    M_add, C_add, K_add (B, n, n), lag_D (B, n, na), lag_E (B, na, n), lag_R (B, na, na)."""
    rfa = aero.rfa
    m, na, b = rfa.n_modes, rfa.n_states, float(rfa.semichord)
    V = np.asarray(velocity, dtype=float).reshape(-1)
    q = np.asarray(dynamic_pressure, dtype=float).reshape(-1)
    B = len(V)
    if q.shape != (B,):
        raise InputError(f"aeroelastic: {B} velocities but {q.size} dynamic pressures")
    if np.any(~np.isfinite(V)) or np.any(V <= 0) or np.any(~np.isfinite(q)) or np.any(q < 0):
        raise InputError("aeroelastic: velocities must be positive and dynamic pressures "
                         "non-negative and finite")
    out = {"M_add": np.zeros((B, n, n)), "C_add": np.zeros((B, n, n)),
           "K_add": np.zeros((B, n, n)), "lag_D": np.zeros((B, n, na)),
           "lag_E": np.zeros((B, na, n))}
    out["M_add"][:, :m, :m] = (q * (b / V) ** 2)[:, None, None] * rfa.A2
    out["C_add"][:, :m, :m] = (q * b / V)[:, None, None] * rfa.A1
    out["K_add"][:, :m, :m] = q[:, None, None] * rfa.A0
    out["lag_D"][:, :m, :] = q[:, None, None] * rfa.D
    out["lag_E"][:, :, :m] = rfa.E
    out["lag_R"] = (V / b)[:, None, None] * np.asarray(rfa.R, dtype=float)
    return out


def rfa_steady_stiffness(aero, n: int) -> np.ndarray:
    """The RFA's A0 (n, n) zero-padded: the steady stiffness per unit dynamic pressure that the
    cases' K_add carries (at rest the lag states vanish)."""
    out = np.zeros((n, n))
    m = aero.rfa.n_modes
    out[:m, :m] = aero.rfa.A0
    return out


@dataclass
class AeroelasticCases:
    """The assembled cases and their flight conditions (arrays (B,), consistent units: ft, slug,
    s for Goland): altitude (in the unit it was given in), mach, velocity V = M a(h), density
    ρ(h), dynamic pressure ½ρV²."""

    system: CaseSystem
    altitude: np.ndarray
    mach: np.ndarray
    velocity: np.ndarray
    density: np.ndarray
    dynamic_pressure: np.ndarray

    def conditions(self) -> list[dict[str, float]]:
        """Per-case flight-condition columns of the results table."""
        return [{"mach": float(self.mach[i]), "velocity": float(self.velocity[i]),
                 "dynamic_pressure": float(self.dynamic_pressure[i]),
                 "density": float(self.density[i])} for i in range(len(self.altitude))]


def aeroelastic_system(rom: NonlinearROM, aero, altitude, *, alpha=0.0, gamma=0.0,
                       stiffness_nl=1.0, damping_nl=1.0, mach=None, units: str = "ft",
                       device=None, dtype=torch.float64, check: bool = True,
                       altitude_unit: str | None = None) -> AeroelasticCases:
    """B aeroelastic cases of ``rom`` with the RFA of ``aero`` (paper Eqs. 49–50, 54).

    Args:
        altitude: (B,) or scalar geometric altitudes, in ``altitude_unit`` ("m" or "ft";
            default the altitude unit of the system ``units``: ft for "ft").
        alpha, gamma: mass-proportional (1/s) and Kelvin–Voigt (s) damping, scalars or (B,).
        stiffness_nl, damping_nl: nonlinearity switches (bools or scales), scalars or (B,).
        mach: None (the GAF Mach) or a Mach number equal to it: the RFA holds at one Mach only.
        check: verify that the aero modes are the ROM's first basis functions
            (:func:`check_aero_matches_rom`).
    """
    if check:
        check_aero_matches_rom(rom, aero)
    if mach is not None and abs(float(mach) - aero.mach) > 1e-9:
        raise InputError(f"aeroelastic: mach {float(mach):g} differs from the Mach number "
                         f"{aero.mach:g} of the aerodynamic data (the RFA holds at one Mach)")
    alt = np.atleast_1d(np.asarray(altitude, dtype=float))
    if alt.ndim != 1 or not np.all(np.isfinite(alt)):
        raise InputError(f"aeroelastic: altitude: expected finite numbers, got {altitude!r}")
    fc = flight_condition(aero.mach, alt, units, altitude_unit)
    return aeroelastic_system_at(rom, aero, fc.velocity, fc.density, altitude=alt, alpha=alpha,
                                 gamma=gamma, stiffness_nl=stiffness_nl, damping_nl=damping_nl,
                                 device=device, dtype=dtype, check=False)


def incidence_load(aero, dynamic_pressure, aoa_deg, n: int) -> np.ndarray:
    """(B, n) the steady load −q∞ Q_α α of a root angle of attack ``aoa_deg`` (deg, (B,) or
    scalar) on the aero file's m modes, zero-padded to n (InputError when the file has no
    incidence load)."""
    inc = aero.padded_incidence(n, "aoa_deg: the aero file")
    q = np.asarray(dynamic_pressure, dtype=float).reshape(-1)
    a = np.broadcast_to(np.radians(np.asarray(aoa_deg, dtype=float)), q.shape)
    return -(q * a)[:, None] * inc[None]


def aeroelastic_system_at(rom: NonlinearROM, aero, velocity, density, *, altitude=None,
                          alpha=0.0, gamma=0.0, stiffness_nl=1.0, damping_nl=1.0, aoa_deg=0.0,
                          device=None, dtype=torch.float64, check: bool = True
                          ) -> AeroelasticCases:
    """B aeroelastic cases at given speeds V and air densities ρ (arrays (B,) or scalars, the
    units of the RFA: ft/s and slug/ft³ for Goland), q∞ = ½ρV² (Eqs. 49–50): a wind tunnel,
    where the speed is swept at one density, or the matched point of
    :func:`aeroelastic_system` (V = M a(h), ρ(h)). ``altitude`` only labels the cases (NaN
    when a density was given directly). ``aoa_deg``: the root angle of attack (deg, scalar or
    (B,)), whose steady load (:func:`incidence_load`) the cases carry (none where all are 0)."""
    if check:
        check_aero_matches_rom(rom, aero)
    V, rho = np.broadcast_arrays(np.atleast_1d(np.asarray(velocity, dtype=float)),
                                 np.atleast_1d(np.asarray(density, dtype=float)))
    if V.ndim != 1 or not np.all(np.isfinite(rho)) or np.any(rho <= 0):
        raise InputError(f"aeroelastic: density: expected positive finite numbers, got "
                         f"{density!r}")
    q = 0.5 * rho * V**2
    add = aero_additions(aero, V, q, rom.n)
    alt = (np.full(len(V), np.nan) if altitude is None
           else np.broadcast_to(np.asarray(altitude, dtype=float), V.shape).copy())
    if np.any(np.asarray(aoa_deg, dtype=float) != 0.0):
        add["load"] = incidence_load(aero, q, aoa_deg, rom.n)
    # a ROM about a deformed state: its coordinates are x = q − q_ref, and the steady load of
    # q_ref with the structural force there is a constant load (torchrom.rom.reference); the
    # steady stiffness is the system's own, q∞ A0 (K_add), so that its statics are consistent
    ref = reference_load(rom, rfa_steady_stiffness(aero, rom.n), q)
    if ref is not None:
        add["load"] = ref if add.get("load") is None else add["load"] + ref
    system = CaseSystem.build(rom, len(V), alpha=alpha, gamma=gamma, stiffness_nl=stiffness_nl,
                              damping_nl=damping_nl, device=device, dtype=dtype, **add)
    return AeroelasticCases(system, alt, np.full(len(V), aero.mach), V.copy(), rho.copy(), q)


# -- the linearised system and the simulator's growth rate --------------------------------------
def linear_state_matrices(system: CaseSystem, about: torch.Tensor | None = None
                          ) -> torch.Tensor:
    """First-order matrices (B, 2n + na, 2n + na) of every case linearised about its static
    state q0 (q = 0 without a load; :func:`~torchrom.sim.system.static_equilibrium` with one),
    state x = [q − q0, q̇, ξ] (torch, the system's device and dtype):

        (M + M_add) q̈ = −(K_T(q0) + K_add) q − (α M + γ D_T(q0) + C_add) q̇ − lag_D ξ,
        ξ̇ = lag_E q̇ + lag_R ξ,

    K_T = K1 + s·(2K2(q0) + 3K3(q0,q0)) and D_T = D̄1 + d·(D̄2(q0) + D̄3(q0,q0)) (K1 and D̄1
    at q0 = 0). ``about``: q0 (B, n) when the caller has it already."""
    from .system import static_equilibrium

    rom, B, n, na = system.rom, system.batch_size, system.n, system.n_lag
    kw = {"device": system.device, "dtype": system.dtype}
    M = rom.M.to(**kw)

    def plus(base, extra):
        base = base.expand(B, n, n)
        return base if extra is None else base + extra

    q0 = static_equilibrium(system) if about is None else about.to(**kw)
    Kt, Ct = rom.tangents(torch.nan_to_num(q0), torch.zeros_like(q0), system.alpha,
                          system.gamma, system.stiffness_nl, system.damping_nl)
    Mt = plus(M, system.M_add)
    C = plus(Ct, system.C_add)
    K = plus(Kt, system.K_add)
    blocks = [K, C] + ([system.lag_D] if na else [])
    rows = torch.linalg.solve(Mt, torch.cat(blocks, dim=2))
    a = torch.zeros(B, 2 * n + na, 2 * n + na, **kw)
    a[:, :n, n:2 * n] = torch.eye(n, **kw)
    a[:, n:2 * n] = -rows
    if na:
        a[:, 2 * n:, n:2 * n] = system.lag_E
        a[:, 2 * n:, 2 * n:] = system.lag_R
    return a


def linear_state_matrix(system: CaseSystem, case: int = 0) -> np.ndarray:
    """First-order matrix of case ``case`` linearised about q = 0 (float64 numpy), state
    x = [q, q̇, ξ] (see :func:`linear_state_matrices`)."""
    s = system.select([case]).to(dtype=torch.float64)
    return linear_state_matrices(s)[0].cpu().numpy()


def critical_eigenpair(system: CaseSystem, case: int = 0,
                       min_frequency_hz: float = 1e-3) -> tuple[complex, np.ndarray]:
    """The oscillatory root of the linearised case with the largest real part (1/s) and its
    eigenvector (state [q, q̇, ξ])."""
    s, v = np.linalg.eig(linear_state_matrix(system, case))
    osc = np.flatnonzero(s.imag > 2 * np.pi * min_frequency_hz)
    if len(osc) == 0:
        raise InputError("aeroelastic: the linearised system has no oscillatory root")
    j = osc[np.argmax(s[osc].real)]
    return complex(s[j]), v[:, j]


def critical_mode_state(system: CaseSystem, output_row, amplitude: float):
    """Initial states (q0, v0, ξ0), each (B, ·), on the critical eigenvector of every case,
    scaled so that the output ``output_row`` · q has the amplitude ``amplitude``; and the (B,)
    critical eigenvalues. Starting there, the linear response is that single root."""
    n, na = system.n, system.n_lag
    row = np.asarray(output_row, dtype=float)
    q0, v0, xi0, roots = [], [], [], []
    for i in range(system.batch_size):
        lam, x = critical_eigenpair(system, i)
        c = row @ x[:n]
        if abs(c) == 0:
            c = x[np.argmax(np.abs(x[:n]))]
        x = x * (amplitude / abs(c)) * np.conj(c) / abs(c)  # output starts at +amplitude
        q0.append(x[:n].real)
        v0.append(x[n:2 * n].real)
        xi0.append(x[2 * n:2 * n + na].real)
        roots.append(lam)
    return np.array(q0), np.array(v0), np.array(xi0).reshape(len(q0), na), np.array(roots)


def growth_rate(t, y) -> tuple[float, float]:
    """(σ 1/s, f Hz) of a sampled oscillation y(t) ≈ A e^{σt} cos(2πf t + φ): least-squares line
    through ln|extremum| against the extremum times (maxima and minima together; the times come
    from a parabola through the three samples around each extremum), and f from the spacing of
    the extremum times. NaN when fewer than four extrema are found."""
    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    i = np.flatnonzero((np.abs(y[1:-1]) >= np.abs(y[:-2])) & (np.abs(y[1:-1]) > np.abs(y[2:])))
    i = i + 1
    if len(i) < 4:
        return float("nan"), float("nan")
    y0, y1, y2 = np.abs(y[i - 1]), np.abs(y[i]), np.abs(y[i + 1])
    den = y0 - 2 * y1 + y2
    with np.errstate(divide="ignore", invalid="ignore"):
        shift = np.where(den != 0, 0.5 * (y0 - y2) / den, 0.0)
    peak = y1 - 0.25 * (y0 - y2) * shift
    h = t[i + 1] - t[i]
    tp = t[i] + shift * h
    sigma = float(np.polyfit(tp, np.log(peak), 1)[0])
    half_period = float(np.polyfit(np.arange(len(tp)), tp, 1)[0])
    return sigma, 1.0 / (2.0 * half_period)
