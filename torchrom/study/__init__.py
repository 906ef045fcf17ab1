"""Case grids from TOML, sweeps through the batched integrator, result tables and figures.

- :mod:`.grid`: ``[cases]`` tables -> case lists (product / zip / explicit), ``case_id``.
- :mod:`.config`: validated sweep configurations (:func:`load_sweep_config`).
- :mod:`.sweep`: :func:`run_sweep` (in-process, chunked).
- :mod:`.table`: one row per case, parquet + CSV written atomically.
- :mod:`.plots`: result figures.
"""

from .config import SweepConfig, load_sweep_config
from .grid import case_id, config_hash, expand_cases
from .plots import parameter_plot
from .sweep import run_sweep
from .table import result_rows, write_table

__all__ = [
    "SweepConfig",
    "load_sweep_config",
    "expand_cases",
    "case_id",
    "config_hash",
    "run_sweep",
    "result_rows",
    "write_table",
    "parameter_plot",
]
