"""Case grids from TOML, sweeps through the batched integrator, result tables and figures.

- :mod:`.grid`: ``[cases]`` tables -> case lists (product / zip / explicit), ``case_id``.
- :mod:`.config`: validated sweep configurations, from a TOML file (:func:`load_sweep_config`)
  or a dict of the same tables (:func:`config_from_dict`, e.g. in a notebook).
- :mod:`.sweep`: :func:`run_sweep` (chunked, resumable; in-process or on Dask workers);
  :func:`sweep_table` (a configuration, dict or file in, the results table out).
- :mod:`.runner`: chunks, part files, executors (:func:`open_executor`, :func:`run_cases`).
- :mod:`.sampling`: seeded uncertainty sampling of case parameters, amplitude distributions.
- :mod:`.calibrate`: :func:`calibrate_gamma` (γ from a target LCO amplitude).
- :mod:`.bifurcation`: :func:`bifurcation_sweep` (supercritical or subcritical LCOs).
- :mod:`.table`: one row per case, parquet + CSV written atomically.
- :mod:`.plots`: result figures.
"""

from .bifurcation import bifurcation_sweep
from .calibrate import calibrate_gamma
from .config import SweepConfig, config_from_dict, load_sweep_config
from .grid import case_id, config_hash, expand_cases
from .plots import parameter_plot
from .runner import open_executor, run_cases
from .sweep import case_evaluator, run_sweep, sweep_table
from .table import result_rows, write_table

__all__ = [
    "SweepConfig",
    "load_sweep_config",
    "config_from_dict",
    "expand_cases",
    "case_id",
    "config_hash",
    "run_sweep",
    "sweep_table",
    "case_evaluator",
    "run_cases",
    "open_executor",
    "calibrate_gamma",
    "bifurcation_sweep",
    "result_rows",
    "write_table",
    "parameter_plot",
]
