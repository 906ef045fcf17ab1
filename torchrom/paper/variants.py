"""The other heavy Goland wing variant beside the study's (issue 15): Table 2, flutter, Table 3
and the findings of the same LCO sweep.

``torchrom paper`` studies the default wing (:data:`torchrom.fe.goland.DEFAULT_VARIANT`, the
model-updated one) and, for the report's side-by-side section, builds the pipeline of each
variant in :data:`COMPARISON_VARIANTS` (its own cached model folder), runs the same LCO sweep on
it and evaluates the same findings, so a reader sees what the model updating changed.
Glue over :mod:`.pipeline`, :mod:`.findings` and the study's cached sweep.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..fe.goland import GOLAND_VARIANTS
from ..study import figures
from ..study.models import alpha_gamma_table
from . import findings as fnd
from .pipeline import GolandPipeline, goland_pipeline

#: the variants shown beside the study's own (every other one)
COMPARISON_VARIANTS = GOLAND_VARIANTS


def variant_study(variant: str, base: GolandPipeline, folder: Path, gammas, sweep: Callable,
                  q4_of: Callable, *, force: bool, log: Callable[[str], None],
                  marches_time: bool = True) -> dict[str, Any]:
    """The pipeline of ``variant`` (into ``folder``), its α(γ), the LCO sweep
    ``sweep(model, name) -> (table, histories, info)`` and the findings (JSON-ready;
    ``marches_time``: the sweep marches in time, :func:`.findings.evaluate`)."""
    res = goland_pipeline(dataclasses.replace(base, variant=variant), folder, force=force,
                          log=log)
    model, fl = res.model, res.flutter
    log(f"variant '{variant}': flutter (state space) {fl['state_space']['altitude']:,.0f} ft, "
        f"{fl['state_space']['frequency_hz']:.3f} Hz")
    alpha_gamma = alpha_gamma_table(model, gammas)
    table, histories, info = sweep(model, f"lco_{variant}")
    kinds = [r.get("kind") for r in fl["table2"]]
    q4 = q4_of(fl["table2"])
    table = table.copy()
    found = fnd.evaluate(table, histories, alpha_gamma, float(fl["state_space"]["altitude"]),
                         kinds, q4_column=figures.ratio_column(table, q4["mode"]),
                         q4_note=q4["note"], marches_time=marches_time)
    return {"variant": variant, "flutter": fl,
            "lco": {k: v for k, v in info.items() if k != "reused_files"},
            "findings": [f.as_dict() for f in found]}
