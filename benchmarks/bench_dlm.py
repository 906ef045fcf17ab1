"""Benchmark of the doublet-lattice GAFs: torchrom's torch kernel vs PanelAero (not run by tests).

    PYTHONPATH=. python benchmarks/bench_dlm.py [--boxes 36] [--k 104] [--pa-k 3]
        [--kernel quartic] [--mach 0.5] [--out benchmarks/results]

Same boxes (a flat 2 x 10 half wing of ``boxes`` x ``boxes`` CAERO1-style boxes, no image),
same modes (six smooth polynomial shapes), same reduced frequencies (``k`` values from 0.001 to
3, the first and last included), one run:

* torchrom: :func:`torchrom.aero.dlm.compute_gaf` (engine "torch") at every k — first a call at
  two k (it includes compiling the kernel, ``torch_first_call_s``), then the timed call at all k
  (``torch_s``; the pressure solves included);
* PanelAero: the same function with engine "panelaero" at ``pa_k`` of the k, spread over the
  range (PanelAero takes tens of seconds per k at 1,296 boxes), scaled linearly to all k
  (``panelaero_s_scaled``: PanelAero's cost is the same at every k > 0);
* the relative difference of the GAFs at the PanelAero k (max |ΔQ| / max |Q| per k).

Writes ``bench_dlm.json`` and ``.csv`` with the load average (2 cores shared with other jobs).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import write_results  # noqa: E402

from torchrom.aero.dlm import BoxMotion, compute_gaf  # noqa: E402
from torchrom.aero.panels import rectangular_wing  # noqa: E402

SHAPES = [
    (lambda x, y: np.ones_like(x), lambda x, y: np.zeros_like(x)),
    (lambda x, y: -(x - 0.8), lambda x, y: -np.ones_like(x)),
    (lambda x, y: (y / 10) ** 2, lambda x, y: np.zeros_like(x)),
    (lambda x, y: -(x - 0.8) * y / 10, lambda x, y: -y / 10),
    (lambda x, y: (y / 10) ** 3 * (1 + 0.2 * x), lambda x, y: 0.2 * (y / 10) ** 3),
    (lambda x, y: np.sin(np.pi * y / 10) * x**2, lambda x, y: 2 * x * np.sin(np.pi * y / 10)),
]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--boxes", type=int, default=36, help="boxes per side (boxes² in all)")
    ap.add_argument("--k", type=int, default=104, help="reduced frequencies")
    ap.add_argument("--pa-k", type=int, default=3, help="k values PanelAero is timed on")
    ap.add_argument("--kernel", default="quartic", choices=["quartic", "parabolic"])
    ap.add_argument("--mach", type=float, default=0.5)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)

    panels = rectangular_wing(2.0, 10.0, args.boxes, args.boxes, full_span=False)
    motion = BoxMotion.from_function(panels, SHAPES)
    k = np.geomspace(1e-3, 3.0, args.k)
    b = 1.0
    print(f"{panels.n} boxes, {args.k} k, {motion.n_modes} modes, Mach {args.mach}, "
          f"{args.kernel}; load {os.getloadavg()}", flush=True)

    t0 = time.perf_counter()
    compute_gaf(panels, motion, args.mach, k[:2], b, args.kernel)
    first = time.perf_counter() - t0
    t0 = time.perf_counter()
    q_torch = compute_gaf(panels, motion, args.mach, k, b, args.kernel).Q
    t_torch = time.perf_counter() - t0
    print(f"torch: first call (2 k, compiling) {first:.1f} s, {args.k} k {t_torch:.1f} s",
          flush=True)

    pick = np.unique(np.linspace(0, args.k - 1, args.pa_k).round().astype(int))
    t0 = time.perf_counter()
    q_pa = compute_gaf(panels, motion, args.mach, k[pick], b, args.kernel,
                       engine="panelaero").Q
    t_pa = time.perf_counter() - t0
    t_pa_all = t_pa * args.k / len(pick)
    rel = [float(np.abs(q_torch[j] - q_pa[i]).max() / np.abs(q_pa[i]).max())
           for i, j in enumerate(pick)]
    print(f"PanelAero: {len(pick)} k {t_pa:.1f} s -> {args.k} k {t_pa_all:.0f} s (scaled); "
          f"speed-up {t_pa_all / t_torch:.1f} (with the first call "
          f"{t_pa_all / (t_torch + first):.1f}); GAF rel. difference max {max(rel):.2e}",
          flush=True)
    row = {"kind": "gaf", "boxes": int(panels.n), "n_k": args.k, "modes": motion.n_modes,
           "mach": args.mach, "kernel": args.kernel, "torch_s": t_torch,
           "torch_first_call_s": first, "panelaero_k_timed": len(pick),
           "panelaero_s_timed": t_pa, "panelaero_s_scaled": t_pa_all,
           "speedup": t_pa_all / t_torch, "speedup_with_first_call": t_pa_all / (t_torch + first),
           "gaf_rel_diff_max": max(rel), "load_average_1min": os.getloadavg()[0]}
    checks = [{"k": float(k[j]), "gaf_rel_diff": r} for j, r in zip(pick, rel)]
    write_results(args.out, "bench_dlm", [row], checks, "agreement", "agreement",
                  threads=torch.get_num_threads(), device="cpu (no GPU on this machine)",
                  panelaero_scaling=f"PanelAero timed on {len(pick)} of the {args.k} k and "
                  "scaled linearly (its cost per k > 0 does not depend on k)",
                  first_call="torch's first call in the process (2 k) compiles the kernel "
                  "(torch.compile; Inductor's on-disk cache makes later processes faster)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
