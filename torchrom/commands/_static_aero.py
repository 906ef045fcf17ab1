"""``torchrom static DECK --aoa DEG --velocity V [V ...]`` (or a SOL 144 deck with TRIM/ANGLEA):
the static aeroelastic equilibrium of a restrained wing at a root angle of attack, linear as
SOL 144 or geometrically nonlinear (``--nonlinear``, as SOL 400 under the steady loads),
continued in speed (:mod:`torchrom.trim`).

JSON (``--json FILE``): ``deck``, ``analysis`` (``static aeroelastic, linear`` or ``...,
nonlinear``), ``loads`` (the steady aerodynamic loads' description), ``units``, ``frame``
(``basic`` for the displacements), ``components``, ``aoa_deg``, ``mach``, ``density``,
``tip`` (``grid``, ``semispan`` in the deck's length unit), ``divergence`` (linear: the static
divergence ``dynamic_pressure`` and ``velocity``, null without one) and ``speeds``: one object
per speed with ``velocity``, ``dynamic_pressure``, ``converged``, ``message``, ``iterations``,
``tip_deflection`` (along the aero frame's z, length unit), ``tip_deflection_pct_semispan``,
``tip_twist_deg`` (nose up about the aero y axis), ``displacements``: grid ID →
[T1 .. R3] in the basic frame (null where not converged) and, with ``--modes N``,
``natural_hz`` (the N lowest natural frequencies about the equilibrium, Hz).
"""

from __future__ import annotations

import argparse
import math
import re
import time
from pathlib import Path

import numpy as np

from ..errors import InputError

COMPONENTS = ("T1", "T2", "T3", "R1", "R2", "R3")
LOADS = ("steady aerodynamic (k = 0 doublet lattice = vortex lattice) on the undeformed boxes: "
         "the root incidence's and the deflection's (aerodynamic stiffness), through the "
         "deck's splines; no gravity")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ._common import finite_float, nonnegative_float, positive_float, positive_int

    group = parser.add_argument_group(
        "static aeroelastic (a restrained wing at a root angle of attack: the deck's CAERO1 "
        "panels, SPLINEs and AERO card; a SOL 144 deck's TRIM/ANGLEA when --aoa is not given)")
    group.add_argument("--aoa", type=finite_float, default=None, metavar="DEG",
                       help="root angle of attack (deg, nose up about the aero y axis)")
    group.add_argument("--velocity", type=positive_float, nargs="+", default=None,
                       metavar="V", help="speeds (the deck's length unit per second), solved "
                                         "in this order (the nonlinear solution continues "
                                         "from one to the next)")
    group.add_argument("--density", type=positive_float, default=None, metavar="RHO",
                       help="air density (default: the AERO card's RHOREF)")
    group.add_argument("--mach", type=nonnegative_float, default=None, metavar="M",
                       help="Mach number (default 0, or the TRIM card's)")
    group.add_argument("--tip", type=positive_int, default=None, metavar="GRID",
                       help="the grid whose deflection and twist are reported (default: the "
                            "spline grid farthest along the aero y axis)")
    group.add_argument("--semispan", type=positive_float, default=None, metavar="L",
                       help="semispan for the % figures (default: the half model's boxes' "
                            "largest aero y)")
    group.add_argument("--modes", type=positive_int, default=None, metavar="N",
                       help="also the N lowest natural frequencies about each equilibrium "
                            "(--nonlinear: of the tangent stiffness there, as SOL 106 + "
                            "eigenvalues; linear: of the undeformed structure)")


#: the options that only the static aeroelastic solution reads
AERO_ONLY = ("density", "mach", "tip", "semispan", "modes")


def refuse_stray_options(args: argparse.Namespace) -> None:
    """An aeroelastic option given to a deck's structural subcases is refused, not ignored."""
    for name in AERO_ONLY:
        if getattr(args, name) is not None:
            raise InputError(f"--{name}: only for the static aeroelastic solution (--aoa DEG "
                             f"--velocity V ..., or a SOL 144 deck)")


