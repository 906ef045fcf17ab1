"""The Pazy wing at a root angle of attack (issue 45's speed items; not run by the test suite).

    PYTHONPATH=. python benchmarks/bench_aoa.py [--rom ROM.npz --aero AERO.npz]
        [--out benchmarks/results]

1. The full FE static aeroelastic sweep, without skin, 5°, 15 speeds 20–62 m/s
   (torchrom.trim.equilibrium.nonlinear_sweep: modified Newton, the tangent's factor and its
   rank-96 aerodynamic correction reused across iterations and speeds); with ``--peer`` also
   against the peer run on the same model in the same process: full Newton (Nastran SOL
   106's default KMETHOD AUTO refactors when it must; this peer refactors every iteration)
   with SciPy's sparse direct solve of the assembled K_T + q Tₛᵀ Q Tₛ, both to
   ‖r‖ ≤ 1e-7 ‖F‖ (slow: SuperLU on the assembled matrix at every iteration).
2. With ``--rom/--aero`` (a condensed ROM of the wing and its aero file), the ROM's onset /
   offset map: 0–7° by 0.5°, 60 speeds, the equilibria and the RFA's state-space roots of the
   tangent (torchrom.trim.reduced), against p-k on the same tangents (Nastran's PK) as the
   peer; the boundaries of the two within the speed grid's spacing.

Writes ``bench_aoa.json`` and ``.csv`` with the machine and load average.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import write_results  # noqa: E402

SPEEDS = np.linspace(20.0, 62.0, 15)
AOA_MAP = np.arange(0.0, 7.01, 0.5)


def full_newton_sweep(fe, op, speeds, density, aoa_rad, tol=1e-7, max_iter=40):
    """The peer: Newton with the assembled tangent refactored at every iteration."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    from torchrom.trim.equilibrium import aero_load

    u = np.zeros(fe.n_dof)
    T = sp.csr_matrix(op.T_s)
    out = []
    for V in speeds:
        q = 0.5 * density * V**2
        A = (T.T @ sp.csr_matrix(op.Q_ss) @ T) * q
        for _ in range(max_iter):
            F = aero_load(fe, op, q, aoa_rad, u)
            r = fe.internal_force(u) - F
            if np.linalg.norm(r) <= tol * np.linalg.norm(F):
                break
            u = u - spla.spsolve((fe.tangent_stiffness(u) + A).tocsc(), r)
        else:
            raise RuntimeError(f"peer: no equilibrium at {V} m/s")
        out.append(u.copy())
    return out


def fe_sweep(rows, peer: bool):
    from experiments.pazy_aoa_static import DENSITY, NOSKIN, _model, _tip_pct
    from torchrom.trim.equilibrium import nonlinear_sweep

    fe, op = _model(NOSKIN)
    aoa = math.radians(5.0)
    t = time.perf_counter()
    ours = nonlinear_sweep(fe, op, SPEEDS, DENSITY, aoa)
    t_ours = time.perf_counter() - t
    assert all(e.converged for e in ours)
    row = {"kind": "fe_static_sweep", "speeds": len(SPEEDS), "aoa_deg": 5.0,
           "torchrom_s": t_ours, "tip_pct_at_last_speed": _tip_pct(fe, ours[-1].u, True),
           "newton_iterations": int(sum(e.iterations for e in ours))}
    if peer:
        t = time.perf_counter()
        sols = full_newton_sweep(fe, op, SPEEDS, DENSITY, aoa)
        t_peer = time.perf_counter() - t
        row.update(peer_full_newton_spsolve_s=t_peer, ratio_peer_over_torchrom=t_peer / t_ours,
                   max_tip_difference_pct=max(abs(_tip_pct(fe, e.u, True) -
                                                  _tip_pct(fe, u, True))
                                              for e, u in zip(ours, sols)))
    rows.append(row)
    print(f"FE static sweep, 15 speeds: torchrom {t_ours:.1f} s"
          + (f", full Newton + spsolve {row['peer_full_newton_spsolve_s']:.1f} s" if peer
             else " (the peer: --peer)"))


def rom_map(rows, rom_path, aero_path):
    from torchrom.aero.files import load_aero
    from torchrom.rom import NonlinearROM
    from torchrom.trim.reduced import (
        SteadyModalAero,
        deformed_flutter,
        rom_equilibria,
        root_finder,
    )

    rom, aero = NonlinearROM.load(rom_path), load_aero(aero_path)
    steady = SteadyModalAero.from_aero(aero, rom.n)
    speeds = np.linspace(20.0, 79.0, 60)
    timings, found = {}, {}
    for method in ("state-space", "p-k"):
        t = time.perf_counter()
        eq = rom_equilibria(rom, steady, AOA_MAP, speeds, 1.225)
        res = deformed_flutter(rom, eq, root_finder(method, rom, aero))
        timings[method] = time.perf_counter() - t
        found[method] = [[(b.kind, b.velocity) for b in bs] for bs in res.boundaries]
    rows.append({"kind": "rom_onset_offset_map", "angles": len(AOA_MAP), "speeds": len(speeds),
                 "torchrom_state_space_s": timings["state-space"],
                 "peer_pk_s": timings["p-k"],
                 "ratio_peer_over_torchrom": timings["p-k"] / timings["state-space"],
                 "boundaries_state_space": found["state-space"],
                 "boundaries_pk": found["p-k"]})
    print(f"ROM map {len(AOA_MAP)} angles x {len(speeds)} speeds: state space "
          f"{timings['state-space']:.2f} s, p-k {timings['p-k']:.1f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rom", type=Path)
    ap.add_argument("--aero", type=Path)
    ap.add_argument("--skip-fe", action="store_true")
    ap.add_argument("--peer", action="store_true",
                    help="also the FE sweep's peer (full Newton + spsolve: tens of minutes)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args()
    rows: list[dict] = []
    if not args.skip_fe:
        fe_sweep(rows, args.peer)
    if args.rom is not None:
        rom_map(rows, args.rom, args.aero)
    write_results(args.out, "bench_aoa", rows, [], "runs", "run")


if __name__ == "__main__":
    main()
