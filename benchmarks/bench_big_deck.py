"""Benchmark of an aircraft-size SOL 145 deck end to end (not run by the test suite).

    PYTHONPATH=. python benchmarks/bench_big_deck.py [--chord-grids 35] [--span-grids 100]
        [--boxes 36] [--k 104] [--dlm-k 26] [--check-boxes 12] [--out benchmarks/results]

The deck (``tests/big_wing_deck.py``): a shell wing box of 2 × chord-grids × span-grids GRIDs
(CQUAD4 skins and spar webs, CBAR spar caps and rib posts), one CAERO1 of boxes × boxes
(AERO SYMXZ = 1), SPLINE1 + SPLINE2, ``k`` MKAERO1 reduced frequencies, FLUTTER PK over 20
speeds, EIGRL ND = 10. Timed in one run:

1. phases in this process: pyNastran's parse of the deck, torchrom's model build and assembly
   (``from_pynastran``), the 10 modes (sparse shift-invert), the DLM GAFs at all k solved at
   ``dlm-k`` of them (interpolated at the others) — the kernel compiled in this process;
2. ``torchrom flutter DECK --dlm-k N`` end to end in a fresh process (wall clock), the figure
   the acceptance asks for;
3. the interpolation error of ``--dlm-k`` (max |ΔQ| / max |Q| over all k and modes, and per k
   relative to that k's largest |Q_ij|, worst up to k = 0.3, 1 and all) against every k solved,
   on the same deck with ``check-boxes`` × ``check-boxes`` boxes (solving all k at 1,296 boxes
   takes longer than the rest of the benchmark together).

Writes ``bench_big_deck.json`` and ``.csv`` with the DOF count and the load average.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import write_results  # noqa: E402

from tests.big_wing_deck import write_deck  # noqa: E402
from torchrom.aero.dlm import compute_gaf  # noqa: E402
from torchrom.aero.nastran_flutter import NASTRAN_KERNEL, load_deck  # noqa: E402
from torchrom.fe.bdf_read import _read_pynastran, from_pynastran  # noqa: E402


def _timed(fn, *a, **k):
    t0 = time.perf_counter()
    out = fn(*a, **k)
    return out, time.perf_counter() - t0


def _gaf(path, fe, n_modes, k_exact):
    deck = load_deck(path)
    modes = fe.modes(n_modes)
    disp = np.asarray(fe.expand(modes.shapes)).reshape(n_modes, -1, 6)
    motion = deck.box_motion(fe.grid_ids, disp)
    k = sorted({k for _, k in deck.mkaero})
    return compute_gaf(deck.aero_panels, motion, 0.5, k, deck.reference.semichord,
                       NASTRAN_KERNEL, k_exact=k_exact).Q


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--chord-grids", type=int, default=35)
    ap.add_argument("--span-grids", type=int, default=100)
    ap.add_argument("--boxes", type=int, default=36)
    ap.add_argument("--k", type=int, default=104)
    ap.add_argument("--dlm-k", type=int, default=26)
    ap.add_argument("--check-boxes", type=int, default=12)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="bench_big_deck_"))
    path = tmp / "wing.bdf"
    info, t_write = _timed(write_deck, path, args.chord_grids, args.span_grids, args.boxes,
                           args.boxes, args.k)
    print(f"{info}; written in {t_write:.1f} s; load {os.getloadavg()}", flush=True)

    model, t_parse = _timed(_read_pynastran, path)
    fe, t_build = _timed(from_pynastran, model, source=str(path), name=path.stem)
    modes, t_modes = _timed(fe.modes, 10)
    print(f"pyNastran parse {t_parse:.1f} s, torchrom build/assembly {t_build:.1f} s "
          f"({fe.n_dof} free DOFs), 10 modes {t_modes:.1f} s", flush=True)
    _, t_gaf = _timed(_gaf, path, fe, 10, args.dlm_k)
    print(f"GAFs ({args.k} k, solved at {args.dlm_k}) {t_gaf:.1f} s (modes again included)",
          flush=True)

    cmd = [sys.executable, "-m", "torchrom", "flutter", str(path), "--dlm-k", str(args.dlm_k)]
    env = dict(os.environ, PYTHONPATH=str(HERE.parent))
    t0 = time.perf_counter()
    run = subprocess.run(cmd, capture_output=True, text=True, env=env)
    t_cli = time.perf_counter() - t0
    tail = (run.stdout + run.stderr).strip().splitlines()[-3:]
    print(f"torchrom flutter end to end: {t_cli:.1f} s (exit {run.returncode})", flush=True)

    small = tmp / "check.bdf"
    write_deck(small, args.chord_grids, args.span_grids, args.check_boxes, args.check_boxes,
               args.k)
    fe_small = from_pynastran(_read_pynastran(small), source=str(small), name="check")
    q_all = _gaf(small, fe_small, 10, None)
    q_sub = _gaf(small, fe_small, 10, args.dlm_k)
    interp_err = float(np.abs(q_sub - q_all).max() / np.abs(q_all).max())
    # per k: max |ΔQ_ij| / max |Q_ij| at that k, worst over k up to a bound
    ks = np.array(sorted({k for _, k in load_deck(small).mkaero}))
    per_k = np.abs(q_sub - q_all).max(axis=(1, 2)) / np.abs(q_all).max(axis=(1, 2))
    by_range = {f"k<={lim:g}": float(per_k[ks <= lim].max()) for lim in (0.3, 1.0, ks.max())}
    print(f"interpolation error of --dlm-k {args.dlm_k} ({args.check_boxes}² boxes): "
          f"{interp_err:.2e} of max |Q|; per k {by_range}", flush=True)

    row = {"kind": "deck", **info, "free_dof": int(fe.n_dof), "dlm_k": args.dlm_k,
           "write_s": t_write, "pynastran_parse_s": t_parse, "torchrom_build_s": t_build,
           "modes_s": t_modes, "gaf_s": t_gaf, "flutter_cli_s": t_cli,
           "flutter_cli_exit": run.returncode, "interpolation_error": interp_err,
           **{f"interpolation_error_per_k_{key}": v for key, v in by_range.items()},
           "interpolation_check_boxes": args.check_boxes ** 2,
           "load_average_1min": os.getloadavg()[0]}
    write_results(args.out, "bench_big_deck", [row], [{"cli_tail": " | ".join(tail)}],
                  "cli", "cli", device="cpu (no GPU on this machine)",
                  command=" ".join(cmd[1:]),
                  note="the CLI time includes Python start-up, reading the deck twice "
                  "(load_deck and read_bdf each parse it with pyNastran), compiling the DLM "
                  "kernel (Inductor's on-disk cache warm or not), modes, GAFs and p-k")
    return 0 if run.returncode == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
