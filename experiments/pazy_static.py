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

    PYTHONPATH=$PWD python experiments/pazy_static.py [--masses 0.25,1,3.5] [--rom L,D]
        [--stiffness condensed] [--amplitude 0.3] [--levels 3]
        [--combinations 1:1] [--amplitudes 8] [--tip-range 0.01,0.25] [--fe-from JSON]
        [--out experiments/results/pazy_static.json] [--figure docs/guide/pazy_static.png]

With ``--rom`` the ROM's validity envelope is printed and saved: the largest full-FE tip
deflection (% of the semispan) up to which every mass's ROM deflection is within 2 % of the
full FE's (:func:`rom_envelope`).
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


def pazy_model(mass: float = 0.0, sol: int = 400, extra: str = "", **options):
    """The Pazy FE model (``read_bdf``) of the test's deck with a ``mass`` kg tip CONM2 and the
    bulk cards ``extra`` (lines)."""
    from torchrom.fe.bdf_read import read_bdf

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in ("fem_noskin_stiftip.bdf", "tip_rbe2_noskin.bdf", "bcs_noskin.bdf"):
            shutil.copy(PAZY / name, tmp / name)
        deck = tmp / "pazy_tip.dat"
        text = PAZY_TIP_DECK.format(sol=sol, ninc=1, mass=mass)
        deck.write_text(text.replace("BEGIN BULK\n", "BEGIN BULK\n" + extra, 1))
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
    #: free-DOF states: the self-weight's, and each mass's nonlinear and linear solution
    u_weight: np.ndarray | None = None
    u_linear_weight: np.ndarray | None = None
    states: list[np.ndarray] = field(default_factory=list)
    linear_states: list[np.ndarray] = field(default_factory=list)


def nonlinear_sweep(fe, masses, *, tol: float = 1e-7, progress=print,
                    mass_grid: int = MASS_GRID) -> SweepResult:
    """Continuation over ``masses`` (kg, increasing from 0) on ``mass_grid``: modified Newton at
    each mass from the last solution with the last tangent factorisation (refactorised when the
    residual falls by less than half an iteration; a mass not reached in 30 iterations is
    approached through the midpoint from the last one), converged to ‖f(u) − F‖ ≤ ``tol`` ‖F‖
    (:func:`torchrom.fe.solvers.modified_newton`). The loads are dead loads
    (:mod:`torchrom.fe.dead_load`): the self-weight's moments and the mass's RBE2 arm follow
    the rotations."""
    from torchrom.errors import ConvergenceError
    from torchrom.fe.solvers import factor_symmetric, modified_newton

    F_w = fe.dead_load(1)
    F_1 = fe.nodal_dead_load({(mass_grid, 3): -GRAVITY})
    t0 = time.perf_counter()
    lin = factor_symmetric(fe.stiffness_matrix())
    u_w, _, _, factor = modified_newton(fe, F_w, np.zeros(fe.n_dof), tol=tol, factor=lin)
    u_lin_w = lin.solve(F_w.linear)
    u = u_w
    out, linear, its, states, linear_states = [], [], [], [], []
    last = 0.0
    for m in masses:
        n_f = n_k = 0
        steps = [m]  # a mass whose Newton fails is reached through the midpoint from the last
        while steps:
            try:
                u_try, a, b, factor = modified_newton(fe, F_w + steps[-1] * F_1, u, tol=tol,
                                                      factor=factor, max_iter=30)
            except ConvergenceError:
                steps.append(0.5 * (last + steps[-1]))
                factor = None
                continue
            u, last = u_try, steps.pop()
            n_f, n_k = n_f + a, n_k + b
        states.append(u)
        linear_states.append(lin.solve((F_w + m * F_1).linear))
        out.append(tip_percent(fe, u, u_w))
        linear.append(tip_percent(fe, linear_states[-1], u_lin_w))
        its.append((n_f, n_k))
        progress(f"  {m:5.2f} kg: {out[-1]:8.3f} % (linear {linear[-1]:8.3f} %), "
                 f"{n_f} residuals, {n_k} tangents, {time.perf_counter() - t0:.0f} s")
    return SweepResult(np.asarray(masses, float), np.array(out), np.array(linear),
                       time.perf_counter() - t0, its, tol, u_w, u_lin_w, states, linear_states)


#: the ROM's validity envelope: |ROM − FE| ≤ this fraction of |FE| (issue 34)
ENVELOPE_TOL = 0.02


def rom_envelope(fe_pct: np.ndarray, rom_pct: np.ndarray, rel_tol: float = ENVELOPE_TOL
                 ) -> float:
    """The largest |FE tip deflection| (% of the semispan) of the sweep's leading masses whose
    ROM deflections are all within ``rel_tol`` of the full FE's (0 when the first is not)."""
    fe_pct, rom_pct = np.abs(np.asarray(fe_pct)), np.abs(np.asarray(rom_pct))
    ok = np.abs(rom_pct - fe_pct) <= rel_tol * fe_pct
    n = len(ok) if ok.all() else int(np.argmin(ok))
    return float(fe_pct[:n].max()) if n else 0.0


