"""Writing a benchmark's results: ``<name>.json`` (meta + sections) and a flat ``<name>.csv``."""

from __future__ import annotations

import json
import os
import platform
import time
from pathlib import Path

import torch


def machine_meta(**meta) -> dict:
    """The machine, torch, date and 1/5/15-min load average, plus ``meta``."""
    return {"machine": platform.processor() or platform.machine(), "cpus": os.cpu_count(),
            "torch": torch.__version__, "date": time.strftime("%Y-%m-%d %H:%M"),
            "load_average": os.getloadavg(), **meta}


def least_of(f, n: int = 5) -> float:
    """The least wall time (s) of ``n`` calls of ``f`` after one warm-up call."""
    f()
    times = []
    for _ in range(n):
        t = time.perf_counter()
        f()
        times.append(time.perf_counter() - t)
    return min(times)


def write_results(out: Path, name: str, throughput: list[dict], runs: list[dict],
                  runs_key: str, runs_kind: str, **meta) -> None:
    """JSON with the machine, torch, date and load average plus ``meta``; CSV with the
    throughput rows and the ``runs`` rows (kind ``runs_kind`` unless a row names its own;
    without their nested 'scipy_runs' lists)."""
    import pandas as pd

    out.mkdir(parents=True, exist_ok=True)
    meta = machine_meta(**meta)
    (out / f"{name}.json").write_text(json.dumps(
        {"meta": meta, "throughput": throughput, runs_key: runs}, indent=2, default=float)
        + "\n")
    flat = throughput + [{"kind": runs_kind} | {k: v for k, v in r.items() if k != "scipy_runs"}
                         for r in runs]
    pd.DataFrame(flat).to_csv(out / f"{name}.csv", index=False)
    print(f"wrote {out / f'{name}.json'} and .csv")
