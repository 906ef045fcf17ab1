"""``torchrom panels DECK --out panels.bdf``: aerodynamic cards for a structure-only deck.

The wing's planform is read from the structure's outline (:mod:`torchrom.aero.outline`) in
the wing's axes (:mod:`torchrom.fe.wing_frame`, the flow along ``--flow-axis``) and written
as the cards a Nastran user writes (:mod:`torchrom.aero.panel_cards`) into a file to read,
edit and INCLUDE in the deck — or to give to ``aero``/``flutter`` with ``--panels``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ._common import (
    add_force_option,
    add_units_option,
    add_wing_axes_options,
    apply_wing_axes,
    check_outputs,
    nonnegative_float,
    positive_float,
    positive_int,
)

NAME = "panels"
HELP = ("write CAERO1/PAERO1/SPLINE1/SET1/AERO/MKAERO1/FLUTTER cards over a structure-only "
        "deck's planform (an include file)")
#: default box count: about square boxes of a chord / --nchord side, at most this many
MAX_DEFAULT_NSPAN = 60
#: default PK speeds: the flutter solution's highest mode from the largest MKAERO1 k (the GAF
#: table's end: no extrapolation) down to K_LOW, a slow flutter's reduced frequency
#: (b = REFC / 2)
K_LOW, N_SPEEDS = 0.1, 40


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("model", type=Path, help="Nastran deck of the wing's structure")
    parser.add_argument("--out", type=Path, required=True,
                        help="the include file to write (e.g. panels.bdf)")
    add_wing_axes_options(parser)
    parser.add_argument("--flow-axis", default=None, metavar="AXIS",
                        help="the free stream's direction in basic axes (x, -x, ... or a,b,c; "
                             "default: the basic axis nearest the wing's chord, positive)")
    parser.add_argument("--box-chord", type=nonnegative_float, nargs=2, default=(0.0, 1.0),
                        metavar=("FRONT", "REAR"),
                        help="fractions of the wing's chord that the structure spans, e.g. "
                             "0.15 0.65 for a wingbox between spars at 15 and 65 %% chord "
                             "(default 0 1: the structure's outline is the planform)")
    parser.add_argument("--nchord", type=positive_int, default=8,
                        help="boxes along the chord (default 8)")
    parser.add_argument("--nspan", type=positive_int, default=None,
                        help=f"boxes along the span in all (default: about square boxes, at "
                             f"most {MAX_DEFAULT_NSPAN})")
    parser.add_argument("--mach", type=nonnegative_float, nargs="+", default=[0.0],
                        help="MKAERO1 Mach numbers (default 0); the first is FLUTTER's")
    parser.add_argument("--velocities", type=positive_float, nargs="+", default=None,
                        metavar="V", help="FLUTTER PK speeds in the deck's units (default: "
                        f"{N_SPEEDS}, geometric, where the highest mode of the flutter solution "
                        f"has k from the largest MKAERO1 k down to {K_LOW:g})")
    parser.add_argument("--symxz", type=int, choices=(-1, 0, 1), default=1,
                        help="AERO SYMXZ: 1 (default) the root is a plane of symmetry (a half "
                             "aircraft, a wall-mounted wing), 0 an isolated wing, -1 "
                             "antisymmetric")
    parser.add_argument("--modes", type=positive_int, default=10,
                        help="PARAM LMODES written for a deck without EIGRL/LMODES: the modes "
                             "of the flutter solution (default 10)")
    add_units_option(parser, "the deck (needed for AERO RHOREF when its cards do not say)")
    add_force_option(parser)


def _flow_axis(text, frame):
    from ..fe.wing_frame import parse_axis

    flow = parse_axis(text, "--flow-axis")
    if flow is None:
        k = int(np.argmax(np.abs(frame.chord)))
        flow = np.eye(3)[k]
    flow = flow - (flow @ frame.up) * frame.up
    if np.linalg.norm(flow) < 1e-6:
        from ..errors import InputError

        raise InputError("--flow-axis: the flow must not be along the wing's up axis")
    return flow / np.linalg.norm(flow)


def spline_grids(fe, local: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Grid ids of one structural grid per planform position (the uppermost): an infinite-plate
    spline cannot take two grids at one (span, chord) point (a box's upper and lower skins)."""
    from ..fe.wing_frame import uppermost_per_position

    top = uppermost_per_position(local, float(np.ptp(local[:, :2], axis=0).max()))
    return np.sort(np.asarray(fe.grid_ids)[rows[top]])


