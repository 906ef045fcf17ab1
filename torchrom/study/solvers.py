"""The solvers a sweep runs its cases with: one small contract, three implementations.

A sweep, the paper study and the CLI hold one :class:`Solver` (``SweepConfig.solver``, chosen
by the configuration's ``method``) and ask it what it needs instead of branching on the
method's name:

- ``run(chunk)``: the :class:`~torchrom.sim.SimulationResult` of one chunk of cases
  (:class:`ChunkRun`: configuration, model, batched system, cases, histories to keep);
- what it is: ``marches_time`` (needs ``[integrator] t_end``, is bounded by case-steps, can
  record time histories), ``chains_neighbours`` (cases chained along their varying parameter
  start from each other's orbits: one chunk per batch, so the chains stay whole),
  ``writes_orbits`` (Fourier orbits per case, the orbit table);
- its bounds (``check_effort``, ``check_memory``: :mod:`torchrom.bounds`), the certificate it
  runs under (``certificate``), and its log lines (``describe``, ``cost_line``).

Implementations: :class:`TimeMarching` (``method = "newmark"``: Newmark transients from the
``[initial]`` starts, waves for sequential starts), :class:`HarmonicBalance` (``"hb"``:
periodic orbits with the adaptive harmonic ladder, neighbour chains and seeding) and
:class:`Shooting` (``"shooting"``: the ``[hb]`` harmonic balance as the predictor — its
ladder in H, neighbour chains and, where it does not converge, time-integration seeds, without
its Floquet multipliers — and every orbit finished by shooting on the discrete Newmark map,
:mod:`torchrom.periodic.shooting`, through the certificate). Every solver's LCO rows are
certified after ``run`` (:func:`torchrom.periodic.certify.certify`, in
:mod:`torchrom.study.sweep`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np
import torch

from ..periodic import HarmonicBalanceMethod
from ..periodic.certify import Certificate
from ..rom import NonlinearROM
from ..sim import HistoryRequest, Newmark, SimulationResult
from ..sim.system import CaseSystem
from .cases import case_system, neighbour_chains
from .starts import march


@dataclass
class ChunkRun:
    """What a solver receives for one chunk: the configuration (a ``SweepConfig``), the model
    (ROM or aeroelastic model) and its ROM, the chunk's batched system and cases, the positions
    of the cases whose histories are kept, the device and a progress callback."""

    cfg: Any
    model: Any
    rom: NonlinearROM
    system: CaseSystem
    cases: list[dict[str, Any]]
    keep: list[int]
    device: torch.device
    progress: Callable[[int, int], None] | None = None


class Solver(Protocol):
    """The solver contract (module docstring)."""

    name: ClassVar[str]
    marches_time: ClassVar[bool]
    chains_neighbours: ClassVar[bool]
    writes_orbits: ClassVar[bool]

    def run(self, chunk: ChunkRun) -> SimulationResult: ...

    def certificate(self, cfg) -> Certificate: ...

    def with_gamma_sensitivity(self, cfg): ...

    def check_effort(self, cfg, n_cases: int, what: str) -> None: ...

    def check_memory(self, cfg, n: int, batch: int, itemsize: int, device=None) -> None: ...

    def describe(self, cfg) -> str: ...

    def cost_line(self, timing: dict[str, Any]) -> str: ...


@dataclass(frozen=True)
class TimeMarching:
    """Newmark transients from the ``[initial]`` starts until the LCO criteria decide."""

    integrator: Newmark
    name: ClassVar[str] = "newmark"
    marches_time: ClassVar[bool] = True
    chains_neighbours: ClassVar[bool] = False
    writes_orbits: ClassVar[bool] = False

    @classmethod
    def from_config(cls, integrator: Newmark, hb: HarmonicBalanceMethod) -> TimeMarching:
        return cls(integrator)

    def run(self, chunk: ChunkRun) -> SimulationResult:
        cfg, done = chunk.cfg, [0]  # cases finished in earlier waves (progress over the chunk)

        def wave_progress(k, _n):
            if chunk.progress is not None:
                chunk.progress(done[0] + k, len(chunk.cases))

        def run(sub, q0, v0, xi0, index):
            # histories of the kept cases among these (positions within this run)
            mine = tuple(j for j, i in enumerate(index) if i in chunk.keep)
            history = HistoryRequest(mine, cfg.history.every) if mine else None
            res = self.integrator.run(sub, q0, v0, xi0, t_end=cfg.t_end, outputs=cfg.outputs,
                                      lco=cfg.lco, history=history, progress=wave_progress)
            done[0] += len(index)
            return res

        res = march(chunk.system, chunk.rom, chunk.cases, cfg.initial, run)
        if chunk.system.load is not None and res.centre is not None:
            # a mean state (a wing at an angle of attack): the middle of each output's band,
            # + C q_ref about a ROM's reference, as harmonic balance's 0th harmonic is reported
            from ..rom.reference import output_offsets
            from ..sim.newmark import output_matrix

            _, C = output_matrix(chunk.rom, res.output_names)
            mean = res.centre + output_offsets(chunk.rom, C)
            res.extra.update({f"mean_{name}": mean[:, j]
                              for j, name in enumerate(res.output_names)})
        return res

    def certificate(self, cfg) -> Certificate:
        return cfg.certificate

    def with_gamma_sensitivity(self, cfg):
        return cfg  # a transient has no implicit-function derivative

    def check_effort(self, cfg, n_cases: int, what: str) -> None:
        from ..bounds import MAX_WORK, check_count

        steps = self.integrator.step_count(cfg.t_end)
        iterations = max(self.integrator.iterations, self.integrator.startup_iterations or 0)
        check_count(f"{cfg.source}: [cases] x [integrator]",
                    f"{what} x steps x iterations ({n_cases} x {steps} x {iterations})",
                    float(n_cases) * steps * iterations, MAX_WORK, override=cfg.allow_large)

    def check_memory(self, cfg, n: int, batch: int, itemsize: int, device=None) -> None:
        from .. import bounds

        bounds.check_memory(f"{cfg.source}: [run] batch_size", f"time marching of {batch} "
                            f"cases at once with {n} modes",
                            bounds.integrator_bytes(n, batch, itemsize), device=device,
                            override=cfg.allow_large)

    def describe(self, cfg) -> str:
        return f"dt = {self.integrator.dt:g} s, t_end = {cfg.t_end:g} s"

    def cost_line(self, timing: dict[str, Any]) -> str:
        return (f"{timing['wall_time_s']:.1f} s integrating and certifying, "
                f"{timing['case_steps']} case-steps, "
                f"{timing['us_per_case_step']:.2f} us per case-step")


@dataclass(frozen=True)
class HarmonicBalance:
    """Periodic orbits by batched harmonic balance (:class:`~torchrom.periodic.method.
    HarmonicBalanceMethod`), neighbours starting from each other's orbits."""

    method: HarmonicBalanceMethod
    name: ClassVar[str] = "hb"
    marches_time: ClassVar[bool] = False
    chains_neighbours: ClassVar[bool] = True
    writes_orbits: ClassVar[bool] = True

    @classmethod
    def from_config(cls, integrator: Newmark, hb: HarmonicBalanceMethod) -> HarmonicBalance:
        return cls(hb)

    def run(self, chunk: ChunkRun) -> SimulationResult:
        cfg, kw = chunk.cfg, {}
        kw["chains"], kw["positions"] = neighbour_chains(chunk.cases)
        if self.method.sensitivity:
            kw["parameter_systems"] = gamma_perturbed_systems(chunk.model, chunk.cases,
                                                              chunk.device)
        return self.method.run(chunk.system, t_end=cfg.t_end, outputs=cfg.outputs,
                               lco=cfg.lco, progress=chunk.progress, **kw)

    def certificate(self, cfg) -> Certificate:
        return cfg.certificate

    def with_gamma_sensitivity(self, cfg):
        """``cfg`` whose orbits carry dA/dγ and df/dγ (implicit-function theorem)."""
        hb = dataclasses.replace(self.method, sensitivity=True)
        return dataclasses.replace(cfg, hb=hb)

    def check_effort(self, cfg, n_cases: int, what: str) -> None:
        from ..bounds import check_harmonic_balance_effort

        check_harmonic_balance_effort(f"{cfg.source}: [hb]", {
            "max_stages": self.method.options.max_stages,
            "metric_points": self.method.options.metric_points,
            "floquet_steps": self.method.floquet_steps}, override=cfg.allow_large)

    def check_memory(self, cfg, n: int, batch: int, itemsize: int, device=None) -> None:
        from .. import bounds

        bounds.check_harmonic_balance(f"{cfg.source}: [hb] max_harmonics", n,
                                      self.method.options.max_harmonics, batch, device=device,
                                      itemsize=itemsize, override=cfg.allow_large)

    def describe(self, cfg) -> str:
        o = self.method.options
        return (f"harmonic balance (H {o.harmonics}..{o.max_harmonics}, {self.method.start} "
                "starts)")

    def cost_line(self, timing: dict[str, Any]) -> str:
        return (f"{timing['wall_time_s']:.1f} s solving and certifying, "
                f"{timing['case_steps']} Newton iterations, "
                f"{1e3 * timing['wall_time_s'] / max(timing['computed'], 1):.1f} ms per case")


