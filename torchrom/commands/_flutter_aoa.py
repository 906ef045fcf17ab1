"""``torchrom flutter ROM.npz AERO.npz --aoa DEG [DEG ...]``: flutter of the ROM about its static
aeroelastic equilibrium at each root angle of attack (:mod:`torchrom.trim.reduced`): the
equilibrium continued in speed, the tangent's roots at each speed, and the onsets (a root's
damping from − to +) and offsets (back) with speed, frequency and the tip deflection there.

``torchrom flutter DECK --aoa DEG ... --velocities V ...``: the same by the FE ("SOL 400, then
SOL 145"): the nonlinear equilibrium of the deck's FE model and p-k on the modes of its
tangent (:mod:`torchrom.trim.flutter`), or with ``--linear-skin PID`` the exact condensation
on the deck's modes of the model without those shells, their linear stiffness kept
(:mod:`torchrom.trim.condensed`, as ``identify --linear-skin``). JSON as below without
``envelope_ratio`` and ``q``; ``route`` says which.

JSON (``--json FILE``): ``rom``, ``aero``, ``density``, ``alpha`` (1/s), ``gamma`` (s),
``damping`` (where α, γ came from: :mod:`._damping`),
``units`` (labels of speed, density, length), ``tip`` (``output``, the ROM output read as the tip
deflection, and ``semispan``, null without ``--semispan``), ``methods``, ``boundaries``: one
object per crossing with ``method``, ``aoa_deg``, ``kind`` (onset/offset), ``velocity``,
``frequency_hz``, ``tip_deflection`` (length unit), ``tip_deflection_pct_semispan`` and
``envelope_ratio``;
``equilibria``: one object per angle and speed with ``aoa_deg``, ``velocity``, ``converged``,
``tip_deflection``, ``tip_deflection_pct_semispan``, ``envelope_ratio`` (above 1: beyond the
loads the ROM's nonlinear terms were fitted to, :func:`torchrom.trim.reduced.envelope_ratio`;
for a ROM about rest, fitted over that range, an extrapolation; for one about a state, whose
terms are the potential's Taylor terms there, a distance to check against the FE), ``q``
(the ROM coordinates),
``natural_hz`` (the tangent's), and per method its critical root's ``damping`` and
``frequency_hz``; ``notes``; ``time_s``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from ..errors import InputError

#: speeds of the default sweep, from V_D/N to 0.98 V_D (V_D: the undeformed ROM's divergence)
DEFAULT_SPEEDS = 60


def add_arguments(p: argparse.ArgumentParser) -> None:
    from ._common import finite_float, positive_float, positive_int

    g = p.add_argument_group("about the deformed wing (ROM.npz AERO.npz with --aoa)")
    g.add_argument("--aoa", type=finite_float, nargs="+", default=None, metavar="DEG",
                   help="root angles of attack (deg, nose up about the aero y axis): flutter "
                        "about the ROM's static aeroelastic equilibrium at each")
    g.add_argument("--velocities", type=positive_float, nargs="+", default=None, metavar="V",
                   help="ascending speeds (the files' speed unit; default: 60 up to 0.98 of "
                        "the undeformed ROM's static divergence speed)")
    g.add_argument("--tip-output", default=None, metavar="NAME",
                   help="the ROM output read as the tip deflection (default: the ROM's first)")
    g.add_argument("--semispan", type=positive_float, default=None, metavar="L",
                   help="semispan (the files' length unit) for the tip deflection in %%")
    g.add_argument("--linear-skin", type=positive_int, action="append", default=None,
                   metavar="PID", help="deck form: the shells of this PSHELL stay linear (a "
                   "foil skin): the exact condensation on the deck's modes of the model "
                   "without them (repeatable)")


#: the options only the --aoa form reads
AOA_ONLY = ("velocities", "tip_output", "semispan", "linear_skin")


def refuse_stray_options(args: argparse.Namespace) -> None:
    for name in AOA_ONLY:
        if getattr(args, name) is not None:
            raise InputError(f"--{name.replace('_', '-')}: only with --aoa (flutter about the "
                             "deformed wing, torchrom flutter ROM.npz AERO.npz --aoa DEG)")


def _refuse_matched_point_options(args) -> None:
    for option, given in (("--alpha-for-gamma", args.alpha_for_gamma),
                          ("--root-locus", args.root_locus), ("--plot", args.plot),
                          ("--at", args.at), ("--alt-range", args.alt_range)):
        if given:
            raise InputError(f"{option}: not with --aoa (flutter about the deformed wing at "
                             "one density, swept in speed)")


def _ascending(velocities) -> np.ndarray:
    v = np.asarray(velocities, dtype=float)
    if np.any(np.diff(v) <= 0):
        raise InputError("--velocities: expected ascending speeds")
    return v


def _speeds(args, rom, steady, density: float) -> np.ndarray:
    if args.velocities is not None:
        return _ascending(args.velocities)
    # the lowest q > 0 with K1 + q Q0 singular: the eigenvalues μ of −K1⁻¹ Q0, q = 1/μ
    mu = np.linalg.eigvals(-np.linalg.solve(rom.K1.numpy(), steady.Q0))
    real = mu[(np.abs(mu.imag) <= 1e-9 * np.abs(mu).max()) & (mu.real > 0)].real
    if not len(real):
        raise InputError("--velocities: the ROM has no static divergence to size the default "
                         "sweep by; give the speeds")
    v_div = float(np.sqrt(2.0 / (density * real.max())))
    return np.linspace(0.98 * v_div / DEFAULT_SPEEDS, 0.98 * v_div, DEFAULT_SPEEDS)


def _tip(args, rom) -> tuple[str, np.ndarray]:
    if not rom.outputs:
        raise InputError("--aoa: the ROM has no outputs to read the tip deflection from "
                         "(identify it with --output NAME=GRID:COMPONENT)")
    name = args.tip_output or next(iter(rom.outputs))
    if name not in rom.outputs:
        raise InputError(f"--tip-output: no output {name!r} in the ROM (it has "
                         f"{', '.join(rom.outputs)})")
    return name, np.asarray(rom.outputs[name])


def run(args, rom_path, aero_path) -> int:
    from ..aero.files import load_aero
    from ..rom import NonlinearROM
    from ..sim.aeroelastic import check_aero_matches_rom
    from ..trim.reduced import (
        SteadyModalAero,
        deformed_flutter,
        envelope_ratio,
        rom_equilibria,
        root_finder,
    )
    from ..units import file_units
    from ._common import maybe_write_json

    t0 = time.perf_counter()
    if args.density is None or len(args.density) != 1:
        raise InputError("--density: --aoa needs one air density (the model's density unit)")
    _refuse_matched_point_options(args)
    rom = NonlinearROM.load(rom_path)
    aero = load_aero(aero_path)
    check_aero_matches_rom(rom, aero)
    system, note = file_units({str(rom_path): rom.metadata, str(aero_path): aero.metadata},
                              args.units)
    if note:
        print(f"  {note}")
    u = system.labels()
    density = float(args.density[0])
    steady = SteadyModalAero.from_aero(aero, rom.n, str(aero_path))
    speeds = _speeds(args, rom, steady, density)
    tip_name, tip_row = _tip(args, rom)
    from ._damping import damping_for_rom

    damping = damping_for_rom(args, rom, rom_path)
    print(f"  {damping.description}")
    alpha, gamma = damping.alpha, damping.gamma
    eq = rom_equilibria(rom, steady, args.aoa, speeds, density)
    methods = {"both": ["state-space", "p-k"], "pk": ["p-k"]}.get(args.method, [args.method])
    results = [deformed_flutter(rom, eq, root_finder(m, rom, aero), alpha, gamma)
               for m in methods]

    from ..rom.reference import reference_q

    def tip(q):  # q: the ROM's coordinates (x = q − q_ref about a deformed state)
        d = float(tip_row @ (q + reference_q(rom)))
        return d, (100.0 * d / args.semispan if args.semispan else None)

    print(f"  flutter about the ROM's static aeroelastic equilibrium: density {density:g} "
          f"{u['density']}, {len(speeds)} speeds {speeds[0]:.4g} .. {speeds[-1]:.4g} "
          f"{u['speed']}, alpha = {alpha:g} 1/s, gamma = {gamma:g} s; tip: output {tip_name}")
    print(f"  {'method':<12}{'AoA deg':>8}  {'kind':<7}{'V ' + u['speed']:>10}"
          f"{'f Hz':>9}{'tip ' + u['length']:>12}{'% semispan':>11}{'envelope':>10}")
    rows = []
    for res in results:
        for a, found in enumerate(res.boundaries):
            if not found:
                print(f"  {res.method:<12}{eq.aoa_deg[a]:8.3g}  no onset or offset in the speeds")
            for b in found:
                q0 = res.state_at(a, b)
                d, pct = tip(q0)
                env = float(envelope_ratio(rom, q0))
                print(f"  {res.method:<12}{eq.aoa_deg[a]:8.3g}  {b.kind:<7}{b.velocity:10.3f}"
                      f"{b.frequency_hz:9.3f}{d:12.5g}{'-' if pct is None else f'{pct:.2f}':>11}"
                      f"{env:10.2f}" + ("  beyond the identification's solves" if env > 1 else ""))
                rows.append({"method": res.method, "aoa_deg": float(eq.aoa_deg[a]),
                             "kind": b.kind, "velocity": b.velocity,
                             "frequency_hz": b.frequency_hz, "tip_deflection": d,
                             "tip_deflection_pct_semispan": pct, "envelope_ratio": env})
    for n in eq.notes:
        print(f"  note: {n}")
    states = []
    for a in range(len(eq.aoa_deg)):
        for i, v in enumerate(eq.velocity):
            item = {"aoa_deg": float(eq.aoa_deg[a]), "velocity": float(v),
                    "converged": bool(eq.converged[a, i])}
            if eq.converged[a, i]:
                d, pct = tip(eq.q[a, i])
                p0 = results[0].points[a][i]
                item.update(tip_deflection=d, tip_deflection_pct_semispan=pct,
                            envelope_ratio=float(envelope_ratio(rom, eq.q[a, i])),
                            q=eq.q[a, i].tolist(), natural_hz=p0.natural_hz.tolist())
                for res in results:
                    g, f = res.points[a][i].critical
                    item[res.method] = {"damping": g, "frequency_hz": f}
            states.append(item)
    maybe_write_json(args, {
        "rom": str(rom_path), "aero": str(aero_path), "density": density, "alpha": alpha,
        "gamma": gamma, "damping": damping.as_metadata(), "units": u,
        "tip": {"output": tip_name, "semispan": args.semispan},
        "methods": methods, "boundaries": rows, "equilibria": states, "notes": eq.notes,
        "time_s": time.perf_counter() - t0})
    print(f"  done in {time.perf_counter() - t0:.1f} s")
    return 0


def run_deck(args, path) -> int:
    """The deck form (module docstring): at each angle, the equilibria continued through
    ``--velocities`` and the p-k roots about each; the deck's PARAM LMODES (else its EIGRL's
    ND, else 10) modes."""
    import math

    from ..aero.flutter import AeroTable, ModalStructure
    from ..aero.nastran_flutter import NASTRAN_KERNEL, load_deck
    from ..errors import ConvergenceError
    from ..fe import read_bdf
    from ..trim.flutter import boundaries, spline_gaf, stability_at
    from ..trim.operators import spline_grids
    from ..trim.reduced import PkRoots, SteadyModalAero
    from ._common import maybe_write_json
    from ._static_aero import _tip, _tip_reading

    t0 = time.perf_counter()
    if args.velocities is None:
        raise InputError("--velocities: the deck form of --aoa needs the speeds (the deck's "
                         "length unit per second)")
    if args.tip_output is not None:
        raise InputError("--tip-output: for ROM.npz AERO.npz (a deck's tip is its spline grid "
                         "farthest along the aero y axis)")
    _refuse_matched_point_options(args)
    speeds = _ascending(args.velocities)
    deck = load_deck(path, require_flutter=False)
    if args.density is not None and len(args.density) != 1:
        raise InputError("--density: --aoa needs one air density")
    density = float(args.density[0]) if args.density else float(deck.reference.rho_ref)
    mach = float(args.mach or 0.0)
    fe = read_bdf(path)
    n = min(int(deck.lmodes or deck.n_modes or 10), fe.n_dof)
    tip, semispan = _tip(argparse.Namespace(tip=None, semispan=args.semispan), fe, deck,
                         argparse.Namespace(grid_ids=spline_grids(deck)))
    skin = list(args.linear_skin or [])
    route = ("FE exact condensation on the deck's modes, shells of PSHELL "
             f"{', '.join(map(str, skin))} linear" if skin else
             "FE nonlinear equilibrium, p-k on the modes of its tangent")
    print(f"  flutter about the deformed wing: {route}; {n} modes, density {density:g}, "
          f"Mach {mach:g}, tip grid {tip}")
    rows, states, notes = [], [], []
    if skin:
        from ..aero.build import build_from_deck
        from ..trim.condensed import deck_condensation

        modes = fe.modes(n)
        aero = build_from_deck(path, fe, mach, n, kernel=NASTRAN_KERNEL)
        steady = SteadyModalAero.from_aero(aero, n, str(path))
        model = deck_condensation(fe, modes.shapes,
                                  np.diag((2 * np.pi * modes.frequencies_hz) ** 2), skin)
        finder = PkRoots(AeroTable.from_gaf(aero.gaf), mach)

        def sweep(aoa):
            p, u = np.zeros(n), None
            for v in speeds:
                try:
                    st = model.equilibrium(steady, 0.5 * density * v**2, math.radians(aoa),
                                           p, u)
                except ConvergenceError as exc:  # reported; the sweep stops there
                    notes.append(f"aoa {aoa:g} deg, {v:g}: {exc}")
                    return
                p, u = st.p, st.u
                pt = finder(ModalStructure(np.eye(n), model.tangent(st)), float(v), density)
                yield pt, _tip_reading(fe, deck, fe.expand(modes.shapes @ st.q), tip, False)[0]
    else:
        from ..trim.equilibrium import nonlinear_sweep
        from ..trim.operators import steady_operator

        op = steady_operator(fe, deck, mach=mach)
        gaf = spline_gaf(deck, op)

        def sweep(aoa):
            for e in nonlinear_sweep(fe, op, speeds, density, math.radians(aoa)):
                if not e.converged:
                    notes.append(f"aoa {aoa:g} deg, {e.velocity:g}: {e.message}")
                    return
                yield (stability_at(fe, op, gaf, e.u, e.velocity, density, n),
                       _tip_reading(fe, deck, fe.expand(e.u, large=True), tip, True)[0])
    for aoa in args.aoa:
        solved = list(sweep(aoa))
        points, tips = [x[0] for x in solved], [x[1] for x in solved]
        for pt, w in zip(points, tips):
            g, f = pt.critical
            states.append({"aoa_deg": float(aoa), "velocity": pt.velocity, "converged": True,
                           "tip_deflection": w,
                           "tip_deflection_pct_semispan": 100.0 * w / semispan,
                           "natural_hz": pt.natural_hz.tolist(),
                           "p-k": {"damping": g, "frequency_hz": f}})
        found = boundaries(points)
        if not found:
            print(f"  {'p-k':<12}{aoa:8.3g}  no onset or offset in the speeds")
        for b in found:
            w = float(np.interp(b.velocity, [q.velocity for q in points], tips))
            print(f"  {'p-k':<12}{aoa:8.3g}  {b.kind:<7}{b.velocity:10.3f}{b.frequency_hz:9.3f}"
                  f"{w:12.5g}{100.0 * w / semispan:11.2f}")
            rows.append({"method": "p-k", "aoa_deg": float(aoa), "kind": b.kind,
                         "velocity": b.velocity, "frequency_hz": b.frequency_hz,
                         "tip_deflection": w, "tip_deflection_pct_semispan": 100 * w / semispan})
    for note in notes:
        print(f"  note: {note}")
    maybe_write_json(args, {"deck": str(path), "route": route, "density": density,
                            "mach": mach, "modes": n, "tip": {"grid": tip, "semispan": semispan},
                            "methods": ["p-k"], "boundaries": rows, "equilibria": states,
                            "notes": notes, "time_s": time.perf_counter() - t0})
    print(f"  done in {time.perf_counter() - t0:.1f} s")
    return 0
