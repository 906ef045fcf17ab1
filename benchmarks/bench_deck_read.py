"""Where reading a large deck spends its time: pyNastran's parse vs torchrom's model build.

    PYTHONPATH=. python benchmarks/bench_deck_read.py [--chord-grids 50] [--span-grids 1000]
        [--out benchmarks/results]

The structure of ``tests/big_wing_deck.py`` (CQUAD4 skins and webs, CBAR caps and posts) at
2 × chord-grids × span-grids GRIDs (100,000 by default), a token 4 × 4 aero model. Times
pyNastran's parse (``_read_pynastran``) and torchrom's build (``from_pynastran``: element
blocks, constraints, assembly of K and M on the free DOFs) in one run, and lists the functions
with the most own time in the build (cProfile). Writes ``bench_deck_read.json`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import cProfile
import os
import pstats
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import write_results  # noqa: E402

from tests.big_wing_deck import write_deck  # noqa: E402
from torchrom.fe.bdf_read import _read_pynastran, from_pynastran  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--chord-grids", type=int, default=50)
    ap.add_argument("--span-grids", type=int, default=1000)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    path = Path(tempfile.mkdtemp(prefix="bench_deck_read_")) / "wing.bdf"
    info = write_deck(path, args.chord_grids, args.span_grids, 4, 4, 8)
    print(f"{info}; load {os.getloadavg()}", flush=True)
    t0 = time.perf_counter()
    model = _read_pynastran(path)
    t_parse = time.perf_counter() - t0
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    fe = from_pynastran(model, source=str(path), name=path.stem)
    prof.disable()
    t_build = time.perf_counter() - t0
    print(f"pyNastran parse {t_parse:.1f} s, torchrom build {t_build:.1f} s, {fe.n_dof} free "
          "DOFs", flush=True)
    stats = pstats.Stats(prof).stats
    top = sorted(((v[2], f"{Path(k[0]).name}:{k[1]}({k[2]})") for k, v in stats.items()),
                 reverse=True)[:12]
    for t, name in top:
        print(f"  {t:7.2f} s  {name}")
    row = {"kind": "read", **info, "free_dof": int(fe.n_dof), "pynastran_parse_s": t_parse,
           "torchrom_build_s": t_build, "load_average_1min": os.getloadavg()[0]}
    write_results(args.out, "bench_deck_read", [row],
                  [{"own_time_s": t, "function": name} for t, name in top], "profile",
                  "profile", note="profile: own (not cumulative) time of the build's "
                  "costliest functions; cProfile slows the build a little")
    return 0


if __name__ == "__main__":
    sys.exit(main())
