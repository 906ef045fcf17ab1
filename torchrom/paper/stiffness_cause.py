"""Why the stiffness nonlinearity doubles the γ = 1e-3 s LCO (paper Fig. 10: "matters little").

The LCO amplitude is where the aerodynamic power input over a cycle equals the structural
dissipation, P = ⟨q̇ᵀ(α M + γ (D̄1 + D̄2(q) + D̄3(q, q))) q̇⟩ (Eq. 54; the stiffness terms K2, K3
are conservative and do no work over a cycle). This module measures, on harmonic balance orbits
of one case (γ, matched α, one altitude):

1. :data:`SWITCHES` — the LCO amplitude with the stiffness nonlinearity on, off, and with parts
   of it switched off one at a time: the cubic K3, the quadratic K2, the couplings through the
   dual (in-plane) basis functions, and everything but those couplings;
2. :func:`energy_terms` — the cycle mean of each term's power (α M, γ D̄1 on the linear modes,
   γ D̄1 on the dual modes, γ D̄2, γ D̄3, and the conservative K2, K3 as a check), so that where
   an amplitude changes the term that changed it is named;
3. :func:`following_ratio` — the nonlinear-to-linear damping ratio of one cycle with the dual
   coordinates as they are and with them replaced by their quasi-static response to the
   quadratic stiffness (K1_dd q_d = −K2_d(q, q)): what the dual modes' following of the bending
   does to the Kelvin–Voigt dissipation.

:func:`stiffness_cause` runs the three on a model (``torchrom paper``'s report section, and
``experiments/stiffness_nl_at_large_gamma.py`` on more altitudes and the other wing variant).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
import torch

from ..periodic import solve_orbits
from ..periodic.fourier import FourierBasis
from ..rom import NonlinearROM
from ..study.cases import case_system

#: the case of the finding: γ = 1e-3 s at the lowest altitude of the paper's Fig. 10
CAUSE_GAMMA = 1e-3
CAUSE_ALTITUDE_FT = 4000.0
#: altitude step (ft) of the neighbour chain from near flutter down to the case
CHAIN_STEP_FT = 1000.0
#: samples of one period for the cycle means
SAMPLES = 512


def _dual(rom: NonlinearROM) -> np.ndarray:
    return np.array([k == "dual" for k in rom.mode_kinds])


def _keep(tensor: torch.Tensor, dual: np.ndarray, with_dual: bool) -> torch.Tensor:
    """``tensor`` with only the entries that involve a dual index (``with_dual``) or only those
    that involve none."""
    d = torch.as_tensor(dual)
    mask = torch.zeros(tensor.shape, dtype=torch.bool)
    for axis in range(tensor.dim()):
        shape = [1] * tensor.dim()
        shape[axis] = -1
        mask = mask | d.reshape(shape)
    return torch.where(mask if with_dual else ~mask, tensor, torch.zeros_like(tensor))


#: name -> (ROM -> ROM, stiffness nonlinearity on): the stiffness nonlinearity in parts
SWITCHES: dict[str, tuple[Callable[[NonlinearROM], NonlinearROM], bool]] = {
    "both nonlinearities": (lambda r: r, True),
    "no stiffness nonlinearity": (lambda r: r, False),
    "K3 off (K2 kept)": (lambda r: r.replace(K3=torch.zeros_like(r.K3)), True),
    "K2 off (K3 kept)": (lambda r: r.replace(K2=torch.zeros_like(r.K2)), True),
    "dual-mode couplings off": (lambda r: r.replace(K2=_keep(r.K2, _dual(r), False),
                                                    K3=_keep(r.K3, _dual(r), False)), True),
    "only the dual-mode couplings": (lambda r: r.replace(K2=_keep(r.K2, _dual(r), True),
                                                         K3=_keep(r.K3, _dual(r), True)), True),
}


def solve_chain(model, hb_options, output_row, altitudes: Sequence[float], gamma: float,
                stiffness_nl: bool = True, damping_nl: bool = True):
    """The HB orbits of the cases (matched α) at ``altitudes``, reached along one chain of
    altitudes from near the flutter altitude down (every :data:`CHAIN_STEP_FT` and the
    requested ones; warm starts). Returns {altitude: (X (2H+1, n), ω rad/s, status)} and α."""
    top = model.reference_altitude()
    low = min(float(h) for h in altitudes)
    grid = {low + CHAIN_STEP_FT * k for k in range(int((top - low) // CHAIN_STEP_FT) + 1)}
    alts = sorted(grid | {float(h) for h in altitudes if float(h) < top})
    chain = [{"altitude_ft": a, "gamma": gamma, "alpha": "matched",
              "stiffness_nl": stiffness_nl, "damping_nl": damping_nl} for a in alts]
    system, _ = case_system(model, chain, torch.device("cpu"), torch.float64)
    orb = solve_orbits(system, output_row, hb_options, chains=[list(range(len(chain)))[::-1]],
                       positions=alts)
    out = {a: (orb.X[i], float(orb.omega[i]), str(orb.status[i])) for i, a in enumerate(alts)}
    return {float(h): out.get(float(h), (None, float("nan"), "above flutter"))
            for h in altitudes}, float(model.matched_alpha(gamma))


def cycle(X: torch.Tensor, omega: float) -> tuple[torch.Tensor, torch.Tensor]:
    """(q, q̇) at :data:`SAMPLES` points of one period of the orbit X (2H+1, n)."""
    basis = FourierBasis.build((X.shape[0] - 1) // 2, SAMPLES)
    X = X.to(torch.float64)
    return basis.E @ X, omega * (basis.dE @ X)


def energy_terms(rom: NonlinearROM, q: torch.Tensor, qd: torch.Tensor, alpha: float,
                 gamma: float, stiffness_nl: bool = True) -> dict[str, float]:
    """Cycle means of the power of each term of Eq. 54 over the samples (T, n) of q, q̇ (the
    model's units of force × velocity); the stiffness terms' means vanish on a periodic orbit."""
    dual = torch.as_tensor(_dual(rom))
    d1 = qd @ rom.D1.T
    zero3, zero4 = torch.zeros_like(rom.D2), torch.zeros_like(rom.D3)
    d2 = torch.einsum("ti,tij,tj->t", qd, rom.replace(D3=zero4).damping_matrix(q), qd) \
        - (qd * d1).sum(1)
    d3 = torch.einsum("ti,tij,tj->t", qd, rom.replace(D2=zero3).damping_matrix(q), qd) \
        - (qd * d1).sum(1)
    k2 = rom.replace(K3=torch.zeros_like(rom.K3)).stiffness_force(q) - q @ rom.K1.T
    k3 = rom.replace(K2=torch.zeros_like(rom.K2)).stiffness_force(q) - q @ rom.K1.T
    s = 1.0 if stiffness_nl else 0.0
    terms = {"α M": alpha * (qd * (qd @ rom.M.T)).sum(1),
             "γ D̄1, linear modes": gamma * (qd * d1)[:, ~dual].sum(1),
             "γ D̄1, dual modes": gamma * (qd * d1)[:, dual].sum(1),
             "γ D̄2(q)": gamma * d2, "γ D̄3(q, q)": gamma * d3,
             "K2 (conservative)": s * (qd * k2).sum(1), "K3 (conservative)": s * (qd * k3).sum(1)}
    return {k: float(v.mean()) for k, v in terms.items()}


def quasi_static_duals(rom: NonlinearROM, q: torch.Tensor, qd: torch.Tensor
                       ) -> tuple[torch.Tensor, torch.Tensor]:
    """q, q̇ with the dual coordinates replaced by their quasi-static response to the quadratic
    stiffness of the linear ones, q_d = −K1_dd⁻¹ K2_d(q_L, q_L) (and its time derivative)."""
    dual = torch.as_tensor(_dual(rom))
    lin = ~dual
    K2 = rom.K2[dual][:, lin][:, :, lin]
    A = torch.linalg.inv(rom.K1[dual][:, dual])
    qL, vL = q[:, lin], qd[:, lin]
    q = q.clone()
    qd = qd.clone()
    q[:, dual] = -torch.einsum("ij,jkl,tk,tl->ti", A, K2, qL, qL)
    qd[:, dual] = -2.0 * torch.einsum("ij,jkl,tk,tl->ti", A, K2, qL, vL)
    return q, qd


def nl_over_linear(rom: NonlinearROM, q: torch.Tensor, qd: torch.Tensor) -> float:
    """⟨q̇ᵀ(D̄2(q) + D̄3(q, q))q̇⟩ / ⟨q̇ᵀD̄1q̇⟩ over the samples (−1: the nonlinear terms cancel
    the linear damping, :mod:`.dissipation`)."""
    full = torch.einsum("ti,tij,tj->t", qd, rom.damping_matrix(q), qd).mean()
    lin = torch.einsum("ti,tij,tj->t", qd, rom.damping_matrix(q, damping_nl=False), qd).mean()
    return float((full - lin) / lin)


def following_ratio(rom: NonlinearROM, q: torch.Tensor, qd: torch.Tensor) -> dict[str, float]:
    """The nonlinear-to-linear damping ratio of a cycle as it is, with its dual coordinates set
    to zero, and with them following the linear ones quasi-statically
    (:func:`quasi_static_duals`)."""
    dual = torch.as_tensor(_dual(rom))
    q0, qd0 = q.clone(), qd.clone()
    q0[:, dual] = 0.0
    qd0[:, dual] = 0.0
    return {"as solved": nl_over_linear(rom, q, qd),
            "dual coordinates zero": nl_over_linear(rom, q0, qd0),
            "dual coordinates quasi-static": nl_over_linear(rom, *quasi_static_duals(rom, q, qd))}


def stiffness_cause(model, hb_options, output: str = "A_Tz",
                    altitudes: Sequence[float] = (CAUSE_ALTITUDE_FT,), gamma: float = CAUSE_GAMMA,
                    switches: Sequence[str] | None = None,
                    progress: Callable[[int], None] | None = None) -> dict[str, Any]:
    """The measures of the module docstring for ``model`` (an AeroelasticModel) at
    ``altitudes`` and ``gamma`` (JSON-ready): per switch and altitude the status, amplitude
    (output units and % of span), frequency, each term's cycle-mean power and the dual modes'
    following ratios (the latter for the two main switches). ``progress(done)``: the number of
    switches finished so far."""
    rom = model.rom
    row = rom.output_matrix([output])[1][0]
    span = model.span
    rows = []
    dual = _dual(rom)
    for done, name in enumerate(switches or list(SWITCHES)):
        if progress is not None:
            progress(done)
        make, stiff = SWITCHES[name]
        variant = replace(model, rom=make(rom))
        orbits, alpha = solve_chain(variant, hb_options, row, altitudes, gamma, stiff)
        for h, (X, omega, status) in orbits.items():
            rec: dict[str, Any] = {"switch": name, "altitude_ft": h, "status": status,
                                   "alpha": alpha, "gamma": gamma}
            if status == "lco":
                q, qd = cycle(X, omega)
                y = q.numpy() @ row
                amp = 0.5 * float(y.max() - y.min())
                rec.update({"amplitude": amp, "frequency_hz": omega / (2 * np.pi),
                            "amplitude_pct_span": 100 * amp / span if span else None,
                            "dual_rms": float(q[:, torch.as_tensor(dual)].pow(2).mean().sqrt()),
                            "terms": energy_terms(variant.rom, q, qd, alpha, gamma, stiff)})
                if name in ("both nonlinearities", "no stiffness nonlinearity"):
                    rec["following"] = following_ratio(variant.rom, q, qd)
            rows.append(rec)
    if progress is not None:
        progress(len(switches or SWITCHES))
    return {"gamma": gamma, "output": output, "rows": rows}
