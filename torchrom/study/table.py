"""Result tables: one row per case, written as parquet and CSV (pandas/pyarrow), atomically.

Columns (DESIGN "Files"; those that apply to the sweep at hand):
``case_id`` (stable hash of the case parameters), the case parameters (``alpha`` 1/s,
``gamma`` s, ``stiffness_nl``, ``damping_nl``, ... plus any other swept parameter), ``status``
(lco, decay, diverged, unconverged, failed), ``amplitude`` (half peak-to-peak of the first
output over the converged window, output units; 0 for a decay, NaN for diverged, unconverged and
failed cases), ``amplitude_pct_span`` (when the model knows its span), ``frequency_hz`` (NaN
unless lco), ``last_amplitude`` / ``last_amplitude_pct_span`` / ``last_frequency_hz`` (the same
measured on the last cycles whatever the status: the value when the case stopped),
``ratio_q1_q2`` / ``ratio_q1_q4`` (generalized-coordinate amplitude
ratios, when tracked), ``steps``, ``t_end`` (simulated time reached, s), ``amplitude_<output>``
for every tracked output, ``amplitude_change`` (relative change over the last cycle),
``solver_error`` (estimated relative acceleration error of the nonlinear iterations),
the method's own columns (harmonic balance: ``method``, ``harmonics``, ``hb_residual``,
``truncation``, ``harmonic_distortion``, ``stable``, ``floquet_multiplier``; see
:mod:`torchrom.periodic.method`), ``config_hash`` and ``version``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from .._version import __version__
from ..io import atomic_path, check_can_write
from ..sim import SimulationResult
from ..sim.metrics import amplitude_ratio
from .grid import case_id

#: DESIGN parameter columns, in this order when present
PARAMETER_ORDER = ("altitude_ft", "altitude_m", "mach", "velocity", "dynamic_pressure",
                   "density", "alpha", "gamma", "stiffness_nl", "damping_nl")


#: extra columns of text with gaps (the certificate's kind: "fourier", "shooting", none)
TEXT_COLUMNS = frozenset({"certificate"})


def result_rows(cases: Sequence[Mapping[str, Any]], result: SimulationResult, *,
                config_hash: str, span: float | None = None,
                extra: Sequence[Mapping[str, Any]] | None = None,
                case_ids: Sequence[str] | None = None,
                precision: str | None = None) -> pd.DataFrame:
    """The table rows of one simulated batch: ``cases[i]`` are the parameters of result case i;
    ``extra[i]`` adds derived columns (e.g. velocity, density) without entering the case_id;
    ``case_ids`` are the ids to write (default: the hash of each case's parameters alone);
    ``precision`` (e.g. "float64") fills a ``precision`` column."""
    names = result.output_names
    amp = result.amplitude
    ids = list(case_ids) if case_ids is not None else [case_id(c) for c in cases]
    cols: dict[str, Any] = {"case_id": ids}
    keys = list(dict.fromkeys(k for c in cases for k in c))
    if extra:
        keys += [k for k in dict.fromkeys(k for e in extra for k in e) if k not in keys]
    ordered = [k for k in PARAMETER_ORDER if k in keys] + [k for k in keys
                                                           if k not in PARAMETER_ORDER]
    for k in ordered:
        cols[k] = [({**c, **(extra[i] if extra else {})}).get(k, np.nan)
                   for i, c in enumerate(cases)]
    cols["status"] = list(result.status)
    cols["amplitude"] = amp[:, 0]
    if span:
        cols["amplitude_pct_span"] = 100.0 * amp[:, 0] / span
    cols["frequency_hz"] = result.frequency_hz
    if result.last_amplitude is not None:
        # the value when the case stopped, whatever its status (amplitude is NaN unless lco)
        cols["last_amplitude"] = result.last_amplitude[:, 0]
        if span:
            cols["last_amplitude_pct_span"] = 100.0 * result.last_amplitude[:, 0] / span
        cols["last_frequency_hz"] = result.last_frequency_hz
    for a, b in (("q1", "q2"), ("q1", "q4")):
        if a in names and b in names:
            cols[f"ratio_{a}_{b}"] = amplitude_ratio(amp[:, names.index(a)],
                                                     amp[:, names.index(b)])
    cols["steps"] = result.steps
    cols["t_end"] = result.time
    for j, name in enumerate(names):
        cols[f"amplitude_{name}"] = amp[:, j]
    cols["amplitude_change"] = result.amplitude_change
    cols["solver_error"] = result.solver_error
    for name, values in result.extra.items():
        values = np.asarray(values)
        if name == "stable":  # True / False / unknown (NaN or None)
            values = pd.array([None if v is None or (isinstance(v, float) and np.isnan(v))
                               else bool(v) for v in values], dtype="boolean")
        elif name in TEXT_COLUMNS:
            # text with gaps: pandas' string dtype, the dtype a parquet part is read back
            # with, so resumed and fresh tables concatenate alike
            values = pd.array([None if v is None else str(v) for v in values], dtype="str")
        cols[name] = values
    if precision is not None:
        cols["precision"] = precision
    cols["config_hash"] = config_hash
    cols["version"] = __version__
    df = pd.DataFrame(cols)
    for k in ("stiffness_nl", "damping_nl"):
        if k in df:
            df[k] = df[k].astype(float)
    return df


def table_paths(out_dir, stem: str = "results") -> dict[str, Path]:
    out = Path(out_dir)
    return {"parquet": out / f"{stem}.parquet", "csv": out / f"{stem}.csv"}


def write_table(df: pd.DataFrame, out_dir, *, force: bool = False,
                stem: str = "results") -> dict[str, Path]:
    """Write ``<stem>.parquet`` and ``<stem>.csv`` into ``out_dir`` atomically; refuse to replace
    existing files unless ``force``."""
    paths = table_paths(out_dir, stem)
    for p in paths.values():
        check_can_write(p, force, "results table")
    with atomic_path(paths["parquet"]) as tmp:
        df.to_parquet(tmp, index=False)
    with atomic_path(paths["csv"]) as tmp:
        df.to_csv(tmp, index=False)
    return paths


def write_histories(frames: Sequence[pd.DataFrame], path) -> Path:
    """Write time-history frames (case_id, t, outputs...) as one parquet file, atomically."""
    path = Path(path)
    with atomic_path(path) as tmp:
        pd.concat(list(frames), ignore_index=True).to_parquet(tmp, index=False)
    return path