@dataclass
class RomSweep:
    masses: np.ndarray
    tip_pct: np.ndarray  # % semispan, self-weight subtracted
    n_linear: int
    n_dual: int
    identify_seconds: float
    summary: dict
    envelope_pct: float = 0.0  # rom_envelope

    @property
    def label(self) -> str:
        """The figure's legend: the basis and the stiffness identification."""
        if self.summary.get("stiffness_method") == "condensed":
            return (f"torchrom ROM ({self.n_linear} modes, condensed to "
                    f"{100 * self.summary['amplitude']:g} % of the span)")
        return f"torchrom ROM ({self.n_linear} linear + {self.n_dual} dual modes)"


def rom_sweep(fe, masses, *, n_linear: int, n_dual: int = 0, combinations=(),
              n_amplitudes: int = 8, tip_range=(0.01, 0.25), stiffness: str = "condensed",
              amplitude: float | None = None, levels: int = 3, condensation_fit: str = "forces",
              progress=print) -> RomSweep:
    """Identify the ROM of ``fe`` (:func:`torchrom.identify.build.identify`: ``stiffness``
    "condensed" (linear modes only) or "tangent" (with ``n_dual`` dual modes of the
    ``combinations``); the damping by decomposition, which the static curve does not use) and
    solve its static tip-mass sweep: the load Φᵀ F(m), the tip displacement from u = Φ q, the
    self-weight solution subtracted; ``condensation_fit`` as
    :class:`~torchrom.identify.build.IdentifyOptions`."""
    from torchrom.identify.basis import DualModeOptions
    from torchrom.identify.build import IdentifyOptions, identify
    from torchrom.identify.validate import rom_static_solve

    opt = IdentifyOptions(n_linear=n_linear, n_dual=n_dual, damping="decomposition",
                          stiffness=stiffness, amplitude=amplitude, levels=levels,
                          condensation_fit=condensation_fit,
                          dual=DualModeOptions(combinations=combinations,
                                               n_amplitudes=n_amplitudes, tip_range=tip_range))
    t0 = time.perf_counter()
    res = identify(fe, opt)
    seconds = time.perf_counter() - t0
    progress(f"identify ({stiffness}): {n_linear} linear + {n_dual} dual modes in "
             f"{seconds:.0f} s")
    Phi = res.basis.Phi
    F_w = fe.load_vector(1)
    F_1 = fe.nodal_load({(MASS_GRID, 3): -GRAVITY})
    q_w = rom_static_solve(res.rom, Phi.T @ F_w)
    q, out = q_w, []
    for m in masses:
        q = rom_static_solve(res.rom, Phi.T @ (F_w + m * F_1), q)
        out.append(tip_percent(fe, Phi @ q, Phi @ q_w))
    return RomSweep(np.asarray(masses, float), np.array(out), n_linear, n_dual, seconds,
                    {**res.summary(), "amplitude": opt.resolved_amplitude})


