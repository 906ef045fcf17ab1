"""Where ``torchrom identify`` spends its time on a small co-rotational deck, and the
identification with and without the changes that made it proportional to its work (not run
by the tests).

    PYTHONPATH=. python benchmarks/bench_identify_small.py [--deck DECK] [--linear 6] [--dual 6]
        [--out benchmarks/results]

The deck (default tests/decks/tacs_mdo_wingbox/wingbox.bdf): the public TACS/MACH coarse
wingbox (76 grids, 432 free DOFs, 91 co-rotational CQUAD4s). Rows: one co-rotational tangent
alone, the same states' tangents in one pass (``FEModel.tangent_stiffnesses``), one internal
force (the least of five each), each with the shells' closed-form kernel
(:mod:`torchrom.fe.elements.corot_shell`) and with the automatic differentiation it replaced.
Runs, side by side in this process: the identification as it is ("new"); with the shells'
automatic differentiation instead of the closed form ("autodiff kernel": the identification
before the closed form, its ROM the reference of the closed form's); and its peer
("old path"), in which modified Newton reuses its factorisation
wherever the residual falls by half or more, however far from equilibrium (``NEWTON_ABOVE``
off, as before), and the stiffness plan takes its tangents one point at a time (the protocol's
``FEBackend.projected_tangents``, as before). The element kernel is the same in both (its own
change shows in the rows' tangent time against the previous kernel's, measured before it
changed). Each run: seconds per stage, static solves, the FE's tangents and residuals within
the static solves, and the ROM tensors' difference between the two runs (relative to the
largest entry). Writes ``bench_identify_small.json`` and ``.csv``.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import least_of, write_results  # noqa: E402

DECK = HERE.parent / "tests" / "decks" / "tacs_mdo_wingbox" / "wingbox.bdf"


class Counting:
    """Counts the FE's residual and tangent evaluations within the backend's static solves."""

    def __init__(self, be):
        self.be, self.fe, self.residuals, self.tangents = be, be.fe, 0, 0
        self.solving = False

    def __enter__(self):
        force, tangent, solve = (self.fe.internal_force, self.fe.tangent_stiffness,
                                 self.be.static_solve)

        def counted_force(u):
            self.residuals += self.solving
            return force(u)

        def counted_tangent(u):
            self.tangents += self.solving
            return tangent(u)

        def counted_solve(load, u0=None):
            self.solving = True
            try:
                return solve(load, u0)
            finally:
                self.solving = False

        self.fe.internal_force, self.fe.tangent_stiffness = counted_force, counted_tangent
        self.be.static_solve = counted_solve
        return self

    def __exit__(self, *exc):
        del self.fe.internal_force, self.fe.tangent_stiffness, self.be.static_solve


def identify_run(path: Path, n_linear: int, n_dual: int, old_path: bool,
                 autodiff: bool = False) -> tuple[dict, object]:
    """One identification of the deck (a fresh read: no state shared with the other runs);
    ``autodiff``: the shells' force and tangent by automatic differentiation."""
    import torchrom.fe.solvers as solvers
    from torchrom.fe import read_bdf
    from torchrom.identify import DualModeOptions
    from torchrom.identify.backend import FEBackend
    from torchrom.identify.basis import parse_combinations
    from torchrom.identify.build import IdentifyOptions, identify
    from torchrom.identify.fe_backend import BuiltinFEBackend

    fe = read_bdf(path)
    if autodiff:
        for kern in fe._state().corot:
            kern.shell = None
    m = fe.modes(n_linear)
    kinds = (["rigid-body"] * m.n_rigid + list(m.kinds))[:n_linear]
    combinations = parse_combinations("transverse", kinds=kinds)
    be = BuiltinFEBackend(fe)
    saved = solvers.NEWTON_ABOVE
    if old_path:
        solvers.NEWTON_ABOVE = None
        be.projected_tangents = lambda Phi, Q, material=False: FEBackend.projected_tangents(
            be, Phi, Q, material)
    try:
        with Counting(be) as count:
            t = time.perf_counter()
            res = identify(be, IdentifyOptions(n_linear=n_linear, n_dual=n_dual,
                                               dual=DualModeOptions(combinations=combinations)))
            seconds = time.perf_counter() - t
    finally:
        solvers.NEWTON_ABOVE = saved
    c = be.counters.as_dict()
    name = "old path" if old_path else "autodiff kernel" if autodiff else "new"
    row = {"run": name, "seconds": seconds,
           **{f"{k}_s": v for k, v in res.timings.items()},
           "static_solves": c["static_solves"], "dual_solve_tangents": count.tangents,
           "dual_solve_residuals": count.residuals,
           "plan_tangents": c["tangent_evaluations"],
           "combinations": " ".join(f"{j}:{l}" for j, l in combinations),
           "largest_residual": max(res.stiffness.residuals.values())}
    return row, res


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--deck", type=Path, default=DECK)
    ap.add_argument("--linear", type=int, default=6)
    ap.add_argument("--dual", type=int, default=6)
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    from torchrom.fe import read_bdf

    fe = read_bdf(args.deck)
    m = fe.modes(6)
    U = np.stack([m.shapes[:, i % 6] * (0.05 * (1 + i // 6) / np.abs(m.shapes[:, i % 6]).max())
                  for i in range(11)])
    n_el = sum(len(k.els) for k in fe._state().corot)
    rows = [{"what": "tangent, one state", "seconds": least_of(lambda: fe.tangent_stiffness(U[0]))},
            {"what": "tangents of 11 states in one pass, a state",
             "seconds": least_of(lambda: fe.tangent_stiffnesses(U)) / len(U)},
            {"what": "internal force", "seconds": least_of(lambda: fe.internal_force(U[0]))}]
    shells = [k.shell for k in fe._state().corot]
    for kern in fe._state().corot:
        kern.shell = None
    rows += [{"what": "tangent, one state, automatic differentiation",
              "seconds": least_of(lambda: fe.tangent_stiffness(U[0]))},
             {"what": "internal force, automatic differentiation",
              "seconds": least_of(lambda: fe.internal_force(U[0]))}]
    for kern, shell in zip(fe._state().corot, shells):
        kern.shell = shell
    for r in rows:
        print(r)
    runs, results = [], []
    for old, autodiff in ((False, False), (False, True), (True, False)):
        row, res = identify_run(args.deck, args.linear, args.dual, old, autodiff)
        runs.append(row)
        results.append(res)
        print(row)
    new, ad, old = results
    for name in ("K1", "K2", "K3", "D1", "D2", "D3"):
        a, b, c = (np.asarray(getattr(r.rom, name)) for r in (new, ad, old))
        runs[0][f"{name}_rel_diff_to_autodiff_kernel"] = float(np.abs(a - b).max()
                                                               / np.abs(b).max())
        runs[0][f"{name}_rel_diff_to_old_path"] = float(np.abs(a - c).max() / np.abs(c).max())
    runs[0]["speedup_vs_autodiff_kernel"] = runs[1]["seconds"] / runs[0]["seconds"]
    runs[0]["speedup_vs_old_path"] = runs[2]["seconds"] / runs[0]["seconds"]
    print({k: v for k, v in runs[0].items() if "diff" in k or "speedup" in k})
    write_results(args.out, "bench_identify_small", rows, runs, "identify_runs", "identify",
                  deck=str(args.deck.name), free_dofs=int(fe.n_dof), corot_elements=n_el,
                  n_linear=args.linear, n_dual=args.dual)
    return 0


if __name__ == "__main__":
    sys.exit(main())
