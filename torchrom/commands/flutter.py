"""``torchrom flutter``: SOL 145-style flutter of a deck, or matched-point flutter of a ROM.

Forms:
  torchrom flutter DECK.bdf                      FLUTTER/FLFACT/MKAERO cards of the deck (PK, KE)
  torchrom flutter ROM.npz AERO.npz [--mach M]   matched point at fixed Mach (p-k + state space);
                                                 at Mach 0, the flutter speed per altitude;
                                                 with --density RHO, the speed at that density
  torchrom flutter goland [--aero AERO.npz]      built-in heavy Goland wing, compared with the paper
  torchrom flutter ROM.npz AERO.npz --aoa DEG --density RHO
                                                 about the ROM's static aeroelastic equilibrium
                                                 at a root angle of attack (:mod:`._flutter_aoa`)
  torchrom flutter DECK --aoa DEG --velocities V ...
                                                 the same by the FE (SOL 400, then SOL 145)

JSON (--json), deck form: {"deck", "title", "modal_frequencies_hz", "flutter": [{flutter_id,
method, mach, density_ratio, mode, kind ("sustained": unstable to the last speed; "hump": stable
again at stable_velocity), velocity (deck units / VREF), frequency_hz, stable_velocity,
stable_frequency_hz, density, dynamic_pressure, reduced_frequency, refined (solved between the
sweep's speeds)}], "rigid_body_roots": [the same, for the roots of rigid-body modes: not
flutter], "unstable_at_first_speed": [{flutter_id, method, mach, density_ratio, mode,
velocity, damping_g, frequency_hz}], "vg": [{..., mode, velocity, damping_g, frequency_hz,
reduced_frequency, eigenvalue_real, eigenvalue_imag}], "notes", "g_tolerance", "divergence":
[the flutter records of real roots crossing zero, divergence true: never flutter],
"not_loaded": [{flutter_id, method, mach, density_ratio, mode, frequency_hz,
max_abs_damping_g}: modes whose |g| stays within g_tolerance, never flutter]}.
F06 (--f06 FILE, every form but --aoa): every root's V-g table in the layout of Nastran's FLUTTER
SUMMARY, read by pyNastran's flutter reader (:mod:`torchrom.aero.f06_summary`).
Damping tolerance (--g-tolerance G, default 1e-3, every form): a crossing counts only where g
goes from below -G to above +G (:mod:`torchrom.aero.crossings`).
Units: the ROM form's numbers are in the unit system the files record (torchrom.units; "units"
holds the label of each quantity: altitude, speed, density, dynamic_pressure, ...); altitudes
(--alt-range, --at, every altitude printed, in the JSON and on the figures) in the run's one
altitude unit: the system's (m for si and mm-t-s, ft for ft-slug-s and in-lbf-s) or
--altitude-unit's; each flutter record names it ("altitude_unit").
Matched-point form: {"mach", "alpha" (1/s), "gamma" (s), "units", "flutter": [{method, altitude,
frequency_hz, velocity, density, dynamic_pressure, mode}], "growing_response": [{altitude,
frequency_hz_state_space, frequency_hz_pk}], "alpha_for_gamma": [{gamma, alpha, altitude}],
"paper": {...} (Goland only)}. With an aero file at Mach 0 (incompressible), no matched point:
{"mach": 0, "alpha", "gamma", "units", "flutter": [{method, altitude, density, velocity,
frequency_hz, dynamic_pressure, mode, kind, stable_velocity, rigid_body_crossings: [{mode,
velocity}], g_tolerance, divergence_velocity, divergence_mode, not_loaded_modes, speed_range,
agrees_with_pk (state space: within 1 % of the p-k)}], "g_tolerance", "rfa_check" (the aero
file's record of its reduced frequencies, :mod:`torchrom.aero.reduced_frequencies`)}, the
flutter speed at the density of each altitude; the same with --density at the aero file's Mach
(altitude null). A free aircraft's rigid-body roots are never a flutter
point, by p-k or the state space: they are printed apart and listed in
``rigid_body_crossings`` (matched point: [{mode, altitude}]). The ROM forms and goland also
hold "damping": {alpha, gamma, source, description, frequencies_hz, zeta_target, zeta_fit},
the structural damping used and where it came from (:mod:`._damping`: --alpha/--gamma, else
--damping-ratio, else what rom.npz records; goland: the paper's Eq. 46 values).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..units import ALTITUDE_UNITS
from . import _flutter_aoa as flutter_aoa
from . import _flutter_shape
from ._common import (
    OrderedRange,
    add_force_option,
    add_json_option,
    add_units_option,
    add_unsupported_option,
    case_parameter,
    check_outputs,
    figure_file,
    finite_float,
    maybe_write_json,
    nonnegative_int,
    positive_float,
    positive_int,
    write_figure,
)
from ._damping import add_damping_ratio_option, damping_ratio_of
from ._flutter_checks import disagreement, matched_disagreement, quiet_lines, rfa_lines

NAME = "flutter"
HELP = (
    "flutter: SOL 145 analysis of a Nastran deck, or matched-point altitude of rom.npz + aero.npz"
)
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "inputs", nargs="+", metavar="INPUT", help="DECK.bdf | ROM.npz AERO.npz | goland"
    )
    p.add_argument("--mach", type=case_parameter("mach"),
                   help="Mach number (default: the aero file's)")
    p.add_argument(
        "--alt-range",
        type=finite_float,
        nargs=2,
        action=OrderedRange,
        metavar=("LO", "HI"),
        default=None,
        help="altitude range searched for the flutter point, in the run's altitude unit "
        "(--altitude-unit; default 0 to 40,000 ft = 12,192 m)",
    )
    p.add_argument("--altitude-unit", choices=tuple(ALTITUDE_UNITS), default=None,
                   help="unit of every altitude of the run: --alt-range, --at and the altitudes "
                        "printed, written and drawn (default: the model's, m for si and "
                        "mm-t-s, ft for ft-slug-s, in-lbf-s and goland)")
    p.add_argument("--alpha", type=finite_float,
                   help="mass-proportional damping α (1/s; default: the structural damping "
                        "rom.npz records, which identify took from the deck's damping cards "
                        "or --damping-ratio, else 0; goland: the paper's 0.2565)")
    p.add_argument(
        "--gamma", type=case_parameter("gamma"),
        help="stiffness-proportional damping γ (s; default: what rom.npz records, as "
             "--alpha; goland: the paper's 1.338e-4)",
    )
    add_damping_ratio_option(p, "ROM forms and goland, instead of --alpha/--gamma: ")
    p.add_argument("--method", choices=["both", "pk", "state-space"], default="both")
    p.add_argument(
        "--at",
        type=finite_float,
        nargs="+",
        metavar="ALT",
        help="altitudes (the run's altitude unit, see --altitude-unit) at which to report the "
        "growing-response frequency (default for goland: the paper's Table 3 altitudes)",
    )
    p.add_argument(
        "--aero", type=Path, help="goland form: use this aero.npz instead of building one"
    )
    p.add_argument("--lags", type=nonnegative_int, default=13,
                   help="goland form: RFA lag states (default 13)")
    p.add_argument("--variant", choices=("calibrated", "updated"), default="updated",
                   help="goland form: the heavy Goland wing variant (default updated; see "
                        "torchrom goland)")
    p.add_argument(
        "--boxes",
        type=positive_int,
        nargs=2,
        default=(8, 20),
        metavar=("NCHORD", "NSPAN"),
        help="goland form: boxes per half wing (default 8 20)",
    )
    p.add_argument(
        "--kernel", choices=["quartic", "parabolic"], default=None,
        help="DLM kernel approximation (default: parabolic for a Nastran deck, as Nastran's DLM; "
        "quartic for the built-in Goland wing)",
    )
    p.add_argument(
        "--alpha-for-gamma",
        type=case_parameter("gamma"),
        nargs="+",
        metavar="GAMMA",
        help="for each γ (s), the α (1/s) that keeps the state-space flutter altitude of the "
        "given α, γ (paper Fig. 9)",
    )
    p.add_argument("--g-tolerance", type=g_tolerance, default=None, metavar="G",
                   help="damping g within ±G counts as zero: a flutter or divergence crossing "
                        "needs g to go from below -G to above +G, and a mode whose |g| stays "
                        "within G at every speed is listed as not loaded by the aerodynamics, "
                        "never as flutter (default 1e-3 = 0.05 %% of critical damping, a tenth "
                        "of a built wing's structural damping; 0 <= G <= 0.05)")
    add_unsupported_option(p, "deck form: ")
    p.add_argument("--panels", type=Path, default=None, metavar="FILE",
                   help="deck form: aerodynamic cards read with the deck as if INCLUDEd (e.g. "
                        "from torchrom panels DECK --out FILE), the deck left as it is")
    p.add_argument("--compare", type=Path, metavar="RUN.f06",
                   help="deck form: print Nastran's flutter points and modes from this f06 beside "
                   "torchrom's, with the differences")
    p.add_argument("--plot", type=figure_file, help="write a V-g / V-f figure (PNG/PDF)")
    p.add_argument("--f06", type=Path, default=None, metavar="FILE",
                   help="write the V-g tables as Nastran's FLUTTER SUMMARY (one table per mode "
                        "and flight condition; PK/KE/PKNL layout, velocities in the model's "
                        "unit), readable by pyNastran's plot_flutter_f06 (not with --aoa)")
    p.add_argument("--symxz", type=int, choices=(-1, 0, 1), default=None,
                   help="deck form: override the deck's AERO/AEROS SYMXZ (1: reflection plane, "
                        "e.g. a wall-mounted model; -1: antisymmetric; 0: isolated half wing)")
    p.add_argument("--resvec", choices=("yes", "no"), default=None,
                   help="deck form: augment the eigenmodes with residual vectors (inertia relief; "
                        "default: the deck's RESVEC, else yes as Nastran's SOL 145); used when "
                        "PARAM LMODES asks for more modes than the EIGR/EIGRL's ND")
    p.add_argument("--length-unit", default=None, metavar="UNIT",
                   help="deck form: label of the deck's length unit (e.g. in) when it has no "
                        "DTI,UNITS card; velocities are printed in UNIT/s")
    p.add_argument("--dlm-k", type=positive_int, default=None, metavar="N",
                   help="deck form: solve the DLM at no more than N (>= 4) of the MKAERO reduced "
                        "frequencies, spread over them with both ends kept, and interpolate the "
                        "GAFs at the others (cubic spline in k); default: every k solved")
    p.add_argument("--root-locus", type=Path, help="write a state-space root-locus figure")
    p.add_argument("--density", type=positive_float, nargs="+", metavar="RHO",
                   help="ROM form: the flutter speed at these air densities (the model's density "
                        "unit, e.g. kg/m^3) at the aero file's Mach, as SOL 145's PK at one Mach "
                        "and density (a wind tunnel), instead of the matched point")
    add_units_option(p, "ROM.npz AERO.npz when they record none (default: what they record; "
                        "files of neither: ft-slug-s, said)")
    flutter_aoa.add_arguments(p)
    add_json_option(p)
    add_force_option(p)


#: the largest --g-tolerance: g = 0.05 is 2.5 % of critical damping, the crossings' hump probe
#: window (:data:`torchrom.aero.crossings.HUMP_PROBE_G`); a larger one would hide real flutter
MAX_G_TOLERANCE = 0.05


def g_tolerance(value: str) -> float:
    """argparse type of --g-tolerance: a finite damping g in [0, :data:`MAX_G_TOLERANCE`]."""
    x = finite_float(value)
    if not 0.0 <= x <= MAX_G_TOLERANCE:
        raise argparse.ArgumentTypeError(
            f"expected a damping g from 0 to {MAX_G_TOLERANCE:g} (default 1e-3), got {value!r}")
    return x


def _tolerance(args) -> float:
    """--g-tolerance, else :data:`torchrom.aero.flutter.G_TOLERANCE`."""
    from ..aero.flutter import G_TOLERANCE

    return G_TOLERANCE if args.g_tolerance is None else float(args.g_tolerance)


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError

    check_outputs(args, [p for p in (args.plot, args.root_locus, args.f06) if p is not None])
    _check_options(args)
    inputs = args.inputs
    _check_input_kinds(inputs)
    if args.aoa is not None:
        if len(inputs) == 2:
            if args.linear_skin:
                raise InputError("--linear-skin: for the deck form (torchrom flutter DECK "
                                 "--aoa DEG --velocities V ...); a ROM keeps its own skin")
            return flutter_aoa.run(args, Path(inputs[0]), Path(inputs[1]))
        if inputs[0] == "goland":
            raise InputError("--aoa: for ROM.npz AERO.npz or a deck with CAERO panels")
        return flutter_aoa.run_deck(args, Path(inputs[0]))
    flutter_aoa.refuse_stray_options(args)
    if len(inputs) == 1 and inputs[0] != "goland":
        return _run_deck(args, Path(inputs[0]))
    if len(inputs) == 1:
        return _run_goland(args)
    if len(inputs) == 2:
        return _run_rom(args, Path(inputs[0]), Path(inputs[1]))
    raise InputError(
        f"flutter: expected DECK.bdf, ROM.npz AERO.npz or goland, got {len(inputs)} inputs"
    )


def _check_input_kinds(inputs: list[str]) -> None:
    """The inputs' kinds (by content, :func:`torchrom.checks.file_kind`) against the three
    forms of the command, so that a ROM file alone is not read as a deck."""
    from ..checks import FILE_KINDS, expect_file_kind, file_kind
    from ..errors import InputError

    kinds = [file_kind(p) if p != "goland" else "goland" for p in inputs]
    for path, kind in zip(inputs, kinds):
        if kind == "missing":  # before any other input is read
            raise InputError(f"{path}: file not found (expected DECK.bdf, ROM.npz AERO.npz or "
                             f"goland)")
    if len(inputs) == 1 and kinds[0] in ("rom", "aero"):
        rom, aero = (inputs[0], "aero.npz") if kinds[0] == "rom" else ("rom.npz", inputs[0])
        raise InputError(f"{inputs[0]} is {FILE_KINDS[kinds[0]]}: give the ROM and its "
                         f"aerodynamics file together: torchrom flutter {rom} {aero} (or a "
                         f"Nastran deck with FLUTTER cards, or goland)")
    if len(inputs) == 2:
        if kinds == ["aero", "rom"]:
            raise InputError(f"{inputs[0]} is {FILE_KINDS['aero']} and {inputs[1]} "
                             f"{FILE_KINDS['rom']}: give the ROM first: torchrom flutter "
                             f"{inputs[1]} {inputs[0]}")
        for path, want in zip(inputs, ("rom", "aero")):
            expect_file_kind(path, want, "torchrom flutter ROM.npz AERO.npz")


def _check_options(args) -> None:
    """LO < HI of --alt-range, boxes and lags, before any work (the altitudes against the
    atmosphere's range in the model's units: :func:`_check_altitudes`)."""
    from ..bounds import MAX_LAGS, check_boxes, check_count
    from ..errors import InputError

    if args.alt_range is not None:
        lo, hi = args.alt_range
        if not lo < hi:
            raise InputError(f"--alt-range: expected LO < HI, got {lo:g} {hi:g}")
    if args.altitude_unit is not None and (args.aoa is not None or (
            len(args.inputs) == 1 and args.inputs[0] != "goland")):
        raise InputError("--altitude-unit: for the matched point of ROM.npz AERO.npz or goland "
                         "(a deck's FLUTTER cards and --aoa give densities, not altitudes)")
    check_boxes("--boxes", 2 * args.boxes[0] * args.boxes[1])
    check_count("--lags", "lag states", args.lags, MAX_LAGS)
    if args.panels is not None and (args.aoa is not None or len(args.inputs) != 1
                                    or args.inputs[0] == "goland"):
        raise InputError("--panels: for the deck form (torchrom flutter DECK --panels FILE): a "
                         "ROM's aerodynamics are in its aero file")
    if args.g_tolerance is not None and args.aoa is not None:
        raise InputError("--g-tolerance: not with --aoa (its onsets and offsets are where the "
                         "damping of the tangent's roots changes sign)")
    if args.damping_ratio is not None and len(args.inputs) == 1 and args.inputs[0] != "goland":
        raise InputError("--damping-ratio: for ROM.npz AERO.npz or goland (a deck's modal "
                         "damping is its case control SDAMP's TABDMP1)")
    damping_ratio_of(args)  # its values, and not beside --alpha/--gamma
    if args.f06 is not None and args.aoa is not None:
        raise InputError("--f06: not with --aoa (its tables hold the critical root per speed, "
                         "not every mode's branch); drop --aoa for the FLUTTER SUMMARY")
    if len(args.inputs) == 1 and args.inputs[0] != "goland" and args.density and \
            args.aoa is None:
        raise InputError("--density: for ROM.npz AERO.npz or goland (a deck's densities are "
                         "its FLFACT density ratios times AERO RHOREF)")
    if len(args.inputs) == 1 and args.units is not None:
        what = "the deck's own" if args.inputs[0] != "goland" else "ft-slug-s for goland"
        if args.inputs[0] != "goland" or args.units != "ft-slug-s":
            raise InputError(f"--units: for ROM.npz AERO.npz only ({what} units are used)")


#: default altitude range searched for the flutter point (ft; converted to the model's unit)
ALT_RANGE_FT = (0.0, 40000.0)


def _check_altitudes(args, system) -> None:
    """--alt-range (default :data:`ALT_RANGE_FT` in ``system``'s altitude unit: the run's,
    :meth:`torchrom.units.UnitSystem.with_altitude`) and --at in the atmosphere's range, in
    that unit (InputError naming the option)."""
    from ..aero.atmosphere import FT, atmosphere
    from ..errors import InputError

    if args.alt_range is None:
        args.alt_range = tuple(h * FT / system.altitude_metre for h in ALT_RANGE_FT)
    for option, values in (("--alt-range", list(args.alt_range)), ("--at", args.at or [])):
        if not values:
            continue
        try:
            atmosphere(values, system.name, system.altitude)
        except InputError as exc:
            raise InputError(f"{option}: {exc}") from None


def _run_deck(args, path: Path) -> int:
    from ..aero.nastran_flutter import NASTRAN_KERNEL, format_deck_result, load_deck, run_deck
    from ..fe import read_bdf

    includes = [args.panels] if args.panels is not None else []
    deck = load_deck(path, symxz=args.symxz, length_unit=args.length_unit,
                     resvec=None if args.resvec is None else args.resvec == "yes",
                     includes=includes)
    print(
        f"torchrom flutter: {path}: {len(deck.cases)} FLUTTER case(s), {deck.aero_panels.n} boxes"
    )
    res = run_deck(deck, fe=read_bdf(path, unsupported=args.unsupported, includes=includes),
                   kernel=args.kernel or NASTRAN_KERNEL, k_exact=args.dlm_k,
                   g_tolerance=_tolerance(args))
    print(format_deck_result(res))
    out = res.as_dict()
    if args.compare is not None:
        from ..aero.nastran_flutter import compare_f06

        text, records = compare_f06(res, args.compare)
        print(f"\ncompared with {args.compare}:")
        print(text)
        out["compare"] = records
    maybe_write_json(args, out)  # the numbers first: a figure failure cannot lose them
    from ..aero.f06_summary import deck_summary

    _write_f06(args, lambda: deck_summary(res))
    ok = True
    if args.plot is not None and res.results:
        from ..aero.plots import plot_vg

        ok = _figure(plot_vg, res.results[0].sweep, args.plot,
                     velocity_label=f"velocity ({deck.length_unit}/s)",
                     title=f"{path.name}: FLUTTER {res.results[0].case.sid}, {deck.symmetry}")
    return 0 if ok else 1


def _write_f06(args, summary) -> None:
    """--f06 FILE: the FLUTTER SUMMARY that ``summary()`` builds
    (:mod:`torchrom.aero.f06_summary`)."""
    if args.f06 is not None:
        from ..aero.f06_summary import write_flutter_summary

        write_flutter_summary(args.f06, summary())
        print(f"wrote {args.f06}")


def _figure(draw, *a, **k) -> bool:
    """Draw one figure (a failure is a warning: :func:`torchrom.io.write_figure`)."""
    path = write_figure(draw, *a, **k)
    if path is not None:
        print(f"wrote {a[1]}")
    return path is not None


def _run_rom(args, rom_path: Path, aero_path: Path) -> int:
    from ..aero.build import structure_from_rom
    from ..aero.files import load_aero
    from ..rom import NonlinearROM
    from ..units import file_units

    aero = load_aero(aero_path)
    rom = NonlinearROM.load(rom_path)
    _flutter_shape.remember_rom(args, rom, rom_path)  # --plot: the flutter mode beside V-g
    system, note = file_units({str(rom_path): rom.metadata, str(aero_path): aero.metadata},
                              args.units)
    system = system.with_altitude(args.altitude_unit)
    if note:
        print(f"  {note}")
    _check_altitudes(args, system)
    from ._damping import damping_for_rom

    damping = damping_for_rom(args, rom, rom_path)
    print(f"  {damping.description}")
    args.damping_used = damping.as_metadata()  # for the JSON
    st = structure_from_rom(rom, aero.n_modes, damping.alpha, damping.gamma, rom_path)
    return _matched(args, st, aero, system, compare_paper=False)


def _run_goland(args) -> int:
    from ..aero.build import GOLAND_K_LIST, build_from_modes, modal_data
    from ..aero.files import load_aero
    from ..aero.panels import goland_panels
    from ..units import unit_system

    # the built-in Goland wing's system, at altitudes in ft unless --altitude-unit says m
    system = unit_system("ft-slug-s").with_altitude(args.altitude_unit)
    _check_altitudes(args, system)
    mach = 0.7 if args.mach is None else args.mach
    from ..fe import goland

    fe = goland(variant=args.variant)
    if args.aero is not None:
        from ..units import file_units

        aero = load_aero(args.aero)
        file_units({"goland": {"unit_system": "ft-slug-s"}, str(args.aero): aero.metadata})
        modes = modal_data(fe, aero.n_modes)
    else:
        modes = modal_data(fe, 9)
        print(
            f"torchrom flutter: goland: {args.boxes[0]}x{args.boxes[1]} boxes per half wing, "
            f"Mach {mach:g}, {args.lags} lags"
        )
        aero = build_from_modes(
            modes, mach, args.lags, GOLAND_K_LIST, goland_panels(*args.boxes), None,
            args.kernel or "quartic",
        )
    print("  modal frequencies (Hz): " + ", ".join(f"{f:.4g}" for f in modes.frequencies_hz))
    from ..rom.rayleigh import elastic_frequencies, goland_damping
    from ._damping import damping_for_modes

    damping = damping_for_modes(args, elastic_frequencies(modes.frequencies_hz),
                                goland_damping())
    print(f"  {damping.description}")
    args.damping_used = damping.as_metadata()  # for the JSON
    alpha, gamma = damping.alpha, damping.gamma
    if args.at is None:  # the paper's Table 3 altitudes (ft) in the run's unit
        args.at = [_from_ft(h, system) for h in (4000.0, 6000.0, 8000.0, 10000.0, 11000.0)]
    return _matched(args, modes.structure(alpha, gamma), aero, system, compare_paper=True)


def _from_ft(h_ft: float, system) -> float:
    """An altitude in ft (the paper's) in ``system``'s altitude unit (exact: 0.3048 m/ft)."""
    from ..aero.atmosphere import FT

    return h_ft if system.altitude == "ft" else h_ft * FT / system.altitude_metre


def _matched(args, structure, aero, system, compare_paper: bool) -> int:
    """Matched-point flutter (or, at Mach 0 or with --density, :func:`_speeds_at_densities`)
    in ``system``'s units (:class:`torchrom.units.UnitSystem`): altitudes, speeds, densities,
    dynamic pressures."""
    from ..aero.build import PAPER_FLUTTER_ALTITUDE_FT, PAPER_FLUTTER_FREQUENCY_HZ, PAPER_TABLE3
    from ..aero.flutter import (
        AeroTable,
        flutter_altitude_pk,
        flutter_altitude_state_space,
        growing_response_frequency,
        growing_response_frequency_pk,
    )
    from ..errors import InputError

    mach = aero.mach if args.mach is None else args.mach
    if abs(mach - aero.mach) > 1e-9:
        raise InputError(f"--mach {mach:g} differs from the aero file's Mach {aero.mach:g}")
    if mach == 0.0 or args.density:  # a speed at a density (Mach 0: no matched point)
        return _speeds_at_densities(args, structure, aero, system, mach)
    u = system.labels()
    h_u, hu = u["altitude"], {"altitude_unit": system.altitude}
    table = AeroTable.from_gaf(aero.gaf)
    results = []
    print(
        f"  matched point at Mach {mach:g}, "
        f"altitudes {args.alt_range[0]:g}..{args.alt_range[1]:g} {h_u}, units {system.name}, "
        f"alpha = {structure.alpha:g} 1/s, gamma = {structure.gamma:g} s, "
        f"RFA fit error {aero.rfa.fit_error.get('rms_relative', float('nan')):.2e}"
    )
    tol = _tolerance(args)
    for line in rfa_lines(aero):
        print(line)
    print(f"  a crossing counts where the damping g changes sign by more than {tol:g} "
          f"(--g-tolerance)")
    if args.method in ("both", "pk"):
        results.append(flutter_altitude_pk(structure, table, mach, args.alt_range,
                                           units=system.name, g_tolerance=tol, **hu))
    if args.method in ("both", "state-space"):
        results.append(flutter_altitude_state_space(structure, aero.rfa, mach, args.alt_range,
                                                    units=system.name, g_tolerance=tol, **hu))
    print(f"  {'method':<13}{'altitude ' + h_u:>13}{'frequency Hz':>14}"
          f"{'V ' + u['speed']:>10}{'q ' + u['dynamic_pressure']:>13}")
    for r in results:
        if r.altitude is None:
            print(f"  {r.method:<13}{'no flutter in range':>46}")
            continue
        print(
            f"  {r.method:<13}{r.altitude:13.1f}{r.frequency_hz:14.4f}{r.velocity:10.1f}"
            f"{0.5 * r.density * r.velocity**2:13.1f}"
        )
    if len(results) == 2:
        warning = matched_disagreement(*results)
        if warning:
            print(warning)
    for r in results:
        for j, a in getattr(r, "rigid_body_crossings", []):
            print(f"  {r.method}: rigid-body root (mode {j + 1}) damping crosses zero near "
                  f"{a:.1f} {h_u}: not flutter (a free aircraft's rigid-body root)")
    if compare_paper:
        print(f"  {'paper':<13}{_from_ft(PAPER_FLUTTER_ALTITUDE_FT, system):13.1f}"
              f"{PAPER_FLUTTER_FREQUENCY_HZ:14.4f}")
    growing = []
    if args.at:
        alts = np.asarray(args.at, dtype=float)
        f_ss = growing_response_frequency(structure, aero.rfa, mach, alts, system.name, **hu)
        f_pk = growing_response_frequency_pk(
            structure, table, mach, alts, system.name, start_altitude=args.alt_range[1], **hu
        )
        print(
            f"  growing-response frequency (Hz){'':8}{'state space':>12}{'p-k':>9}"
            + (f"{'paper':>9}" if compare_paper else "")
        )
        for a, fs, fp in zip(alts, f_ss, f_pk):
            paper = PAPER_TABLE3.get(next((h for h in PAPER_TABLE3 if np.isclose(
                _from_ft(h, system), a, rtol=1e-9)), None)) if compare_paper else None
            print(f"  {a:10.0f} {h_u:<2}{'':28}{fs:12.4f}{fp:9.4f}"
                  + (f"{paper:9.3f}" if paper else ""))
            growing.append(
                {
                    "altitude": float(a),
                    "frequency_hz_state_space": float(fs),
                    "frequency_hz_pk": float(fp),
                }
            )
    pairs = []
    if args.alpha_for_gamma:
        from ..aero.flutter import alpha_for_gamma

        ref = flutter_altitude_state_space(structure, aero.rfa, mach, args.alt_range,
                                           units=system.name, g_tolerance=tol, **hu)
        if ref.altitude is None:
            raise InputError("--alpha-for-gamma: no state-space flutter point in --alt-range")
        print(f"  alpha(gamma) keeping the flutter altitude at {ref.altitude:.1f} {h_u}:")
        for g in args.alpha_for_gamma:
            a = alpha_for_gamma(structure, aero.rfa, g, mach, ref.altitude, system.name, **hu)
            print(f"    gamma = {g:10.4g} s   alpha = {a:10.5g} 1/s")
            pairs.append({"gamma": g, "alpha": a, "altitude": ref.altitude})
    out = {
        "mach": mach,
        "alpha": structure.alpha,
        "gamma": structure.gamma,
        "units": u,
        "g_tolerance": tol,
        "rfa_check": aero.metadata.get("reduced_frequencies"),
        "flutter": [r.as_dict() for r in results],
        "growing_response": growing,
        "alpha_for_gamma": pairs,
        "damping": getattr(args, "damping_used", None),
    }
    if compare_paper:
        out["paper"] = {
            "altitude": _from_ft(PAPER_FLUTTER_ALTITUDE_FT, system),
            "frequency_hz": PAPER_FLUTTER_FREQUENCY_HZ,
            "table3": {f"{_from_ft(k, system):g}": v for k, v in PAPER_TABLE3.items()},
        }
    maybe_write_json(args, out)  # the numbers first: a figure failure cannot lose them
    from ..aero.f06_summary import matched_summary

    _write_f06(args, lambda: matched_summary(" ".join(args.inputs), u, results, structure,
                                             aero.rfa, mach))
    ok = True
    if args.plot is not None:
        from ..aero.plots import plot_vg

        sweep = next((r.sweep for r in results if r.method == "p-k"), None)
        if sweep is not None:
            pk = next(r for r in results if r.method == "p-k")
            ok &= _figure(plot_vg, sweep, args.plot, x="altitude", title=f"p-k, Mach {mach:g}",
                          altitude_label=f"altitude ({h_u})",
                          **_flutter_shape.beside(args, structure, table, pk, sweep))
    if args.root_locus is not None:
        from ..aero.plots import plot_root_locus

        sweep = next((r.sweep for r in results if r.method == "state-space"), None)
        if sweep is not None:
            ok &= _figure(plot_root_locus, sweep, args.root_locus,
                          title=f"state space, Mach {mach:g}")
    return 0 if ok else 1


def _speeds_at_densities(args, structure, aero, system, mach: float) -> int:
    """The flutter speed at fixed densities and the aero file's Mach (SOL 145's PK at one
    Mach and density; a wind tunnel): at each --density, or (Mach 0, no matched point) at the
    density of each altitude of --at (default the two ends of --alt-range); by p-k and the
    state space (:mod:`torchrom.aero.flutter_speed`)."""
    from ..aero.atmosphere import atmosphere
    from ..aero.flutter import AeroTable
    from ..aero.flutter_speed import flutter_speed_at_density, flutter_speed_pk_at_density
    from ..errors import InputError

    for option, given in (("--alpha-for-gamma", args.alpha_for_gamma),
                          ("--root-locus", args.root_locus)):
        if given:
            raise InputError(f"{option}: needs a matched point (a flight Mach number > 0 "
                             "without --density); here the flutter point is a speed")
    table = AeroTable.from_gaf(aero.gaf)
    u = system.labels()
    if args.density:
        conditions = [(float("nan"), float(rho)) for rho in args.density]
        where = "at each --density"
    else:
        altitudes = list(args.at) if args.at else list(args.alt_range)
        conditions = [(float(h), float(atmosphere(h, system.name, system.altitude).density))
                      for h in altitudes]
        where = "at the density of each altitude"
    print(f"  Mach {mach:g}{' (incompressible)' if mach == 0 else ''}: flutter speed {where}, "
          f"units {system.name}, alpha = {structure.alpha:g} 1/s, gamma = {structure.gamma:g} s")
    tol = _tolerance(args)
    for line in rfa_lines(aero):
        print(line)
    print(f"  a crossing counts where the damping g changes sign by more than {tol:g} "
          f"(--g-tolerance)")
    print(f"  {'method':<13}{'altitude ' + u['altitude']:>13}{'density ' + u['density']:>22}"
          f"{'V ' + u['speed']:>10}{'frequency Hz':>14}{'q ' + u['dynamic_pressure']:>13}"
          f"  kind")
    results, first_sweep, pk_sweeps = [], None, []
    for alt, rho in conditions:
        found = []
        if args.method in ("both", "pk"):
            pk, sweep = flutter_speed_pk_at_density(structure, table, rho, mach,
                                                    g_tolerance=tol)
            first_sweep = first_sweep or sweep
            pk_sweeps.append(sweep)
            found.append(pk)
        if args.method in ("both", "state-space"):
            found.append(flutter_speed_at_density(structure, aero.rfa, table, rho, mach=mach,
                                                  g_tolerance=tol))
        head = f"{'-' if alt != alt else f'{alt:.1f}':>13}{rho:22.5g}"
        for r in found:
            r.altitude, r.units = alt, system.name
            if r.velocity is None:
                print(f"  {r.method:<13}{head}{'no flutter in the speed range':>33}")
                continue
            kind = "" if r.kind is None else r.kind + (
                f" (stable again at {r.stable_velocity:.1f} {u['speed']})"
                if r.stable_velocity else "")
            print(f"  {r.method:<13}{head}{r.velocity:10.2f}{r.frequency_hz:14.4f}"
                  f"{0.5 * r.density * r.velocity**2:13.1f}  {kind}")
        results += found
        if len(found) == 2:
            at = "" if alt != alt else f" at {alt:g} {u['altitude']}"
            warning = disagreement(*found, structure, aero.rfa, u["speed"], at)
            found[1].agrees_with_pk = warning is None
            if warning:
                print(warning)
    for r in results:
        at = "" if r.altitude != r.altitude else f" at {r.altitude:g} {u['altitude']}"
        for line in quiet_lines(r, u["speed"], at):
            print(line)
    for r in results:
        for j, v in r.rigid_body_crossings:
            where = "" if r.altitude != r.altitude else f" at {r.altitude:g} {u['altitude']}"
            print(f"  {r.method}: rigid-body root (mode {j + 1}) damping crosses zero near "
                  f"{v:.1f} {u['speed']}{where}: not flutter (a free aircraft's rigid-body root)")
    maybe_write_json(args, {"mach": mach, "alpha": structure.alpha, "gamma": structure.gamma,
                            "damping": getattr(args, "damping_used", None),
                            "units": u, "g_tolerance": tol,
                            "rfa_check": aero.metadata.get("reduced_frequencies"),
                            "flutter": [{**r.as_dict(), **({} if r.method == "p-k" else {
                                "agrees_with_pk": getattr(r, "agrees_with_pk", None)})}
                                for r in results]})
    from ..aero.f06_summary import density_summary

    _write_f06(args, lambda: density_summary(
        " ".join(args.inputs), u, pk_sweeps, [r for r in results if r.method != "p-k"],
        structure, aero.rfa, mach))
    ok = True
    if args.plot is not None and first_sweep is not None:
        from ..aero.plots import plot_vg

        ok = _figure(plot_vg, first_sweep, args.plot, velocity_label=f"velocity ({u['speed']})",
                     title=f"p-k, Mach {mach:g}, density {conditions[0][1]:.4g} {u['density']}",
                     **_flutter_shape.beside(args, structure, table, next(
                         r for r in results if r.method == "p-k"), first_sweep))
    return 0 if ok else 1
