"""How much a ROM's nonlinear damping dissipates on an LCO: the damping cause check's measure.

For a Kelvin–Voigt ROM the dissipated power is P = γ q̇ᵀ (D̄1 + D̄2(q) + D̄3(q, q)) q̇ (Eq. 54, α
aside). On a converged γ = 0 LCO (the trajectory does not depend on the damping tensors, so every
damping identification can be judged on the same cycle) the ratio

    r = ⟨q̇ᵀ (D̄2(q) + D̄3(q, q)) q̇⟩ / ⟨q̇ᵀ D̄1 q̇⟩          (⟨·⟩: mean over whole periods)

says whether the nonlinear terms add dissipation (r > 0) or cancel the linear damping of the
dual-mode motion (r → −1: the motion is nearly inextensional, the strain rate and with it the
Kelvin–Voigt dissipation nearly vanish). The smallest eigenvalue of the scaled extended matrix
(the decomposition's criterion, :mod:`torchrom.identify.damping`) is reported beside it.

Over :mod:`torchrom.sim` and :mod:`torchrom.rom`.
"""

from __future__ import annotations

import numpy as np
import torch

from ..identify import damping as dmp
from ..periodic import solve_orbits
from ..periodic.fourier import FourierBasis
from ..rom import NonlinearROM
from ..rom import conventions as cv
from ..sim.newmark import HistoryRequest
from ..study.cases import case_system
from ..study.sweep import initial_displacement, initial_velocity

#: periods of the converged LCO the cycle means are taken over
CYCLE_PERIODS = 3


def scaled_min_eigenvalue(rom: NonlinearROM) -> float:
    """Smallest eigenvalue of the scaled extended matrix of the ROM's damping tensors (the
    quantity the optimum decomposition maximises; ≥ 0 means dissipative for every motion)."""
    G, H = rom.gram()
    K_E = cv.energy_extended_matrix(rom.D1, G, H)
    return float(torch.linalg.eigvalsh(dmp.scale_matrix(K_E, rom.D1.numpy(), H.numpy())).min())


#: samples of one period when the cycle comes from a harmonic balance orbit
HB_CYCLE_SAMPLES = 1024
#: altitude step (ft) of the neighbour chain that reaches the check's orbit from near flutter
HB_CHAIN_STEP_FT = 1000.0


def lco_cycle(model, cfg, altitude_ft: float, t_end: float | None = None,
              orbit: tuple[np.ndarray, float] | None = None
              ) -> tuple[np.ndarray, np.ndarray, str]:
    """(q, q̇, status) over the last :data:`CYCLE_PERIODS` periods of the γ = 0 case ("NL stiff")
    of the sweep ``cfg`` (its initial condition, integrator and LCO criteria) at ``altitude_ft``,
    every time step; q̇ by central differences of the recorded q. With ``method = "hb"`` the
    cycle is the harmonic balance orbit (:data:`HB_CYCLE_SAMPLES` samples of one period, q̇
    exact): the ratio is a mean over whole periods either way. ``orbit``: that case's orbit
    (Fourier coefficients (2H+1, n), ω in rad/s) from a sweep that already solved it (the
    large γ = 0 orbits need a time-integration seed, :mod:`torchrom.periodic.seed`); else it
    is solved here."""
    rom = model.rom
    if orbit is not None:
        return _orbit_cycle(torch.as_tensor(orbit[0], dtype=torch.float64), float(orbit[1]))
    cases = [{"altitude_ft": float(altitude_ft), "gamma": 0.0, "alpha": "matched"}]
    system, _ = case_system(model, cases, torch.device("cpu"), torch.float64)
    # the sweep's deciding output (its first; the ROM's first output if it names none)
    names, C = rom.output_matrix([(cfg.outputs or list(rom.outputs))[0]])
    if not cfg.solver.marches_time:  # a periodic orbit itself, sampled finely
        # reached along a chain of altitudes from near flutter (warm starts, robust)
        alts = [float(altitude_ft) + HB_CHAIN_STEP_FT * k for k in range(
            int((model.reference_altitude() - float(altitude_ft)) // HB_CHAIN_STEP_FT) + 1)]
        chain = [{**cases[0], "altitude_ft": a} for a in alts]
        system, _ = case_system(model, chain, torch.device("cpu"), torch.float64)
        orb = solve_orbits(system, C[0], cfg.hb.options, chains=[list(range(len(chain)))[::-1]],
                           positions=alts)
        if orb.status[0] != "lco":
            return np.zeros((0, rom.n)), np.zeros((0, rom.n)), str(orb.status[0])
        return _orbit_cycle(orb.X[0], float(orb.omega[0]))
    names += [f"q{i + 1}" for i in range(rom.n)]
    res = cfg.integrator.run(system, initial_displacement(rom, cfg.initial, cases),
                             initial_velocity(rom, cfg.initial, 1),
                             t_end=cfg.t_end if t_end is None else t_end,
                             outputs=(names, np.vstack([C, np.eye(rom.n)])), lco=cfg.lco,
                             history=HistoryRequest((0,), 1))
    h = res.histories[0]
    dt = float(h.t[1] - h.t[0])
    freq = float(res.frequency_hz[0])
    k = int(round(CYCLE_PERIODS / freq / dt)) if np.isfinite(freq) and freq > 0 else len(h.t) // 4
    q = h.y[-k - 2:, 1:]
    return q[1:-1], (q[2:] - q[:-2]) / (2 * dt), str(res.status[0])


def _orbit_cycle(X: torch.Tensor, omega: float) -> tuple[np.ndarray, np.ndarray, str]:
    """(q, q̇, "lco") at :data:`HB_CYCLE_SAMPLES` samples of one period of the orbit X (2H+1, n)
    with angular frequency ω (rad/s)."""
    basis = FourierBasis.build((X.shape[0] - 1) // 2, HB_CYCLE_SAMPLES)
    return (basis.E @ X).numpy(), omega * (basis.dE @ X).numpy(), "lco"


def dissipation_ratio(rom: NonlinearROM, q: np.ndarray, qd: np.ndarray) -> float:
    """⟨q̇ᵀ (D̄2(q) + D̄3(q, q)) q̇⟩ / ⟨q̇ᵀ D̄1 q̇⟩ over the samples (T, n) of q and q̇."""
    Q = torch.as_tensor(q, dtype=torch.float64)
    V = torch.as_tensor(qd, dtype=torch.float64)
    full = torch.einsum("ti,tij,tj->t", V, rom.damping_matrix(Q), V).mean()
    lin = torch.einsum("ti,tij,tj->t", V, rom.damping_matrix(Q, damping_nl=False), V).mean()
    return float((full - lin) / lin)
