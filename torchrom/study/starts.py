"""Initial states of a sweep's cases: the start kinds of ``[initial] start`` (written here).

- ``small`` (default, the paper's start): the ``[initial]`` pattern q0 with the dual coordinates
  on the ROM's static manifold (:func:`torchrom.sim.initial.static_manifold`); every case on its
  own, all in one batch, so a result depends on its own parameters only.
- ``neighbour``: cases ordered along one parameter (``along``) into lines; each case starts from
  the previous case's LCO state, scaled by λ ∈ [½, 2] toward the amplitude extrapolated from the
  last two (linear coordinates by λ, dual by λ²); the lines run in waves.
- ``hb``: every case starts on its harmonic-balance orbit (:func:`torchrom.periodic.solve_orbits`),
  so the time integration only confirms it; small where there is no orbit.

A supercritical LCO does not depend on the start (tested); for a subcritical system the start
decides the attractor, and ``neighbour`` follows the LCO branch (hysteresis) where ``small``
finds the rest position. What each start costs is measured by ``benchmarks/bench_lco.py``. A
start kind is one function ``start(context) -> InitialState`` in :data:`START_KINDS`, with a flag
saying whether it continues from finished cases (runs in waves).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import torch

from ..errors import InputError
from ..rom import NonlinearROM
from ..sim import CaseSystem, SimulationResult
from ..sim.initial import dual_indices, static_manifold
from ..sim.result import gather_results
from .cases import initial_displacement, initial_velocity

#: clip of the amplitude-extrapolation scale of a neighbour start
SCALE_RANGE = (0.5, 2.0)


@dataclass
class Finished:
    """A case already integrated in this chunk: its parameter along the line and final state."""

    x: float
    status: str
    amplitude: float
    q: np.ndarray
    v: np.ndarray
    xi: np.ndarray | None


@dataclass
class StartContext:
    """What a start kind sees: the cases to start (one wave) and, per case, the finished cases
    of its line nearest first (empty for the first case of a line or a non-sequential start)."""

    rom: NonlinearROM
    system: CaseSystem
    cases: list[dict[str, Any]]
    initial: dict[str, Any]
    along: str | None = None
    previous: list[list[Finished]] = field(default_factory=list)


@dataclass
class InitialState:
    q: np.ndarray
    v: np.ndarray
    xi: np.ndarray | None = None


# ----------------------------------------------------------------------------------------------
# start kinds
# ----------------------------------------------------------------------------------------------
def small_start(ctx: StartContext) -> InitialState:
    """The ``[initial]`` pattern, dual coordinates on the static manifold (module docstring)."""
    q = initial_displacement(ctx.rom, ctx.initial, ctx.cases)
    if ctx.initial.get("static_manifold", True):
        q, _ = static_manifold(ctx.system, q)
    return InitialState(q, initial_velocity(ctx.rom, ctx.initial, len(ctx.cases)))


def neighbour_scale(previous: Sequence[Finished], x: float) -> float:
    """λ: the linear extrapolation of the last two LCO amplitudes of a line to ``x`` over the
    nearest one's amplitude (1 with fewer than two), clipped to :data:`SCALE_RANGE`."""
    lco = [p for p in previous if p.status == "lco"][:2]
    if len(lco) < 2 or lco[0].x == lco[1].x or not lco[0].amplitude > 0:
        return 1.0
    a, b = lco
    predicted = a.amplitude + (a.amplitude - b.amplitude) * (x - a.x) / (a.x - b.x)
    return float(np.clip(predicted / a.amplitude, *SCALE_RANGE))


def neighbour_start(ctx: StartContext) -> InitialState:
    """The previous LCO of each case's line, scaled toward its predicted amplitude; a small
    start where the line has none (module docstring)."""
    start = small_start(ctx)
    dual = dual_indices(ctx.rom)
    linear = [i for i in range(ctx.rom.n) if i not in dual]
    na = ctx.system.n_lag
    xi = np.zeros((len(ctx.cases), na))
    for k, (case, prev) in enumerate(zip(ctx.cases, ctx.previous)):
        if not prev or prev[0].status != "lco":
            continue
        lam = neighbour_scale(prev, float(case.get(ctx.along, np.nan)))
        near = prev[0]
        for target, source in ((start.q, near.q), (start.v, near.v)):
            target[k, linear] = lam * source[linear]
            target[k, dual] = lam * lam * source[dual]
        if near.xi is not None and na:
            xi[k] = lam * near.xi
    if ctx.initial.get("static_manifold", True):
        # the neighbour's dual coordinates carry its own stiff-mode motion; their static values
        # for the scaled linear coordinates start the case without exciting them
        start.q, _ = static_manifold(ctx.system, start.q)
    return InitialState(start.q, start.v, xi)