def figure(masses, res: SweepResult, nl_ref, lin_ref, path: Path, rom=None) -> None:
    """Tip displacement (% semispan, downward positive) against tip mass: torchrom nonlinear
    and linear, SOL 400 and SOL 101."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.4))
    ax.plot(nl_ref[:, 0], -nl_ref[:, 1], "o", mfc="none", color="C0", label="MSC Nastran SOL 400")
    ax.plot(lin_ref[:, 0], -lin_ref[:, 1], "s", mfc="none", color="C1",
            label="MSC Nastran SOL 101")
    ax.plot(masses, -res.nonlinear, "-", color="C0", label="torchrom FE, co-rotational")
    ax.plot(masses, -res.linear, "--", color="C1", label="torchrom FE, linear")
    if rom is not None:
        ax.plot(rom.masses, -rom.tip_pct, ":", color="C2", marker=".",
                label=rom.label)
    ax.set_xlabel("tip mass (kg)")
    ax.set_ylabel("tip deflection, downward (% of semispan)")
    ax.set_title("Pazy wing (no skin, rigid tip): static bending under gravity")
    ax.grid(alpha=0.3)
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--masses", default=None, help="tip masses (kg), default: the table's")
    p.add_argument("--tol", type=float, default=1e-7)
    p.add_argument("--out", type=Path, default=None, help="JSON of the measured sweep")
    p.add_argument("--figure", type=Path, default=None, help="PNG of the sweep")
    p.add_argument("--rom", default=None, metavar="L,D",
                   help="also identify a ROM of L linear and D dual modes and sweep it (D = 0 "
                        "with --stiffness condensed, e.g. 2,0)")
    p.add_argument("--stiffness", default="condensed", choices=("condensed", "tangent", "step"),
                   help="the ROM's stiffness identification (default condensed)")
    p.add_argument("--amplitude", type=float, default=None,
                   help="identification amplitude, fraction of the span (default: the "
                        "method's, 0.3 for condensed)")
    p.add_argument("--levels", type=int, default=3, help="condensation load levels")
    p.add_argument("--combinations", default="1:1,1:2", help="dual-mode load pairs J:L,...")
    p.add_argument("--amplitudes", type=int, default=8, help="loads per combination")
    p.add_argument("--tip-range", default="0.01,0.25",
                   help="dual-mode loads' tip deflections, fractions of the span")
    p.add_argument("--fe-from", type=Path, default=None, metavar="JSON",
                   help="take the full-FE sweep from an earlier run's --out JSON (same "
                        "masses) instead of solving it again")
    args = p.parse_args(argv)
    nl_ref, lin_ref = sweep_table(SOL400), sweep_table(SOL101)
    masses = nl_ref[:, 0] if args.masses is None else \
        np.array([float(x) for x in args.masses.split(",")])
    t = time.perf_counter()
    fe = pazy_model()
    print(f"model: {fe.n_dof} DOFs, rotations={fe.rotations}, read in "
          f"{time.perf_counter() - t:.1f} s")
    if args.fe_from is not None:
        old = json.loads(args.fe_from.read_text())
        if not np.allclose(old["masses_kg"], masses):
            raise SystemExit(f"{args.fe_from}: masses {old['masses_kg']}, expected "
                             f"{masses.tolist()}")
        res = SweepResult(masses, np.array(old["nonlinear_pct"]), np.array(old["linear_pct"]),
                          old["seconds"], old["iterations"], old["tol"])
        print(f"sweep: from {args.fe_from} ({res.seconds:.1f} s when it was solved)")
    else:
        res = nonlinear_sweep(fe, masses, tol=args.tol)
    print(f"sweep: {len(masses)} masses in {res.seconds:.1f} s, iterations {res.iterations}")
    print("| mass kg | SOL 400 % | torchrom NL % | diff (% semispan) | SOL 101 % | "
          "torchrom linear % |")
    for m, a, b in zip(masses, res.nonlinear, res.linear):
        r4 = np.interp(m, nl_ref[:, 0], nl_ref[:, 1])
        r1 = np.interp(m, lin_ref[:, 0], lin_ref[:, 1])
        print(f"| {m:.2f} | {r4:.3f} | {a:.3f} | {a - r4:+.3f} | {r1:.3f} | {b:.3f} |")
    rom = None
    if args.rom:
        n_lin, n_dual = (int(x) for x in args.rom.split(","))
        pairs = [tuple(int(x) for x in c.split(":")) for c in args.combinations.split(",")]
        lo, hi = (float(x) for x in args.tip_range.split(","))
        rom = rom_sweep(fe, masses, n_linear=n_lin, n_dual=n_dual, combinations=pairs,
                        n_amplitudes=args.amplitudes, tip_range=(lo, hi),
                        stiffness=args.stiffness, amplitude=args.amplitude, levels=args.levels)
        print("| mass kg | torchrom FE NL % | ROM % | ROM - FE (% of FE) |")
        for m, a, b in zip(masses, res.nonlinear, rom.tip_pct):
            rel = "" if a == 0 else f"{100 * (b - a) / abs(a):+.2f}"
            print(f"| {m:.2f} | {a:.3f} | {b:.3f} | {rel} |")
        loaded = masses > 0
        rom.envelope_pct = rom_envelope(res.nonlinear[loaded], rom.tip_pct[loaded])
        print(f"ROM envelope: within {100 * ENVELOPE_TOL:g} % of the full FE up to a tip "
              f"deflection of {rom.envelope_pct:.1f} % of the semispan")
    if args.figure:
        figure(masses, res, nl_ref, lin_ref, args.figure, rom)
        print(f"figure: {args.figure}")
    if args.out:
        args.out.write_text(json.dumps({
            "masses_kg": masses.tolist(), "nonlinear_pct": res.nonlinear.tolist(),
            "linear_pct": res.linear.tolist(), "seconds": res.seconds,
            "iterations": res.iterations, "tol": res.tol,
            "semispan_m": PAZY_SEMISPAN, "tip_arm_m": PAZY_TIP_ARM,
            "rom": None if rom is None else {
                "n_linear": rom.n_linear, "n_dual": rom.n_dual, "tip_pct": rom.tip_pct.tolist(),
                "stiffness": args.stiffness, "amplitude": rom.summary["amplitude"],
                "levels": args.levels,
                "identify_seconds": rom.identify_seconds, "combinations": args.combinations,
                "amplitudes": args.amplitudes, "tip_range": args.tip_range,
                "envelope_pct_semispan": rom.envelope_pct}}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
