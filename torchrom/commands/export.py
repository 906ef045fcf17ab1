"""``torchrom export``: mode shapes, the flutter mode and LCO motion as files viewers open.

Forms (``--out`` repeatable; the suffix picks the format: ``.vtu``, ``.xdmf``, ``.op2``,
:mod:`torchrom.post.viewers`):

  torchrom export MODEL.bdf --out modes.vtu [--n N] [--mode K ...]
        the deck's linear modes (the elastic ones, as ``torchrom modes`` lists them)
  torchrom export ROM.npz --out basis.op2 [--mode K ...]
        the ROM's basis on the deck's grids (``rom.npz`` keeps it since identify stores it)
  torchrom export ROM.npz AERO.npz --flutter --out flutter.xdmf [--density RHO | --alt-range
        LO HI] [--phases 12]
        the flutter mode at the p-k flutter point (at the density, or the matched point at the
        aero file's Mach), over one cycle
  torchrom export ROM.npz --sweep DIR --row ROW --out lco.xdmf [--frames 24]
        one sweep row's LCO over one period (ROW: its 0-based position in DIR/results.parquet
        or its case_id), from DIR/orbits.parquet (harmonic balance) or DIR/histories.parquet
        with q1..qn (time marching)

Displacements are T1 T2 T3 along basic x y z in the deck's length unit and R1 R2 R3 in rad;
modes are mass-normalised, the flutter mode has its largest translation 1 (phase 0 there), an
LCO is physical. ``--json FILE``: {"files", "kind", "frames", "values", "value_unit",
"length_unit", "scale", "grids"} and for the flutter mode {"velocity", "density",
"frequency_hz", "damping_g", "reduced_frequency", "mode", "residual", "units"}, for an LCO
{"row", "case_id", "source", "period_s", "amplitude"}.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    OrderedRange,
    add_force_option,
    add_json_option,
    check_outputs,
    finite_float,
    maybe_write_json,
    nonnegative_float,
    positive_float,
    positive_int,
)

NAME = "export"
HELP = ("write mode shapes, the flutter mode or a sweep row's LCO motion for viewers "
        "(VTU/XDMF for ParaView, OP2 for Nastran post-processors)")
FORMATS = (".vtu", ".xdmf", ".op2")


def output_file(value: str) -> Path:
    """argparse type of ``--out``: a file name ending in one of :data:`FORMATS`."""
    path = Path(value)
    if path.suffix.lower() not in FORMATS:
        raise argparse.ArgumentTypeError(f"expected a file name ending in one of "
                                         f"{', '.join(FORMATS)}, got {value!r}")
    return path


def add_motion_options(parser: argparse.ArgumentParser) -> None:
    """The options that choose a motion: the modes, the flutter mode or a sweep row."""
    parser.add_argument("--mode", type=positive_int, nargs="+", default=None, metavar="K",
                        help="modes (1-based) of a deck or a ROM's basis (default: all)")
    parser.add_argument("--n", type=positive_int, default=None,
                        help="deck form: number of modes (default: EIGR/EIGRL ND of the deck, "
                             "else 10)")
    parser.add_argument("--flutter", action="store_true",
                        help="ROM.npz AERO.npz: the flutter mode at the p-k flutter point")
    parser.add_argument("--density", type=positive_float, default=None, metavar="RHO",
                        help="--flutter: the flutter speed at this density (the files' units; "
                             "needed for an aero file at Mach 0); else the matched point")
    parser.add_argument("--alt-range", type=finite_float, nargs=2, action=OrderedRange,
                        metavar=("LO", "HI"), default=None,
                        help="--flutter, matched point: altitudes searched, in the files' "
                             "altitude unit (default 0 to 40,000 ft = 12,192 m)")
    parser.add_argument("--alpha", type=nonnegative_float, default=None,
                        help="--flutter: mass-proportional damping α (1/s; default what the "
                             "ROM records)")
    parser.add_argument("--gamma", type=nonnegative_float, default=None,
                        help="--flutter: stiffness-proportional damping γ (s; default what the "
                             "ROM records)")
    parser.add_argument("--phases", type=positive_int, default=12,
                        help="--flutter: frames over the mode's cycle (default 12)")
    parser.add_argument("--sweep", type=Path, default=None, metavar="DIR",
                        help="the output folder of `torchrom sweep` whose row --row to show")
    parser.add_argument("--row", default=None,
                        help="--sweep: the row (0-based position in DIR/results.parquet) or "
                             "its case_id")
    parser.add_argument("--frames", type=positive_int, default=24,
                        help="--sweep: instants over the LCO's period (default 24)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("inputs", nargs="+", metavar="INPUT",
                        help="MODEL.bdf | ROM.npz | ROM.npz AERO.npz (with --flutter)")
    parser.add_argument("--out", type=output_file, action="append", required=True,
                        metavar="FILE",
                        help="file to write, .vtu (ParaView), .xdmf (ParaView time series) or "
                             ".op2 (Nastran post-processors); repeatable")
    add_motion_options(parser)
    add_json_option(parser)
    add_force_option(parser)


def motion_of(args: argparse.Namespace):
    """(motion, record) that the options choose (:mod:`torchrom.post.motions`); ``record`` is
    the JSON of what it is. Bad input: InputError in one line."""
    from ..errors import InputError

    inputs = [Path(p) for p in args.inputs]
    if len(inputs) > 2:
        raise InputError(f"expected MODEL.bdf, ROM.npz or ROM.npz AERO.npz, got {len(inputs)} "
                         "inputs")
    forms = [name for name, on in (("--flutter", args.flutter), ("--sweep", args.sweep))
             if on]
    if len(forms) > 1:
        raise InputError("--flutter and --sweep: give one of them")
    if args.row is not None and args.sweep is None:
        raise InputError("--row: needs --sweep DIR (the sweep whose row to show)")
    if args.sweep is not None and args.row is None:
        raise InputError("--sweep: needs --row ROW (a row number or case_id of the sweep)")
    is_rom = inputs[0].suffix == ".npz"
    if args.flutter and (len(inputs) != 2 or not is_rom):
        raise InputError("--flutter: expected ROM.npz AERO.npz")
    if not args.flutter and len(inputs) == 2:
        raise InputError(f"{inputs[1]}: an aero file is read with --flutter only")
    if args.sweep is not None and not is_rom:
        raise InputError("--sweep: expected ROM.npz (the sweep's model) as INPUT")
    if (args.density is not None or args.alt_range is not None) and not args.flutter:
        raise InputError("--density/--alt-range: options of --flutter")
    if args.mode and (args.flutter or args.sweep is not None):
        raise InputError("--mode: for mode shapes (MODEL.bdf or ROM.npz alone)")
    if args.n is not None and is_rom:
        raise InputError("--n: for a deck (a ROM's basis has its own size; choose with --mode)")
    if not is_rom:
        return _deck_modes(args, inputs[0])
    from ..rom import NonlinearROM

    rom = NonlinearROM.load(inputs[0])
    shapes = rom.grid_shapes(str(inputs[0]))
    if args.flutter:
        return _flutter(args, rom, shapes, inputs[0], inputs[1])
    if args.sweep is not None:
        return _lco(args, shapes, rom)
    from ..post.motions import mode_motion

    m = mode_motion(shapes, rom.frequencies_hz, args.mode,
                    f"{inputs[0].name}: basis on the grids of {Path(shapes.source).name}")
    return m, {}


def _deck_modes(args, path: Path):
    from ..checks import expect_text_file
    from ..fe import read_bdf
    from ..fe.shapes import mesh_shapes
    from ..post.motions import mode_motion

    expect_text_file(path, "a Nastran deck or a rom.npz", "model.bdf")
    fe = read_bdf(path)
    n = args.n if args.n is not None else (max(args.mode) if args.mode else None)
    modes = fe.modes(n)
    shapes = mesh_shapes(fe, modes.shapes)
    m = mode_motion(shapes, modes.frequencies_hz, args.mode, f"{path.name}: modes")
    return m, {"kinds": [modes.kinds[int(k[4:]) - 1] for k in m.keys]}


def _flutter(args, rom, shapes, rom_path: Path, aero_path: Path):
    import numpy as np

    from ..aero.build import structure_from_rom
    from ..aero.files import load_aero
    from ..aero.flutter import AeroTable, flutter_altitude_pk
    from ..aero.flutter_mode import pk_flutter_mode
    from ..aero.flutter_speed import flutter_speed_pk_at_density
    from ..errors import InputError
    from ..post.motions import flutter_motion
    from ..units import file_units
    from ._damping import damping_for_rom

    aero = load_aero(aero_path)
    system, note = file_units({str(rom_path): rom.metadata, str(aero_path): aero.metadata})
    if note:
        print(f"  {note}")
    damping = damping_for_rom(args, rom, rom_path)
    print(f"  {damping.description}")
    st = structure_from_rom(rom, aero.n_modes, damping.alpha, damping.gamma, rom_path)
    table = AeroTable.from_gaf(aero.gaf)
    u = system.labels()
    if args.density is not None or aero.mach == 0:
        if args.density is None:
            raise InputError(f"--flutter: {aero_path} is at Mach 0 (no matched point): give "
                             f"--density RHO ({u['density']})")
        res, sweep = flutter_speed_pk_at_density(st, table, args.density, aero.mach)
        where = f"density {args.density:g} {u['density']}"
    else:
        from ..aero.atmosphere import FT

        hi = 40000.0 * FT / system.altitude_metre
        res = flutter_altitude_pk(st, table, aero.mach, args.alt_range or (0.0, hi),
                                  units=system.name, altitude_unit=system.altitude)
        sweep = res.sweep
        where = (f"Mach {aero.mach:g}" if res.altitude is None else
                 f"Mach {aero.mach:g}, {res.altitude:.1f} {system.altitude}")
    if res.velocity is None or res.mode is None:
        raise InputError(f"--flutter: no p-k flutter point of {rom_path} with {aero_path} at "
                         f"{where}: no flutter mode to show")
    fm = pk_flutter_mode(st, table, res.velocity, res.density, sweep, res.mode)
    title = (f"flutter mode {fm.mode + 1}: {fm.frequency_hz:.4g} Hz at {fm.velocity:.4g} "
             f"{u['speed']} ({where})")
    print(f"  {title}; g = {fm.damping_g:.1e}, k = {fm.k:.4g}, p-k residual {fm.residual:.1e}")
    motion = flutter_motion(shapes, fm.vector, fm.eigenvalue, args.phases, title)
    rec = {"velocity": fm.velocity, "density": fm.density, "frequency_hz": fm.frequency_hz,
           "damping_g": fm.damping_g, "reduced_frequency": fm.k, "mode": fm.mode + 1,
           "residual": fm.residual, "units": u,
           "modal_vector_real": np.real(fm.vector).tolist(),
           "modal_vector_imag": np.imag(fm.vector).tolist()}
    return motion, rec


def _lco(args, shapes, rom):
    import numpy as np

    from ..post.motions import lco_motion, sweep_row

    r = sweep_row(args.sweep, args.row, rom.n, args.frames)
    T = float(r.t[1] - r.t[0]) * len(r.t)
    unit = shapes.length_unit or "length unit"
    labels = {"altitude_ft": ("altitude", "ft"), "altitude_m": ("altitude", "m"),
              "velocity": ("V", f"{unit}/s"), "gamma": ("γ", "s")}
    params = ", ".join(f"{name} {r.row[k]:.5g} {u}" for k, (name, u) in labels.items()
                       if isinstance(r.row.get(k), (int, float)) and np.isfinite(r.row[k]))
    title = (f"LCO of {args.sweep.name} row {r.index} ({params}): "
             f"{r.row.get('frequency_hz', float('nan')):.4g} Hz")
    rec = {"row": r.index, "case_id": r.case_id, "source": r.source, "period_s": T,
           "amplitude": r.row.get("amplitude")}
    return lco_motion(shapes, r.t, r.q, title), rec


def run(args: argparse.Namespace) -> int:
    from ..errors import InputError

    outs = list(args.out)
    if len(set(outs)) != len(outs):
        raise InputError("--out: the same file given twice")
    check_outputs(args, outs)
    motion, rec = motion_of(args)
    from ..post.viewers import write_motion

    for path in outs:
        write_motion(path, motion)
        print(f"wrote {path}  ({len(motion.keys)} {'frames' if motion.kind != 'modes' else 'modes'}"
              f" on {motion.shapes.n_grid} grids)")
    unit = {"modes": "Hz", "phases": "deg", "period": "s"}[motion.kind]
    maybe_write_json(args, {"files": [str(p) for p in outs], "kind": motion.kind,
                            "frames": motion.keys, "values": motion.values.tolist(),
                            "value_unit": unit, "length_unit": motion.shapes.length_unit,
                            "scale": motion.scale, "grids": motion.shapes.n_grid, **rec})
    return 0
