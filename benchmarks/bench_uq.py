"""Benchmark: the Goland uncertainty study (``configs/goland_uq_hb.toml``) as a user runs it.

    PYTHONPATH=. python benchmarks/bench_uq.py [--samples N ...] [--workers W]

For each ``--samples`` count (default 1000) the configuration is copied with ``samples = N``
(same seed, same Latin hypercube) and run through the real command line, ``torchrom sweep
COPY --out DIR --workers W`` in a subprocess, into a fresh folder. Recorded per run:

- ``wall_s``: the command's wall-clock time (start-up, model cache, Dask cluster, sweep,
  table and figures); ``cpu_s``: the user + system CPU seconds of the command and every
  process it waited for (its Dask workers included: ``RUSAGE_CHILDREN``), the figure a loaded
  machine does not inflate the way it inflates wall time; ``cpu_ms_per_case``;
- from the command's ``time:`` line: the sweep's own elapsed time (``sweep_elapsed_s``) and the
  seconds its chunks spent solving and certifying (Σ over chunks: ``solve_and_certify_s``);
- from the results table: ``rows``, the statuses, ``certified`` (rows with status ``lco`` and
  ``certified`` true), ``stability_resolved`` (``stable`` true or false, not unknown), the
  certificates used (fourier / shooting) and the finished rows;
- the load average before and after (the machine is shared: compare CPU seconds).

Writes ``benchmarks/results/bench_uq.json`` (meta + one record per run) and ``.csv``.
"""

from __future__ import annotations

import argparse
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from results_io import write_results  # noqa: E402

CONFIG = HERE.parent / "configs" / "goland_uq_hb.toml"


def config_with_samples(text: str, samples: int) -> str:
    """The configuration's text with ``samples = N`` (exactly one such line expected)."""
    new, count = re.subn(r"(?m)^samples\s*=\s*\d+", f"samples = {samples}", text)
    if count != 1:
        raise SystemExit(f"{CONFIG}: expected one 'samples = N' line, found {count}")
    return new


def children_cpu_s() -> float:
    """User + system CPU seconds of the finished child processes (and theirs) so far."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def run_once(samples: int, workers: int, folder: Path) -> dict:
    """One run of the study at ``samples`` samples (module docstring)."""
    cfg = folder / f"goland_uq_hb_{samples}.toml"
    cfg.write_text(config_with_samples(CONFIG.read_text(), samples))
    out = folder / f"out{samples}"
    cmd = [sys.executable, "-m", "torchrom", "sweep", str(cfg), "--out", str(out),
           "--workers", str(workers)]
    load0 = os.getloadavg()
    cpu0, t0 = children_cpu_s(), time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall, cpu = time.perf_counter() - t0, children_cpu_s() - cpu0
    if proc.returncode != 0:
        raise SystemExit(f"torchrom sweep failed ({proc.returncode}): {proc.stderr.strip()}")
    table = pd.read_parquet(out / "results.parquet")
    # "time: 41.1 s elapsed, 37.8 s solving and certifying, ..."
    timing = re.search(r"time: ([\d.]+) s elapsed, ([\d.]+) s solving", proc.stdout)
    lco = table["status"] == "lco"
    certified = lco & (table["certified"] == True)  # noqa: E712 - an object column
    resolved = table["stable"].notna()  # true or false, not unknown
    return {"samples": samples, "workers": workers, "rows": len(table),
            "statuses": table["status"].value_counts().to_dict(),
            "certified": int(certified.sum()), "stability_resolved": int(resolved.sum()),
            "certificates": table["certificate"].value_counts().to_dict(),
            "finished": int((table["finished"] == True).sum()),  # noqa: E712
            "wall_s": wall, "cpu_s": cpu, "cpu_ms_per_case": 1e3 * cpu / samples,
            "sweep_elapsed_s": float(timing[1]) if timing else None,
            "solve_and_certify_s": float(timing[2]) if timing else None,
            "load_before": load0, "load_after": os.getloadavg()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--samples", type=int, nargs="+", default=[1000])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args()
    runs = []
    with tempfile.TemporaryDirectory(prefix="bench_uq_") as tmp:
        for samples in args.samples:
            row = run_once(samples, args.workers, Path(tmp))
            print(f"{samples} samples, {args.workers} workers: {row['wall_s']:.1f} s wall, "
                  f"{row['cpu_s']:.1f} CPU s ({row['cpu_ms_per_case']:.1f} ms per case), "
                  f"{row['certified']}/{row['rows']} certified LCO, "
                  f"{row['stability_resolved']} with stability resolved; load "
                  f"{row['load_before'][0]:.2f} -> {row['load_after'][0]:.2f}")
            runs.append(row)
    write_results(args.out, "bench_uq", [], runs, "runs", "uq_sweep",
                  config=str(CONFIG.relative_to(HERE.parent)),
                  command="torchrom sweep CONFIG(samples = N) --out DIR --workers W")


if __name__ == "__main__":
    main()
