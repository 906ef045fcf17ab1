"""Run a sweep: cases in chunks through the batched integrator, one table row each.

A chunk of cases is integrated together (one :class:`~torchrom.sim.CaseSystem`, built by
:func:`torchrom.study.cases.case_system` for a structural or an aeroelastic model) by a
:class:`SweepTask`; :mod:`.runner` splits the cases into chunks, runs them in-process or on
Dask workers and, given an output folder, stores finished chunks as resumable part files.
Case ids hash each case's parameters together with the run key (:func:`run_description`).
Pandas for the table.
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import torch

from ..errors import InputError
from ..periodic.certify import certify
from ..periodic.newton import single_thread
from ..rom import NonlinearROM
from ..sim import output_matrix
from .cases import case_system, chain_order, history_table, orbit_table
from .cases import initial_displacement as initial_displacement  # noqa: F401 - public name
from .cases import initial_velocity as initial_velocity  # noqa: F401 - public name
from .cases import structural_system as structural_system  # noqa: F401 - public name
from .config import SweepConfig
from .grid import case_id, config_hash
from .models import AeroelasticModel, model_rom
from .runner import ChunkResult, PartStore, run_cases
from .solvers import ChunkRun
from .table import result_rows
from .units import sweep_units

#: statuses of a float32 case that a float64 run confirms or corrects (the solver's error
#: estimate above the tolerance, or a non-finite state)
CONFIRM_STATUSES = ("unconverged", "failed")


@dataclass
class SweepTask:
    """One chunk of a sweep (picklable: what a Dask worker receives once).

    ``model``: a :class:`~torchrom.rom.NonlinearROM` (structural sweep) or an
    :class:`~torchrom.study.models.AeroelasticModel`. Called as ``task(cases, case_ids,
    progress)`` -> :class:`~torchrom.study.runner.ChunkResult` with one table row per case and
    the time histories of the cases that ``[history]`` selects (see :mod:`torchrom.study.runner`).
    """

    cfg: SweepConfig
    model: Any
    device: str = "cpu"
    dtype: torch.dtype = torch.float64
    #: in float32, rerun the borderline cases (:data:`CONFIRM_STATUSES`) in float64
    confirm_float64: bool = True

    def __call__(self, cases: list[dict[str, Any]], case_ids: list[str],
                 progress: Callable[[int, int], None] | None = None) -> ChunkResult:
        rows, hist, wall, steps, orbits, cert = self._run(cases, case_ids, self.dtype, progress)
        if self.dtype != torch.float32 or not self.confirm_float64:
            return ChunkResult(rows, wall, steps, hist, orbits, certificate_s=cert)
        redo = [i for i, s in enumerate(rows["status"]) if s in CONFIRM_STATUSES]
        if redo:
            # the solver's own error estimate says float32 was not enough for these cases:
            # their rows (and histories) are replaced by a float64 run of the same cases
            ids = [case_ids[i] for i in redo]
            rows64, hist64, wall64, steps64, orbits64, cert64 = self._run(
                [cases[i] for i in redo], ids, torch.float64)
            rows64["precision"] = "float64 (confirmed)"
            rows64.index = pd.Index(redo)
            rows = pd.concat([rows.drop(index=redo), rows64.reindex(columns=rows.columns)]
                             ).sort_index().reset_index(drop=True)
            if hist is not None and hist64 is not None:
                hist = pd.concat([hist[~hist["case_id"].isin(ids)], hist64],
                                 ignore_index=True)
            if orbits is not None and orbits64 is not None:
                orbits = pd.concat([orbits[~orbits["case_id"].isin(ids)], orbits64],
                                   ignore_index=True)
            wall, steps, cert = wall + wall64, steps + steps64, cert + cert64
        return ChunkResult(rows, wall, steps, hist, orbits, certificate_s=cert)

    def _run(self, cases, case_ids, dtype, progress=None):
        cfg, rom = self.cfg, model_rom(self.model)
        system, extra = case_system(self.model, cases, torch.device(self.device), dtype)
        keep = cfg.history.indices(cases) if cfg.history is not None else []
        solver = cfg.solver
        res = solver.run(ChunkRun(cfg, self.model, rom, system, cases, keep,
                                  torch.device(self.device), progress))
        # every LCO row carries its certificate, whatever the method (one shooting evaluation)
        _, C = output_matrix(rom, cfg.outputs)
        t0 = time.perf_counter()
        # on one intra-op thread, as the integrator runs these batches ("auto"): the
        # certificate's thousands of small per-step kernels gain nothing from a second thread,
        # and on a loaded machine each parallel region waits for it (the quick study's
        # 19-LCO certificate took 11 min at load 13 with two threads)
        with single_thread():
            res = certify(system, res, C, cfg.lco.decision_outputs[0],
                          solver.certificate(cfg), cfg.integrator.dt)
        # the solver's time includes its certificate (a shooting solver's finish is there),
        # also counted apart: what a cheaper certificate would save
        cert = time.perf_counter() - t0
        res = dataclasses.replace(res, wall_time_s=res.wall_time_s + cert)
        if progress is not None:  # every case integrated (also those run to t_end undecided)
            progress(len(cases), len(cases))
        span = getattr(self.model, "span", None) or rom.metadata.get("span")
        rows = result_rows(cases, res, config_hash=cfg.hash, span=span, case_ids=case_ids,
                           extra=extra, precision=str(dtype).replace("torch.", ""))
        return (rows, history_table(res, case_ids) if keep else None, res.wall_time_s,
                res.case_steps, orbit_table(res, case_ids), cert)




def model_hash(model) -> str:
    """Content hash of a sweep model: the ROM's tensors, outputs and metadata, and for an
    aeroelastic model its aerodynamic data and flight-condition settings too."""
    rom = model_rom(model)
    info = {"tensors": rom.content_hash(), "metadata": rom.metadata}
    if isinstance(model, AeroelasticModel):
        info["aeroelastic"] = model.content_hash()
    return config_hash(info)


def run_description(cfg: SweepConfig, model, dtype=torch.float64,
                    context: str | None = None) -> dict[str, str]:
    """The run key of a sweep (a hash of the configuration without its case grid, the model
    (:func:`model_hash`), the precision and the caller's ``context``, e.g. settings it changed
    after loading the configuration) with its parts: what case ids and stored results depend
    on. Any change of the model gives new case ids."""
    info = {"config_hash": cfg.hash, "model_hash": model_hash(model),
            "dtype": str(dtype).replace("torch.", ""),
            **({"context": context} if context is not None else {})}
    return {"run_key": config_hash(info), **info, "title": cfg.title, "config": str(cfg.source)}


def run_sweep(cfg: SweepConfig, *, device=None, dtype=torch.float64,
              progress: Callable[[int, int], None] | None = None,
              rom: NonlinearROM | None = None, model=None,
              cases: list[dict[str, Any]] | None = None,
              out=None, force: bool = False, executor=None, chunk_size: int | None = None,
              log: Callable[[str], None] | None = None,
              on_history: Callable[[pd.DataFrame], None] | None = None,
              on_orbits: Callable[[pd.DataFrame], None] | None = None,
              context: str | None = None,
              ) -> tuple[pd.DataFrame, dict[str, float]]:
    """Integrate every case of ``cfg`` (or ``cases``, e.g. a calibration batch); returns
    (table, timing) with timing keys wall_time_s (Σ integration time), case_steps,
    us_per_case_step, elapsed_s, cases, reused, computed and chunks.

    ``out``: folder for resumable part files (:class:`~torchrom.study.runner.PartStore`; a
    folder of another configuration needs ``force``); ``executor``: from
    :func:`~torchrom.study.runner.open_executor` (default in-process); ``model``: the sweep's
    model (default ``cfg.build_model()``; ``rom`` is accepted for a structural model);
    ``on_history(frame)`` receives the time histories of the cases that ``[history]`` selects
    (see :func:`torchrom.study.cases.history_table`); ``on_orbits(frame)`` the harmonic balance
    orbits (:func:`torchrom.study.cases.orbit_table`); ``context``: see
    :func:`run_description`."""
    model = model if model is not None else (rom if rom is not None else cfg.build_model())
    cases = cfg.cases if cases is None else cases
    run = run_description(cfg, model, dtype, context)
    ids = [case_id(c, context=run["run_key"]) for c in cases]
    task = SweepTask(cfg, model, str(torch.device(device or "cpu")), dtype)
    store = PartStore(Path(out), run) if out is not None else None
    # a solver that chains neighbours gets chunks of neighbours (the cases in chain order;
    # the table comes back in case order)
    order = chain_order(cases) if cfg.solver.chains_neighbours else list(range(len(cases)))
    table, stats = run_cases(task, [cases[i] for i in order], [ids[i] for i in order],
                             batch_size=cfg.batch_size,
                             chunk_size=chunk_size or sweep_chunk_size(cfg), executor=executor,
                             store=store, force=force, progress=progress, log=log,
                             on_history=on_history, on_orbits=on_orbits)
    table = table.iloc[np.argsort(order)].reset_index(drop=True)
    table.attrs["units"] = sweep_units(list(table.columns), list(cfg.outputs or []),
                                       model_length_unit(model), flight_units(model))
    return table, stats.as_dict()


def sweep_chunk_size(cfg: SweepConfig) -> int | None:
    """Cases per chunk: ``[run] chunk_size``; else, for a solver that chains neighbours
    (harmonic balance, shooting), ``batch_size`` (one chunk where the cases fit); else None
    (:func:`~torchrom.study.runner.plan_chunks`' default
    of about 8 chunks). A harmonic-balance chunk costs nearly as much with few cases as with
    many — its time-integration seeds (:mod:`torchrom.periodic.seed`) are launch-bound at
    these batch widths — and a chunk boundary cuts the neighbour chains; a sweep for
    several workers sets ``chunk_size``."""
    if cfg.chunk_size is not None or not cfg.solver.chains_neighbours:
        return cfg.chunk_size
    return cfg.batch_size


def flight_units(model) -> dict[str, str]:
    """Units of the flight-condition columns (speed, velocity, density, dynamic_pressure) of
    a model with aerodynamics: its unit system's (empty for a structural model)."""
    units = getattr(model, "units", None)
    if units is None:
        return {}
    labels = units.labels()
    return {k: labels[k] for k in ("speed", "velocity", "density", "dynamic_pressure")}