def is_static_aeroelastic(args: argparse.Namespace) -> bool:
    """Whether the command asks for, or the deck is, a static aeroelastic solution."""
    if args.aoa is not None or args.velocity is not None:
        return True
    try:
        head = Path(args.model).read_text(errors="replace").upper().split("CEND", 1)[0]
    except OSError:
        return False  # the reader's own message follows
    return re.search(r"^\s*SOL\s+144\b", head, re.MULTILINE) is not None


def _cases(args, deck, model) -> list[tuple[float, float, float]]:
    """(velocity, aoa_rad, mach) per speed from the options or the deck's TRIM cards."""
    from ..trim.cards import read_trims

    density = args.density or deck.reference.rho_ref
    if args.aoa is not None:
        if args.velocity is None:
            raise InputError("--aoa: expected --velocity V [V ...] with it")
        return [(float(v), math.radians(args.aoa), args.mach or 0.0) for v in args.velocity]
    if args.velocity is not None:
        raise InputError("--velocity: expected --aoa DEG with it (the root angle of attack)")
    trims = read_trims(model, args.model)
    if not trims:
        raise InputError(f"{args.model}: SOL 144: no TRIM card; give --aoa DEG and --velocity "
                         "V [V ...]")
    return [(math.sqrt(2.0 * t.dynamic_pressure / density), t.aoa_rad,
             args.mach if args.mach is not None else t.mach) for t in trims]


def _tip(args, fe, deck, op) -> tuple[int, float]:
    if args.tip is not None:
        if args.tip not in set(fe.grid_ids.tolist()):
            raise InputError(f"--tip: grid {args.tip} not found in {args.model.name}")
        tip = int(args.tip)
    else:
        xyz = deck.frame.points(fe.grid_xyz[[fe.mesh.grid_row()[int(g)] for g in op.grid_ids]])
        tip = int(op.grid_ids[int(np.argmax(xyz[:, 1]))])
    semispan = args.semispan or float(deck.panels.corners[:, :, 1].max())
    return tip, semispan


def _tip_reading(fe, deck, full: np.ndarray, tip: int, large: bool) -> tuple[float, float]:
    """(deflection along the aero z, twist deg nose up about the aero y) of grid ``tip`` in the
    expanded displacements ``full`` (n_grid, 6)."""
    import torch

    from ..fe.elements.corotational import rotation_exp

    d = full[fe.mesh.grid_row()[tip]]
    t, r = deck.frame.vectors(d.reshape(2, 3))
    if not large:
        return float(t[2]), math.degrees(float(r[1]))
    R = rotation_exp(torch.from_numpy(np.asarray(r, float))).numpy()
    return float(t[2]), math.degrees(math.asin(-float(R[2, 0])))


