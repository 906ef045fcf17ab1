"""How much the paper pipeline's numbers move with the number of BLAS/torch threads.

The optimum damping decomposition (paper Ref. 28, :mod:`torchrom.identify.damping`) chooses D̄2,
D̄3 among many equally "optimal" tensors (README, "The paper study"), so rounding-level changes in
its least-squares and eigenvalue solves — a different summation order with another thread count
or BLAS — can move them far more than rounding. This script builds the full Goland pipeline
(FE → 9L12D ROM → DLM/RFA → flutter; :data:`torchrom.paper.study.FULL_PIPELINE`) once per thread
count, each in a fresh process with ``OMP_NUM_THREADS`` and ``torch.set_num_threads`` set, and
compares:

- the stiffness tensors K̃2, K̃3 and the damping tensors D̄2, D̄3 (relative Frobenius norm of the
  difference to the first run);
- the flutter altitude (state space);
- the Fig. 10 amplitude of point A at 4,000 ft for γ = 0, 1e-5 and 1e-3 s (the cases of
  ``paper_lco.toml``).

    PYTHONPATH=. OMP_NUM_THREADS=1 python experiments/decomposition_spread.py [--threads 1 2]
        [--out experiments/results/decomposition_spread.md]

Writes Markdown (and JSON beside it).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
ALTITUDE_FT = 4000.0
GAMMAS = (0.0, 1e-5, 1e-3)


def one_build(folder: Path, threads: int) -> None:
    """(child process) the pipeline into ``folder`` and the three sweep cases."""
    import dataclasses

    import torch

    torch.set_num_threads(threads)
    from torchrom.paper.pipeline import goland_pipeline
    from torchrom.paper.study import FULL_PIPELINE, config_path
    from torchrom.study.config import load_sweep_config
    from torchrom.study.sweep import run_sweep

    res = goland_pipeline(FULL_PIPELINE, folder / "model", log=lambda m: None)
    cfg = load_sweep_config(config_path("paper_lco.toml"))
    cases = [c for c in cfg.cases if float(c.get("altitude_ft", -1)) == ALTITUDE_FT
             and float(c.get("gamma", 0.0)) in GAMMAS and c.get("stiffness_nl", True)
             and c.get("damping_nl", True)]
    table, _ = run_sweep(dataclasses.replace(cfg, cases=cases, history=None), model=res.model)
    rom = res.model.rom
    np.savez(folder / "tensors.npz", K2=rom.K2.numpy(), K3=rom.K3.numpy(), D2=rom.D2.numpy(),
             D3=rom.D3.numpy())
    out = {"threads": threads,
           "flutter_altitude_ft": float(res.flutter["state_space"]["altitude"]),
           "amplitude_ft": {f"{float(r.gamma):g}": float(r.amplitude)
                            for r in table.itertuples()},
           "status": {f"{float(r.gamma):g}": r.status for r in table.itertuples()}}
    (folder / "summary.json").write_text(json.dumps(out, indent=2))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--threads", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--out", type=Path, default=ROOT / "experiments" / "results" /
                    "decomposition_spread.md")
    ap.add_argument("--child", nargs=2, metavar=("FOLDER", "THREADS"), help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        one_build(Path(args.child[0]), int(args.child[1]))
        return 0
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for t in args.threads:
            folder = Path(tmp) / f"threads{t}"
            folder.mkdir()
            env = {**os.environ, "OMP_NUM_THREADS": str(t), "MKL_NUM_THREADS": str(t),
                   "PYTHONPATH": str(ROOT)}
            print(f"building the pipeline with {t} thread(s) ...", flush=True)
            subprocess.run([sys.executable, __file__, "--child", str(folder), str(t)], env=env,
                           check=True)
            z = np.load(folder / "tensors.npz")
            runs.append({**json.loads((folder / "summary.json").read_text()),
                         "tensors": {k: z[k] for k in z.files}})
    ref = runs[0]
    rows, record = [], []
    for r in runs:
        rel = {k: float(np.linalg.norm(r["tensors"][k] - ref["tensors"][k])
                        / np.linalg.norm(ref["tensors"][k])) for k in ("K2", "K3", "D2", "D3")}
        amp = {g: 100 * (r["amplitude_ft"][g] / ref["amplitude_ft"][g] - 1)
               for g in ref["amplitude_ft"]}
        rec = {"threads": r["threads"], "relative_difference": rel,
               "flutter_altitude_ft": r["flutter_altitude_ft"],
               "amplitude_ft": r["amplitude_ft"], "amplitude_change_pct": amp,
               "status": r["status"]}
        record.append(rec)
        rows.append(f"| {r['threads']} | {rel['K2']:.1e} | {rel['K3']:.1e} | {rel['D2']:.1e} | "
                    f"{rel['D3']:.1e} | {r['flutter_altitude_ft']:,.2f} | "
                    + " | ".join(f"{r['amplitude_ft'][g]:.4f} ({amp[g]:+.2f} %)"
                                 for g in sorted(ref["amplitude_ft"], key=float)) + " |")
    gam = sorted(ref["amplitude_ft"], key=float)
    md = ["# Thread count and the pipeline's numbers (experiments/decomposition_spread.py)", "",
          f"Relative differences to the {ref['threads']}-thread run; Fig. 10 amplitude of point "
          f"A at {ALTITUDE_FT:,.0f} ft in ft (change to the first run).", "",
          "| threads | K̃2 | K̃3 | D̄2 | D̄3 | flutter altitude ft | "
          + " | ".join(f"γ = {g} s" for g in gam) + " |",
          "|---|---|---|---|---|---|" + "---|" * len(gam), *rows, ""]
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(md))
    args.out.with_suffix(".json").write_text(json.dumps(record, indent=2) + "\n")
    print("\n".join(md))
    return 0


if __name__ == "__main__":
    sys.exit(main())
