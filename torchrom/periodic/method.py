"""Harmonic balance as a sweep method: the same call and the same result as the time integrator.

:class:`HarmonicBalanceMethod` has the signature of :meth:`torchrom.sim.Newmark.run` and returns
a :class:`~torchrom.sim.SimulationResult`, so a sweep switches between time marching and
periodic orbits with ``method = "hb"`` and writes the same table: ``status`` (``lco``,
``decay``, ``diverged``, ``unconverged``, ``failed``), ``amplitude`` (half peak-to-peak of each
output over one period of the orbit), ``frequency_hz`` and the ratios. HB adds per-case columns
(:attr:`SimulationResult.extra`): ``method`` ("hb"), ``harmonics`` (H), ``hb_residual`` (last
Newton residual), ``truncation`` (see :func:`~.solve.truncation_residual`),
``harmonic_distortion`` (of the first output), ``stable`` and ``floquet_multiplier`` (modulus
of the critical Floquet multiplier, :mod:`.floquet`; ``stable`` is unknown where the monodromy
matrix misses the trivial multiplier by more than 5 %, ``floquet_error``) and ``seeded`` (the
orbit was seeded by a short time integration: :mod:`.seed`, for the cases the harmonic ladder
left unconverged — or, with ``seed = "unresolved"``, not converged in H); ``steps`` holds the
Newton iterations and ``t_end`` is NaN (no simulated time). A decaying case is stable when its
critical linear root is; its amplitude is 0.

The initial condition and ``t_end`` of a time-marching configuration do not apply; the
``[initial] q0`` sets the cold start's first amplitude scale when no ``amplitude_scale`` is
given.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np
import torch

from ..errors import InputError
from ..rom.reference import output_offsets
from ..sim.lco import LCOCriteria
from ..sim.newmark import output_matrix
from ..sim.result import SimulationResult
from ..sim.system import CaseSystem
from .floquet import FLOQUET_STEPS, floquet
from .fourier import resize_harmonics
from .seed import SEED_MODES, seed_unresolved
from .sensitivity import amplitude_derivative
from .solve import HBOptions, solve_orbits

#: orbits per monodromy batch
FLOQUET_BATCH = 16


@dataclass
class HarmonicBalanceMethod:
    """Periodic orbits by harmonic balance for a batch of cases (module docstring).

    Attributes:
        options: the solver's settings (:class:`~.solve.HBOptions`).
        stability: compute Floquet multipliers (``stable``, ``floquet_multiplier``).
        floquet_steps: steps per period of the monodromy matrix (exponential midpoint rule).
        start: "neighbour" (cases chained along their varying parameter start from their
            neighbour's orbit) or "cold" (every case from its linear flutter mode).
        seed: which cases to re-solve from a short time integration's orbit at higher H
            (:mod:`.seed`): "unconverged" (default: the cases harmonic balance did not
            converge), "unresolved" (also the LCOs not accepted in H; more cases, each costs
            a few periods of time integration) or "off".
        sensitivity: also the derivatives of each LCO's amplitude and frequency with respect
            to γ by the implicit-function theorem (:mod:`.sensitivity`; columns
            ``amplitude_dgamma``, output units per s, and ``frequency_dgamma``, Hz per s); the
            caller passes the systems at γ ± δγ (``parameter_systems`` of :meth:`run`).
    """

    options: HBOptions = field(default_factory=HBOptions)
    stability: bool = True
    floquet_steps: int = FLOQUET_STEPS
    start: str = "neighbour"
    sensitivity: bool = False
    seed: str = "unconverged"

    def __post_init__(self):
        if isinstance(self.sensitivity, str) or not isinstance(self.sensitivity, bool):
            raise InputError(f"hb.sensitivity: expected true or false, got {self.sensitivity!r}")
        if self.start not in ("neighbour", "cold"):
            raise InputError(f"hb.start: expected 'neighbour' or 'cold', got {self.start!r}")
        if isinstance(self.stability, str) or not isinstance(self.stability, bool):
            raise InputError(f"hb.stability: expected true or false, got {self.stability!r}")
        if self.seed not in SEED_MODES:
            raise InputError(f"hb.seed: expected one of {list(SEED_MODES)}, got {self.seed!r}")
        if (isinstance(self.floquet_steps, bool) or not isinstance(self.floquet_steps, int)
                or self.floquet_steps < 8 or self.floquet_steps % 2):
            raise InputError(f"hb.floquet_steps: expected an even integer >= 8, got "
                             f"{self.floquet_steps!r}")

    def run(self, system: CaseSystem, q0=None, v0=None, xi0=None, *, t_end: float = math.nan,
            outputs=None, lco: LCOCriteria | None = None, history=None, progress=None,
            chains: list[list[int]] | None = None, positions=None,
            parameter_systems=None) -> SimulationResult:
        """The orbits of every case; ``lco.max_amplitude`` bounds them ('diverged' beyond),
        ``chains``/``positions`` as :func:`~.solve.solve_orbits` (used with start
        "neighbour"); ``parameter_systems``: (plus, minus, δγ (B,)) the cases at γ ± δγ, for
        ``sensitivity``."""
        t0 = time.perf_counter()
        names, C = output_matrix(system.rom, outputs)
        crit = lco or LCOCriteria()
        decide = C[crit.decision_outputs[0]]
        opts = self.options
        if math.isfinite(crit.max_amplitude) and not math.isfinite(opts.max_amplitude):
            opts = dataclasses.replace(opts, max_amplitude=float(crit.max_amplitude))
        system64 = system.to(dtype=torch.float64)
        if self.start != "neighbour":
            chains = positions = None
        orb = solve_orbits(system64, decide, opts, chains=chains, positions=positions)
        orb, seeded = seed_unresolved(system64, torch.as_tensor(decide, dtype=torch.float64),
                                      orb, opts, self.seed, chains, positions)
        rows = torch.as_tensor(C, dtype=torch.float64)
        amp = orb.amplitude(rows, opts.metric_points)
        B = system.batch_size
        freq = orb.frequency_hz.copy()
        freq[orb.status == "decay"] = 0.0
        stable = np.full(B, np.nan, dtype=object)
        mult = np.full(B, np.nan)
        ferr = np.full(B, np.nan)
        decay = orb.status == "decay"
        root = orb.critical_root
        stable[decay] = root.real[decay] < 0
        mult[decay] = np.exp(root.real[decay] * 2 * np.pi / np.maximum(root.imag[decay],
                                                                        1e-300))
        lco_idx = np.flatnonzero(orb.status == "lco")
        if self.stability and lco_idx.size:
            for h in np.unique(orb.harmonics[lco_idx]):
                same_h = lco_idx[orb.harmonics[lco_idx] == h]
                # in slices: the per-step matrices of a whole large batch outgrow the caches
                for start in range(0, same_h.size, FLOQUET_BATCH):
                    idx = same_h[start: start + FLOQUET_BATCH]
                    t = torch.as_tensor(idx)
                    fl = floquet(system.select(t).to(dtype=torch.float64),
                                 resize_harmonics(orb.X[t], int(h)), orb.omega[t],
                                 self.floquet_steps)
                    stable[idx] = fl.stable
                    mult[idx] = fl.critical_modulus
                    ferr[idx] = fl.trivial_error
        if self.sensitivity and parameter_systems is not None:
            dA, df = np.full(B, np.nan), np.full(B, np.nan)
            plus, minus, dg = parameter_systems
            r = torch.as_tensor(decide, dtype=torch.float64)
            for h in np.unique(orb.harmonics[lco_idx]):
                idx = lco_idx[orb.harmonics[lco_idx] == h]
                t = torch.as_tensor(idx)
                a, w = amplitude_derivative(
                    system.select(t).to(dtype=torch.float64),
                    plus.select(t).to(dtype=torch.float64),
                    minus.select(t).to(dtype=torch.float64),
                    torch.as_tensor(np.asarray(dg, dtype=float)[idx]),
                    resize_harmonics(orb.X[t], int(h)), orb.omega[t], r, opts.metric_points)
                dA[idx], df[idx] = a.numpy(), w.numpy() / (2 * np.pi)
            sens = {"amplitude_dgamma": dA, "frequency_dgamma": df}
        else:
            sens = {}
        dist = orb.distortion(rows[:1])[:, 0]
        dist[orb.status != "lco"] = np.nan
        if system.load is not None:  # a mean state (a wing at an angle of attack): its outputs
            # + C q_ref: a ROM about a deformed state moves about its reference (rom.reference)
            mean = (orb.X[:, 0] @ rows.T).cpu().numpy() + output_offsets(system.rom, C)
            mean[~np.isin(orb.status, ("lco", "decay"))] = np.nan
            sens = {**sens, **{f"mean_{name}": mean[:, j] for j, name in enumerate(names)}}
        extra = {"method": np.full(B, "hb", dtype=object), "harmonics": orb.harmonics,
                 "hb_residual": orb.residual, "truncation": orb.truncation,
                 "harmonic_distortion": dist, "stable": stable, "floquet_multiplier": mult,
                 "floquet_error": ferr, "seeded": seeded,
                 **sens}
        wall = time.perf_counter() - t0
        if progress is not None:
            progress(B, B)
        nan = np.full(B, np.nan)
        n = system.n
        q = orb.X[:, 0] + orb.X[:, 1::2].sum(1)  # the orbit at τ = 0
        return SimulationResult(
            output_names=names, status=orb.status.astype(object), steps=orb.iterations,
            time=nan.copy(), amplitude=amp, frequency_hz=freq,
            amplitude_change=orb.amplitude_change, solver_error=orb.residual,
            q=q.cpu().numpy().reshape(B, n), v=np.zeros((B, n)), wall_time_s=wall,
            case_steps=int(orb.iterations.sum()), extra=extra,
            orbits=(orb.X.cpu().numpy(), orb.omega.cpu().numpy()))