def hb_start(ctx: StartContext) -> InitialState:
    """Each case on its harmonic-balance orbit; a small start where there is none (module
    docstring)."""
    from ..periodic import HBOptions, solve_orbits
    from ..periodic.solve import orbit_state
    from .cases import neighbour_chains

    start = small_start(ctx)
    if not ctx.rom.outputs:
        raise InputError("[initial] start = \"hb\": the ROM has no named output to measure "
                         "the orbits' phase and amplitude on")
    row = np.asarray(next(iter(ctx.rom.outputs.values())), dtype=float).reshape(-1)
    system = ctx.system.to(dtype=torch.float64)
    chains, positions = neighbour_chains(ctx.cases)
    orb = solve_orbits(system, row, HBOptions(), chains=chains, positions=positions)
    on = orb.status == "lco"
    xi = np.zeros((len(ctx.cases), ctx.system.n_lag))
    if on.any():
        idx = torch.as_tensor(np.flatnonzero(on))
        q, v, x = orbit_state(system.select(idx), orb.X[idx], orb.omega[idx])
        start.q[on], start.v[on], xi[on] = q, v, x
    return InitialState(start.q, start.v, xi)


@dataclass(frozen=True)
class StartKind:
    """A start: ``initial(context)`` and whether it continues from finished cases (waves)."""

    initial: Callable[[StartContext], InitialState]
    sequential: bool


START_KINDS: dict[str, StartKind] = {
    "small": StartKind(small_start, sequential=False),
    "neighbour": StartKind(neighbour_start, sequential=True),
    "hb": StartKind(hb_start, sequential=False),
}
#: the start of a sweep without ``[initial] start`` (see the module docstring)
DEFAULT_START = "small"


def check_start(initial: dict[str, Any], parameters: Sequence[str], where: str = "[initial]"
                ) -> None:
    """InputError naming the key unless ``start``, ``along`` and ``static_manifold`` are valid."""
    start = initial.get("start", DEFAULT_START)
    if start not in START_KINDS:
        raise InputError(f"{where} start: expected one of {sorted(START_KINDS)}, got {start!r}")
    along = initial.get("along")
    if along is not None and along not in parameters:
        raise InputError(f"{where} along: expected a case parameter {list(parameters)}, got "
                         f"{along!r}")
    sm = initial.get("static_manifold", True)
    if not isinstance(sm, bool):
        raise InputError(f"{where} static_manifold: expected true or false, got {sm!r}")


# ----------------------------------------------------------------------------------------------
# lines and waves
# ----------------------------------------------------------------------------------------------
def default_along(cases: Sequence[dict[str, Any]]) -> str | None:
    """The numeric parameter with the most distinct values (the first such in case order)."""
    best, count = None, 1
    for case in cases:
        for name in case:
            values = {c.get(name) for c in cases
                      if isinstance(c.get(name), (int, float)) and not isinstance(c.get(name),
                                                                                  bool)}
            if len(values) > count:
                best, count = name, len(values)
    return best


def sweep_lines(cases: Sequence[dict[str, Any]], along: str | None) -> list[list[int]]:
    """Case indices grouped by every parameter but ``along`` and ordered by ``along``
    (ascending); lines in order of their first case."""
    if along is None:
        return [[i] for i in range(len(cases))]
    groups: dict[str, list[int]] = {}
    for i, case in enumerate(cases):
        value = case.get(along)
        numeric = isinstance(value, (int, float)) and not isinstance(value, bool)
        key = repr(sorted((k, repr(v)) for k, v in case.items() if k != along)) if numeric \
            else f"#{i}"
        groups.setdefault(key, []).append(i)
    return [sorted(line, key=lambda i: float(cases[i][along])) if len(line) > 1 else line
            for line in groups.values()]


def march(system: CaseSystem, rom: NonlinearROM, cases: list[dict[str, Any]],
          initial: dict[str, Any], run: Callable[..., SimulationResult]) -> SimulationResult:
    """Integrate ``cases`` from the starts of ``initial['start']``: one batched
    ``run(system, q0, v0, xi0, index)`` for a non-sequential start, one per wave otherwise
    (``index``: the cases' positions in ``cases``); the results in case order."""
    kind = START_KINDS[initial.get("start", DEFAULT_START)]
    along = initial.get("along") or default_along(cases)
    if not kind.sequential:
        ctx = StartContext(rom, system, cases, initial, along, [[] for _ in cases])
        st = kind.initial(ctx)
        return run(system, st.q, st.v, st.xi, np.arange(len(cases)))
    lines = sweep_lines(cases, along)
    finished: dict[int, Finished] = {}
    parts = []
    for k in range(max(len(line) for line in lines)):
        wave = [line[k] for line in lines if len(line) > k]
        previous = [[finished[j] for j in reversed(line[:k])]
                    for line in lines if len(line) > k]
        sub = system.select(wave)
        wave_cases = [cases[i] for i in wave]
        st = kind.initial(StartContext(rom, sub, wave_cases, initial, along, previous))
        res = run(sub, st.q, st.v, st.xi, np.asarray(wave))
        for j, i in enumerate(wave):
            finished[i] = Finished(float(cases[i].get(along, np.nan)) if along else np.nan,
                                   str(res.status[j]), float(res.amplitude[j, 0]),
                                   res.q[j], res.v[j], None if res.xi is None else res.xi[j])
        parts.append((np.asarray(wave), res))
    return gather_results(parts, len(cases))