def model_length_unit(model) -> str | None:
    """Length unit of a model's physical outputs (ROM metadata ``units``, else the model's unit
    system, else the aerodynamic data's, e.g. "ft, slug, s"), None when unknown."""
    rom = model_rom(model)
    units = rom.metadata.get("units")
    if isinstance(units, dict) and units.get("length"):
        return str(units["length"])
    system = getattr(model, "units", None)
    if system is not None:
        return system.length
    aero = getattr(model, "aero", None)
    text = getattr(aero, "metadata", {}).get("units") if aero is not None else None
    return str(text).split(",")[0].strip() or None if text else None


def case_evaluator(cfg: SweepConfig, model=None, *, device=None,
                   dtype=torch.float64, executor=None, chunk_size: int | None = None
                   ) -> Callable[[list[dict[str, Any]]], pd.DataFrame]:
    """``evaluate(cases) -> table``: the cases simulated with ``cfg``'s model and options, one
    row each in order (no part files) — what calibration and bifurcation sweeps iterate on.
    ``model``: a NonlinearROM or an AeroelasticModel (default ``cfg.build_model()``)."""
    model = model if model is not None else cfg.build_model()

    def evaluate(cases: list[dict[str, Any]]) -> pd.DataFrame:
        return run_sweep(cfg, model=model, cases=cases, device=device, dtype=dtype,
                         executor=executor, chunk_size=chunk_size)[0]

    return evaluate


