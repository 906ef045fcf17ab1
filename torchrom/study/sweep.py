"""Run a sweep: cases in batches through the batched integrator, one table row each.

In-process and chunked: ``batch_size`` cases are integrated together (one
:class:`~torchrom.sim.CaseSystem`, built by :func:`torchrom.study.cases.case_system` for a
structural or an aeroelastic model); chunks are independent, so a later scale-out (worker
processes or Dask) only has to distribute them. Hand-written; pandas for the table.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import pandas as pd
import torch

from ..errors import InputError
from ..rom import NonlinearROM
from ..sim import HistoryRequest
from .cases import case_system, history_table
from .cases import structural_system as structural_system  # noqa: F401 - public name
from .config import SweepConfig
from .grid import case_id
from .models import model_rom
from .table import result_rows


def initial_displacement(rom: NonlinearROM, initial: dict[str, Any],
                         cases: list[dict[str, Any]], where: str = "[initial]") -> np.ndarray:
    """(B, n) initial displacements: the ``[initial]`` pattern, scaled by each case's ``q0``."""
    n = rom.n
    q0 = initial.get("q0", 1e-3)
    mode = initial.get("mode", 1)
    if isinstance(mode, bool) or not isinstance(mode, int) or not 1 <= mode <= n:
        raise InputError(f"{where} mode: expected a basis function number 1..{n}, got {mode!r}")
    if isinstance(q0, list):
        base = np.asarray(q0, dtype=float)
        if base.shape != (n,):
            raise InputError(f"{where} q0: expected {n} values, got {len(q0)}")
        amp = 1.0
    elif isinstance(q0, (int, float)) and not isinstance(q0, bool):
        base = np.zeros(n)
        base[mode - 1] = 1.0
        amp = float(q0)
    else:
        raise InputError(f"{where} q0: expected a number or a list of {n} numbers, got {q0!r}")
    scale = np.array([float(c.get("q0", amp)) for c in cases])
    return scale[:, None] * base[None, :]


def initial_velocity(rom: NonlinearROM, initial: dict[str, Any], batch: int,
                     where: str = "[initial]") -> np.ndarray:
    v0 = initial.get("v0", 0.0)
    arr = np.asarray(v0, dtype=float)
    if arr.ndim == 0:
        arr = np.full(rom.n, float(arr))
    if arr.shape != (rom.n,):
        raise InputError(f"{where} v0: expected a number or {rom.n} values, got {v0!r}")
    return np.broadcast_to(arr, (batch, rom.n)).copy()


def run_sweep(cfg: SweepConfig, *, device=None, dtype=torch.float64,
              progress: Callable[[int, int], None] | None = None,
              rom: NonlinearROM | None = None, model=None,
              on_history: Callable[[pd.DataFrame], None] | None = None,
              ) -> tuple[pd.DataFrame, dict[str, float]]:
    """Integrate every case of ``cfg``; returns (table, timing) with timing keys wall_time_s,
    case_steps and us_per_case_step.

    ``model``: the sweep's model (default ``cfg.build_model()``; ``rom`` is accepted for a
    structural model); ``on_history(frame)`` receives the time histories of the cases that
    ``[history]`` selects (see :func:`torchrom.study.cases.history_table`), chunk by chunk.
    """
    model = model if model is not None else (rom if rom is not None else cfg.build_model())
    rom = model_rom(model)
    cases = cfg.cases
    span = getattr(model, "span", None) or rom.metadata.get("span")
    frames, wall, case_steps, done = [], 0.0, 0, 0
    for start in range(0, len(cases), cfg.batch_size):
        chunk = cases[start:start + cfg.batch_size]
        system, extra = case_system(model, chunk, device, dtype)
        q0 = initial_displacement(rom, cfg.initial, chunk)
        v0 = initial_velocity(rom, cfg.initial, len(chunk))
        keep = cfg.history.indices(chunk) if cfg.history is not None else []
        history = HistoryRequest(tuple(keep), cfg.history.every) if keep else None

        def report(k, total, base=done):
            if progress is not None:
                progress(base + k, len(cases))

        res = cfg.integrator.run(system, q0, v0, t_end=cfg.t_end, outputs=cfg.outputs,
                                 lco=cfg.lco, history=history, progress=report)
        frames.append(result_rows(chunk, res, config_hash=cfg.hash, span=span, extra=extra))
        if keep and on_history is not None:
            on_history(history_table(res, [case_id(c) for c in chunk]))
        wall += res.wall_time_s
        case_steps += res.case_steps
        done += len(chunk)
    table = pd.concat(frames, ignore_index=True)
    timing = {"wall_time_s": wall, "case_steps": case_steps,
              "us_per_case_step": 1e6 * wall / max(case_steps, 1)}
    return table, timing