def run(args: argparse.Namespace) -> int:
    from ..aero.nastran_flutter import load_deck
    from ..aero.panels import read_model
    from ..fe import read_bdf
    from ..fe.solvers import factor_symmetric
    from ..trim.equilibrium import LinearSolver, linear_sweep, nonlinear_sweep
    from ..trim.operators import steady_operator
    from ._common import check_outputs, maybe_write_json

    check_outputs(args, [])
    if args.linear and args.nonlinear:
        raise InputError("--linear and --nonlinear: expected one of them")
    deck = load_deck(args.model, require_flutter=False)
    model = read_model(args.model)
    cases = _cases(args, deck, model)
    machs = {m for _, _, m in cases}
    if len(machs) > 1:
        raise InputError(f"{args.model}: TRIM cards at several Mach numbers {sorted(machs)}: "
                         "expected one (run one deck per Mach number)")
    density = args.density or deck.reference.rho_ref
    t0 = time.perf_counter()
    fe = read_bdf(args.model)
    op = steady_operator(fe, deck, mach=machs.pop())
    nonlinear = bool(args.nonlinear)
    kind = "nonlinear" if nonlinear else "linear"
    tip, semispan = _tip(args, fe, deck, op)
    print(f"{args.model}: static aeroelastic, {kind}; {fe.n_dof} free DOFs, {op.n_boxes} boxes, "
          f"{len(op.grid_ids)} spline grids; density {density:g}, Mach {op.mach:g}; tip grid "
          f"{tip}, semispan {semispan:.6g} ({time.perf_counter() - t0:.1f} s)")
    divergence = None
    if not nonlinear:
        K = factor_symmetric(fe.stiffness_matrix())
        q_div = LinearSolver(K, op).divergence_pressure()
        if q_div is not None:
            divergence = {"dynamic_pressure": q_div,
                          "velocity": math.sqrt(2.0 * q_div / density)}
            print(f"static divergence: q = {q_div:.6g}, V = {divergence['velocity']:.6g} at "
                  f"density {density:g}")
    results = []
    for aoa in sorted({a for _, a, _ in cases}):
        speeds = [v for v, a, _ in cases if a == aoa]
        if nonlinear:
            def show(e, aoa=aoa):
                state = "converged" if e.converged else f"NOT CONVERGED: {e.message}"
                print(f"  V = {e.velocity:g}: {state} ({e.iterations} iterations, "
                      f"{time.perf_counter() - t0:.0f} s)")
            sweep = nonlinear_sweep(fe, op, speeds, density, aoa, progress=show)
        else:
            sweep = linear_sweep(fe, op, speeds, density, aoa, K_factor=K)
        results += [(aoa, e) for e in sweep]
    ids = [str(int(g)) for g in fe.grid_ids]
    records = []
    linear_hz = (None if args.modes is None or nonlinear
                 else fe.modes(args.modes).frequencies_hz.tolist())
    print(f"{'AoA (deg)':>9} {'V':>10} {'q':>12} {'tip defl.':>12} {'% semispan':>10} "
          f"{'twist (deg)':>11}")
    for aoa, e in results:
        rec = {"aoa_deg": math.degrees(aoa), "velocity": e.velocity,
               "dynamic_pressure": e.dynamic_pressure, "converged": e.converged,
               "message": e.message, "iterations": e.iterations, "tip_deflection": None,
               "tip_deflection_pct_semispan": None, "tip_twist_deg": None,
               "displacements": None}
        if e.converged:
            full = fe.expand(e.u, large=nonlinear)
            w, twist = _tip_reading(fe, deck, full, tip, nonlinear)
            rec.update(tip_deflection=w, tip_deflection_pct_semispan=100.0 * w / semispan,
                       tip_twist_deg=twist,
                       displacements={g: [float(x) for x in row] for g, row in zip(ids, full)})
            print(f"{math.degrees(aoa):9.4g} {e.velocity:10.5g} {e.dynamic_pressure:12.6g} "
                  f"{w:12.6g} {100.0 * w / semispan:10.4f} {twist:11.4f}")
            if args.modes is not None:
                from ..trim.modes import tangent_modes

                hz = linear_hz or tangent_modes(fe, e.u, args.modes).frequencies_hz.tolist()
                rec["natural_hz"] = hz
                print(f"{'':>9} natural frequencies (Hz): " + ", ".join(f"{f:.4g}" for f in hz))
        else:
            print(f"{math.degrees(aoa):9.4g} {e.velocity:10.5g} {e.dynamic_pressure:12.6g} "
                  f"not solved: {e.message}")
        records.append(rec)
    maybe_write_json(args, {
        "deck": str(args.model), "analysis": f"static aeroelastic, {kind}", "loads": LOADS,
        "units": dict(getattr(fe, "units", {}) or {}), "frame": "basic",
        "components": list(COMPONENTS), "mach": op.mach, "density": density,
        "tip": {"grid": tip, "semispan": semispan}, "divergence": divergence,
        "speeds": records})
    return 0