def checked_model(cfg: SweepConfig, device=None, dtype=torch.float64,
                  note: Callable[[str], None] | None = None):
    """The sweep's model, built and checked before any case runs (what ``torchrom sweep`` and
    :func:`sweep_table` both do): the work bounds (:func:`~.config.check_work`), the initial
    state, outputs and flight conditions against the model (:func:`~.config.check_initial`) and
    the run's memory on ``device`` in ``dtype`` (:func:`~.config.check_memory`); InputError
    naming the key. ``note`` receives the model's damping note (what its flutter lines use)."""
    from .config import check_initial, check_memory, check_work

    check_work(cfg)
    model = cfg.build_model()
    if note is not None and getattr(model, "damping_note", None):
        note(model.damping_note)
    check_initial(cfg, model)
    check_memory(cfg, model, device, dtype)
    return model


def sweep_table(config, variant: str | None = None, *, device=None, dtype=torch.float64,
                out=None, force: bool = False, executor=None, progress: bool = True
                ) -> pd.DataFrame:
    """Run a sweep and return its results table, for a notebook or a script: one row per case
    (the columns of :mod:`.table`), ``table.attrs["units"]`` per column and
    ``table.attrs["timing"]`` (:func:`run_sweep`'s timing). ``config``: a :class:`SweepConfig`,
    a dict of its tables (:func:`~.config.config_from_dict`) or a TOML file
    (:func:`~.config.load_sweep_config`), with ``variant``; checked before any case runs as
    ``torchrom sweep`` checks it (:func:`checked_model`). ``out``: a folder for resumable part
    files, locked for the run (:func:`torchrom.locks.folder_lock`); ``executor``: see
    :func:`run_sweep`; ``progress``: a bar (:class:`torchrom.progress.Progress`, tqdm's notebook
    bar in a Jupyter kernel). Writes no table or figure (:func:`~.table.write_table`,
    :func:`~.plots.parameter_plot` do)."""
    from ..locks import folder_lock
    from ..progress import Progress, info
    from .config import config_from_dict, load_sweep_config

    if isinstance(config, SweepConfig):
        if variant is not None:
            raise InputError(f"{config.source}: variant {variant!r}: a SweepConfig is already "
                             f"validated; expected a dict or a TOML file with the variant")
        cfg = config
    elif isinstance(config, Mapping):
        cfg = config_from_dict(config, variant)
    else:
        cfg = load_sweep_config(config, variant)
    device = torch.device(device or "cpu")
    model = checked_model(cfg, device, dtype, note=info)
    with contextlib.ExitStack() as stack:
        if out is not None:
            stack.enter_context(folder_lock(out, "torchrom.study.sweep_table"))
        bar = stack.enter_context(Progress(len(cfg.cases), "cases done")) if progress else None
        table, timing = run_sweep(
            cfg, model=model, device=device, dtype=dtype, out=out, force=force,
            executor=executor, log=bar.write if bar else None,
            progress=(lambda done, total: bar.update_to(done)) if bar else None)
    table.attrs["timing"] = timing
    return table
