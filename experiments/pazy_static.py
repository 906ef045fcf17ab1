"""Pazy wing static bending sweep (Riso & Cesnik, SciTech 2022): tip vertical displacement
(% of the semispan, self-weight subtracted) against a tip mass of 0 … 3.5 kg under gravity,
torchrom's full FE model (co-rotational, geometrically nonlinear; and linear) against MSC Nastran
SOL 400 and SOL 101 (issue 34).

The deck, the tip mass (a CONM2 on grid 61 under GRAV 9.81 m/s² in −z: a dead load) and the
tip displacement (the rigid tip section's mid-chord) are those of the SOL 101 test
(``tests/test_public_decks.py``: ``PAZY_TIP_DECK``, ``pazy_tip_percent``). One FE model is
read; the load of mass m is F(m) = F_w + m F_1 (F_w the self-weight, F_1 = 9.81 N down at grid
61, exact: the CONM2's GRAV load). The nonlinear sweep is a continuation: the solution at one
mass is the start of the next (one Newton load step per mass, halved if it fails).

    PYTHONPATH=$PWD python experiments/pazy_static.py [--masses 0.25,1,3.5] [--rom]
        [--out experiments/results/pazy_static.json] [--figure docs/guide/pazy_static.png]
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from tests.test_public_decks import (
    PAZY,
    PAZY_SEMISPAN,
    PAZY_TIP_ARM,
    PAZY_TIP_DECK,
    pazy_tip_percent,
)

#: the tip mass's grid (the tip rod's mid-point, the mid-chord) and the tip section's grid
MASS_GRID = 61
TIP_GRID = 2366
GRAVITY = 9.81  # m/s², the deck's GRAV
SOL400 = "sweep_static_bending_GFEM_sweep_wo_skin.txt"
SOL101 = "sweep_static_bending_GFEM_linear_sweep_wo_skin.txt"


def sweep_table(name: str) -> np.ndarray:
    """(15, 2): tip mass (kg), tip vertical displacement (% of the semispan)."""
    return np.loadtxt(PAZY / name)


def pazy_model(mass: float = 0.0, sol: int = 400, **options):
    """The Pazy FE model (``read_bdf``) of the test's deck with a ``mass`` kg tip CONM2."""
    from torchrom.fe.bdf_read import read_bdf

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in ("fem_noskin_stiftip.bdf", "tip_rbe2_noskin.bdf", "bcs_noskin.bdf"):
            shutil.copy(PAZY / name, tmp / name)
        deck = tmp / "pazy_tip.dat"
        deck.write_text(PAZY_TIP_DECK.format(sol=sol, ninc=1, mass=mass))
        return read_bdf(deck, **options)


def tip_percent(fe, u: np.ndarray, u_weight: np.ndarray) -> float:
    """Tip mid-chord vertical displacement (% semispan) of free-DOF state ``u``, the self-weight
    state ``u_weight`` subtracted (the test's ``pazy_tip_percent`` on grid 2366)."""
    rows = {str(TIP_GRID): None}
    k = int(np.flatnonzero(fe.grid_ids == TIP_GRID)[0])

    def step(v):
        rows[str(TIP_GRID)] = fe.expand(v)[k].tolist()
        return {"displacements": dict(rows)}

    return pazy_tip_percent(step(u), step(u_weight))


@dataclass
class SweepResult:
    masses: np.ndarray
    nonlinear: np.ndarray  # % semispan
    linear: np.ndarray
    seconds: float
    iterations: list[int] = field(default_factory=list)
    tol: float = 0.0


def nonlinear_sweep(fe, masses, *, tol: float = 1e-6, max_iter: int = 30,
                    progress=print) -> SweepResult:
    """Continuation over ``masses`` (kg, increasing from 0): Newton at each mass from the last
    solution, converged to ‖r‖ ≤ ``tol`` ‖F‖ (or the solver's work criterion)."""
    from torchrom.fe.solvers import solve_symmetric, static_solve

    F_w = fe.load_vector(1)
    F_1 = fe.nodal_load({(MASS_GRID, 3): -GRAVITY})
    t0 = time.perf_counter()
    w = static_solve(fe, F_w, n_steps=1, tol=tol, max_iter=max_iter, raise_on_failure=True)
    u_w = u = w.u
    K = fe.stiffness_matrix()
    u_lin_w = solve_symmetric(K, F_w)
    out, lin, its = [], [], []
    for m in masses:
        r = static_solve(fe, F_w + m * F_1, u0=u, n_steps=1, tol=tol, max_iter=max_iter,
                         raise_on_failure=True)
        u = r.u
        out.append(tip_percent(fe, u, u_w))
        lin.append(tip_percent(fe, solve_symmetric(K, F_w + m * F_1), u_lin_w))
        its.append(r.iterations)
        progress(f"  {m:5.2f} kg: {out[-1]:8.3f} % (linear {lin[-1]:8.3f} %), "
                 f"{r.iterations} iterations, {time.perf_counter() - t0:.0f} s")
    return SweepResult(np.asarray(masses, float), np.array(out), np.array(lin),
                       time.perf_counter() - t0, its, tol)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--masses", default=None, help="tip masses (kg), default: the table's")
    p.add_argument("--tol", type=float, default=1e-6)
    p.add_argument("--out", type=Path, default=None)
    args = p.parse_args(argv)
    nl_ref, lin_ref = sweep_table(SOL400), sweep_table(SOL101)
    masses = nl_ref[:, 0] if args.masses is None else \
        np.array([float(x) for x in args.masses.split(",")])
    t = time.perf_counter()
    fe = pazy_model()
    print(f"model: {fe.n_dof} DOFs, rotations={fe.rotations}, read in "
          f"{time.perf_counter() - t:.1f} s")
    res = nonlinear_sweep(fe, masses, tol=args.tol)
    print(f"sweep: {len(masses)} masses in {res.seconds:.1f} s, iterations {res.iterations}")
    print("| mass kg | SOL 400 % | torchrom NL % | diff (% semispan) | SOL 101 % | "
          "torchrom linear % |")
    for m, a, b in zip(masses, res.nonlinear, res.linear):
        r4 = np.interp(m, nl_ref[:, 0], nl_ref[:, 1])
        r1 = np.interp(m, lin_ref[:, 0], lin_ref[:, 1])
        print(f"| {m:.2f} | {r4:.3f} | {a:.3f} | {a - r4:+.3f} | {r1:.3f} | {b:.3f} |")
    if args.out:
        args.out.write_text(json.dumps({
            "masses_kg": masses.tolist(), "nonlinear_pct": res.nonlinear.tolist(),
            "linear_pct": res.linear.tolist(), "seconds": res.seconds,
            "iterations": res.iterations, "tol": res.tol,
            "semispan_m": PAZY_SEMISPAN, "tip_arm_m": PAZY_TIP_ARM}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