@dataclass(frozen=True)
class Shooting(HarmonicBalance):
    """Shooting on the discrete Newmark map from a harmonic-balance predictor (the ``[hb]``
    method without Floquet: the monodromy of the shooting finish is the stability of record),
    every LCO finished through the certificate (always on, always finishing)."""

    name: ClassVar[str] = "shooting"

    @staticmethod
    def predictor(method: HarmonicBalanceMethod) -> HarmonicBalanceMethod:
        """The ``[hb]`` method without its Floquet multipliers and γ-derivatives (the finish
        replaces both). Its ladder in H stays: on the Goland γ = 0 orbits Newton from H = 5
        wandered for 10–25 iterations (one did not converge in 25) where the ladder's
        orbits, 1–2 % off, finish in 4–11."""
        return dataclasses.replace(method, stability=False, sensitivity=False)

    def run(self, chunk: ChunkRun) -> SimulationResult:
        res = HarmonicBalance(self.predictor(self.method)).run(chunk)
        res.extra["method"] = np.full(res.batch_size, self.name, dtype=object)
        return res

    def certificate(self, cfg) -> Certificate:
        return dataclasses.replace(cfg.certificate, enabled=True, finish=True,
                                   always_finish=True)

    def with_gamma_sensitivity(self, cfg):
        return cfg  # the predictor's derivative is not the finished orbit's

    def describe(self, cfg) -> str:
        o = self.method.options
        return (f"shooting on the Newmark map at dt = {cfg.certificate.dt or cfg.integrator.dt:g}"
                f" s from harmonic balance (H {o.harmonics}..{o.max_harmonics})")

    def cost_line(self, timing: dict[str, Any]) -> str:
        return (f"{timing['wall_time_s']:.1f} s solving and finishing, "
                f"{1e3 * timing['wall_time_s'] / max(timing['computed'], 1):.1f} ms per case")


