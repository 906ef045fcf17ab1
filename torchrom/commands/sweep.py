"""``torchrom sweep CONFIG.toml --out DIR``: run a TOML-defined grid of LCO simulations.

Writes ``DIR/results.parquet`` and ``DIR/results.csv`` (one row per case; columns in
:mod:`torchrom.study.table`), ``DIR/<y>_vs_<x>.png`` (the ``[plot]`` figure) and, when the
configuration asks for them (``[history]``), ``DIR/histories.parquet`` (case_id, t and one column
per output) and, by harmonic balance, ``DIR/orbits.parquet`` (each LCO's Fourier coefficients of
q: case_id, omega, k, q1..qn, :func:`torchrom.study.cases.orbit_table`; ``torchrom export`` and
``plot`` draw the wing's motion from it). With
``--json FILE`` the same rows are written as a JSON list of records (same keys and units as the
table columns; NaN as null). A configuration that samples parameters from distributions
(:mod:`torchrom.study.sampling`) also gets ``DIR/amplitude_distribution.{parquet,csv,png}``:
per group of the other swept parameters (e.g. altitude) the counts, P(LCO), mean, standard
deviation and 5/50/95 % quantiles of the amplitude, and its histogram and CDF.

Cases run in chunks, in-process by default, on a local Dask cluster with ``--workers N`` or on
an existing one with ``--scheduler ADDR`` (:mod:`torchrom.study.runner`). Finished chunks are
kept in ``DIR/parts`` as they complete, so an interrupted or crashed sweep is resumed by running
the same command again (only the missing cases are computed). A folder holding results of a
different configuration or model, or results it did not write, or a table or figure edited since
this sweep wrote it (``DIR/parts/outputs.json`` records their SHA-256), is refused unless
``--force``. The folder is locked for the run: a second sweep on it exits with status 2, naming
the first one's PID (:mod:`torchrom.locks`).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    add_study_options,
    check_outputs,
    load_study,
    maybe_write_json,
    thread_count,
    write_figure,
)

NAME = "sweep"
DISTRIBUTION = "amplitude_distribution"
HELP = "run a TOML-defined grid of batched LCO simulations; write a results table and a figure"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("config", type=Path, help="sweep configuration (TOML)")
    add_study_options(parser, "results.parquet, results.csv, figures, parts/")
    parser.add_argument("--compile", action="store_true",
                        help="compile the time step with torch.compile (pays off for long runs)")
    parser.add_argument("--threads", type=thread_count, default=None,
                        help="torch intra-op threads, at most the number of cores (default: "
                             "automatic)")


def _write_distribution(table, cfg, sampled: list[str], paths: dict[str, Path]) -> list[Path]:
    """The amplitude distribution of an uncertainty-sampling sweep: summary table and figure
    per group of the non-sampled swept parameters (e.g. per altitude)."""
    from ..study.plots import distribution_plot
    from ..study.sampling import amplitude_distribution, group_parameters
    from ..study.table import write_table

    by = group_parameters(cfg.cases, sampled)
    summary = amplitude_distribution(table, by)
    written = write_table(summary, paths["parquet"].parent, force=True, stem=DISTRIBUTION)
    figure = write_figure(distribution_plot, table, paths["figure"], by=by, force=True,
                          title=f"{cfg.title}: {', '.join(sampled)} sampled")
    print(f"amplitude distribution ({', '.join(sampled)} sampled; decay counts as 0):")
    print(summary.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    return [*written.values(), *([figure] if figure else [None])]


def _check_same_cases(table_path: Path, cfg, run: dict) -> None:
    """A finished table of this run is replaced only by the same case grid (else --force)."""
    if not table_path.exists():
        return
    import pandas as pd

    from ..errors import InputError
    from ..study.grid import case_id

    try:
        old = set(pd.read_parquet(table_path, columns=["case_id"])["case_id"])
    except Exception:  # noqa: BLE001 - an unreadable table is not ours to replace
        old = None
    new = {case_id(c, context=run["run_key"]) for c in cfg.cases}
    if old != new:
        raise InputError(f"{table_path} holds the results of another case grid "
                         f"({len(old or ())} cases, {len(new)} now); pass --force to replace "
                         f"it or choose another output folder")


def run(args: argparse.Namespace) -> int:
    # heavy imports here, not at module level: `torchrom --help` must stay fast

    from ..locks import folder_lock
    from ..study.config import with_overrides
    from ..study.sweep import checked_model

    device, dtype, cfg = load_study(args)
    cfg = with_overrides(cfg, compile=True if args.compile else None, threads=args.threads)
    # the checks of torchrom.study.sweep_table too (--threads with the configuration's own
    # bounds); the damping note is what the flutter lines and "matched" α use
    model = checked_model(cfg, device, dtype, note=lambda text: print(f"  {text}"))
    # one run per folder: a second sweep on it refuses (exit 2, naming this one's PID)
    with folder_lock(args.out, "torchrom sweep"):
        return _run_in(Path(args.out), args, cfg, model, device, dtype)


def _run_in(out: Path, args: argparse.Namespace, cfg, model, device, dtype) -> int:
    from ..errors import InputError
    from ..study.plots import parameter_plot
    from ..study.runner import PartStore, open_executor
    from ..study.sampling import sampled_parameters
    from ..study.sweep import run_description, run_sweep
    from ..study.table import table_paths, write_histories, write_table

    # outputs of this very run (same run key) may be rewritten: that is how a sweep resumes
    store = PartStore(out, run_description(cfg, model, dtype))
    resumable = store.check(args.force)
    paths = table_paths(out)
    figure = out / f"{cfg.plot.y}_vs_{cfg.plot.x}.png"
    hist_path = out / "histories.parquet"
    orbit_path = out / "orbits.parquet"
    sampled = sampled_parameters(cfg.raw.get("cases", {}))
    uq_paths = {**table_paths(out, DISTRIBUTION), "figure": out / f"{DISTRIBUTION}.png"}
    outputs = (*paths.values(), figure, *(uq_paths.values() if sampled else ()),
               *((hist_path,) if cfg.history else ()),
               *((orbit_path,) if cfg.solver.writes_orbits else ()))
    if resumable and not args.force:
        _check_same_cases(paths["parquet"], cfg, store.run)
        edited = store.edited_outputs(outputs)
        if edited:
            more = f" (and {len(edited) - 1} more)" if len(edited) > 1 else ""
            raise InputError(f"{edited[0]}{more}; pass --force to replace it or choose another "
                             f"output folder")
    check_outputs(args, outputs, may_replace=args.force or resumable)

    from ..progress import Progress, info

    with open_executor(args.workers, args.scheduler) as executor:
        how = cfg.solver.describe(cfg)
        info(f"torchrom sweep: {len(cfg.cases)} cases of '{cfg.title}' ({args.config}) on "
             f"{device}/{args.dtype}, {executor.description}, {how}")
        with Progress(len(cfg.cases), "cases done") as bar:
            def progress(done: int, total: int) -> None:
                bar.update_to(done)

            histories, orbits = [], []
            # an interrupt or failure is reported by the runner with the cases its parts keep
            table, timing = run_sweep(cfg, model=model, device=device, dtype=dtype,
                                      progress=progress, out=out, force=args.force,
                                      executor=executor, chunk_size=args.chunk_size,
                                      log=bar.write, on_history=histories.append,
                                      on_orbits=orbits.append)

    written = write_table(table, out, force=True)
    if histories:
        written["histories"] = write_histories(histories, hist_path)
    if orbits:
        written["orbits"] = write_histories(orbits, orbit_path)
    drawn = write_figure(parameter_plot, table, figure, x=cfg.plot.x, y=cfg.plot.y,
                         hue=cfg.plot.hue, title=cfg.title, force=True)
    extra = _write_distribution(table, cfg, sampled, uq_paths) if sampled else []
    figures_ok = drawn is not None and None not in extra
    extra = [p for p in extra if p is not None]
    # what this run wrote, hashed: a rerun replaces these, not a file edited since
    store.record_outputs([*written.values(), *([figure] if drawn else []), *extra])
    counts = table["status"].value_counts().to_dict()
    print("status: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    from ..study.cases import flutter_speed_lines

    for line in flutter_speed_lines(model, cfg.cases):  # wind-tunnel sweeps: where LCOs begin
        print(line)
    confirmed = (int((table["precision"] == "float64 (confirmed)").sum())
                 if "precision" in table else 0)
    if confirmed:
        print(f"precision: {confirmed} float32 case(s) above the solver tolerance rerun in "
              f"float64 (column precision)")
    chunks = f"{timing['chunks']} chunk{'' if timing['chunks'] == 1 else 's'}"
    print(f"cases: {timing['computed']} computed in {chunks}, "
          f"{timing['reused']} reused from {out / 'parts'}")
    print(f"time: {timing['elapsed_s']:.1f} s elapsed, {cfg.solver.cost_line(timing)}")
    for p in (*written.values(), *([figure] if drawn else []), *extra):
        print(f"wrote {p}")
    maybe_write_json(args, table.to_dict(orient="records"))
    return 0 if figures_ok else 1