def run(args: argparse.Namespace) -> int:
    from ..aero.outline import planform
    from ..aero.panel_cards import PanelOptions, panel_model, write_panel_cards
    from ..checks import expect_text_file
    from ..errors import InputError
    from ..fe import read_bdf
    from ..fe.deck_units import declare_units
    from ..fe.wing_frame import structural_rows
    from ..units import recorded_units

    check_outputs(args, [args.out])
    expect_text_file(args.model, "a Nastran deck", "model.bdf")
    fe = read_bdf(args.model)
    if fe.bdf is not None and fe.bdf.caeros:
        raise InputError(f"{args.model}: CAERO1: the deck has aerodynamic panels already "
                         f"({len(fe.bdf.caeros)} CAERO cards); torchrom panels is for a "
                         f"structure-only deck")
    declare_units(fe, args.units, str(args.model))
    system = recorded_units(fe.units or {})
    if system is None:
        raise InputError(f"{args.model}: units: the deck does not say its unit system (AERO "
                         f"RHOREF, GRAV, PARAM WTMASS): give --units (e.g. --units si) for the "
                         f"AERO card's sea-level density")
    apply_wing_axes(args, fe, say=False)
    frame = fe.wing_frame()
    flow = _flow_axis(args.flow_axis, frame)
    span = np.cross(frame.up, flow)
    span = span if span @ frame.span >= 0 else -span
    rows = structural_rows(fe)
    xyz = np.asarray(fe.grid_xyz, dtype=float)[rows]
    axes = np.stack((span, flow, frame.up))
    root = xyz[np.argmin(xyz @ span)]
    local = (xyz - root) @ axes.T
    plan = planform(local, tuple(args.box_chord))
    origin = root  # CAERO1 positions are in the aerodynamic system about the root
    first_id = 10 ** len(str(max([*fe.bdf.nodes, *fe.bdf.elements, *fe.bdf.properties,
                                   *fe.bdf.coords, 1]))) if fe.bdf is not None else 1
    b = 0.5 * plan.mean_chord
    velocities = args.velocities
    lmodes = None if _has_mode_count(fe.bdf) else args.modes
    if velocities is None:
        from ..aero.panel_cards import DEFAULT_K

        w = 2 * np.pi * float(fe.modes(lmodes or args.modes).frequencies_hz[-1])
        velocities = np.geomspace(w * b / max(DEFAULT_K), w * b / K_LOW, N_SPEEDS)
    span_length = float(plan.s[-1] - plan.s[0])
    nspan = args.nspan or int(min(MAX_DEFAULT_NSPAN, max(
        len(plan.s) - 1, round(span_length / (plan.mean_chord / args.nchord)))))
    opts = PanelOptions(n_chord=args.nchord, n_span=nspan, machs=tuple(args.mach),
                        velocities=tuple(float(v) for v in velocities),
                        rho_ref=system.sea_level_density, first_id=first_id,
                        lmodes=lmodes, symxz=args.symxz)
    grids = spline_grids(fe, local, rows)
    model = panel_model(plan, origin, flow, frame.up, span, grids, opts)
    n_boxes = sum(c.nspan * c.nchord for c in model.caeros.values())
    header = [
        f"aerodynamic cards for {args.model.name}, written by torchrom panels",
        f"wing axes: {frame.describe()}; flow {_name(flow)}",
        f"planform from the structure's outline: {len(plan.s) - 1} straight segment(s), span "
        f"{span_length:.6g}, area {plan.area:.6g}, reference chord {plan.mean_chord:.6g} "
        f"({system.length})",
        f"structure spans {args.box_chord[0]:g} .. {args.box_chord[1]:g} of the chord",
        f"{n_boxes} boxes; splines on {len(grids)} structural grids; include with: "
        f"INCLUDE '{args.out.name}'",
    ]
    write_panel_cards(args.out, model, header)
    for line in header[1:]:
        print(line)
    print(f"wrote {args.out}: AERO (RHOREF {system.sea_level_density:.6g} {system.density}, "
          f"SYMXZ {args.symxz}), "
          f"{len(model.caeros)} CAERO1, {len(model.splines)} SPLINE1, MKAERO1 at Mach "
          f"{', '.join(f'{m:g}' for m in args.mach)}, FLUTTER PK at {len(velocities)} speeds "
          f"{velocities[0]:.4g} .. {velocities[-1]:.4g} {system.speed}")
    return 0


def _has_mode_count(model) -> bool:
    """The deck says how many modes (EIGRL/EIGR or PARAM LMODES)."""
    return bool(model is not None and (model.methods or "LMODES" in model.params))


def _name(v) -> str:
    from ..fe.wing_frame import axis_name

    return axis_name(v)