#: the solvers by the configuration's ``method`` name
SOLVERS: dict[str, type] = {cls.name: cls for cls in (TimeMarching, HarmonicBalance, Shooting)}
#: the solver of a configuration without ``method``
DEFAULT_METHOD = TimeMarching.name


def make_solver(method: str, integrator: Newmark, hb: HarmonicBalanceMethod) -> Solver:
    """The solver named ``method`` (a key of :data:`SOLVERS`) with the configuration's
    integrator and ``[hb]`` method."""
    return SOLVERS[method].from_config(integrator, hb)


def gamma_perturbed_systems(model, cases, device, rel: float = 1e-4, floor: float = 1e-9):
    """(plus, minus, δγ): the cases with γ ± δγ (δγ = rel·|γ|, at least ``floor`` s; a matched α
    is matched again), in float64: the central difference of the harmonic balance residual
    in γ that the implicit-function theorem needs (:mod:`torchrom.periodic.sensitivity`)."""
    g = np.array([float(c.get("gamma", 0.0)) for c in cases])
    dg = np.maximum(rel * np.abs(g), floor)
    # one-sided at γ = 0 would leave the model's domain only in name: γ − δγ < 0 is a valid
    # (slightly negative) Kelvin–Voigt factor for a residual evaluation
    plus = case_system(model, [{**c, "gamma": float(x)} for c, x in zip(cases, g + dg)],
                       device, torch.float64)[0]
    minus = case_system(model, [{**c, "gamma": float(x)} for c, x in zip(cases, g - dg)],
                        device, torch.float64)[0]
    return plus, minus, dg
