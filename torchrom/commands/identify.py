"""``torchrom identify MODEL.bdf``: non-intrusive identification of the nonlinear ROM.

    torchrom identify MODEL.bdf --linear 9 --dual 12 --damping decomposition|exact --out rom.npz
                      [--stiffness tangent|step|condensed] [--amplitude A] [--levels 3]
                      [--nonlinear-modes K] [--higher-amplitude F] [--linear-skin PID]
                      [--about-aero AERO --about-aoa DEG --about-velocity V --about-density RHO]
                      [--damping-ratio ZETA | Z1@F1 Z2@F2]
                      [--report DIR] [--json FILE] [--force]

Reads the deck with the built-in FE, computes the linear and dual modes, identifies the stiffness
and the Kelvin–Voigt damping tensors (DIGEST Secs. 4–6), writes ``rom.npz`` and, with
``--report``, validates the ROM against the FE (Markdown + PNG). ``--json`` keys: see
:meth:`torchrom.identify.build.IdentificationResult.summary` (counts, seconds ``time_*_s``,
relative residuals, smallest eigenvalues of the extended damping matrix), plus the report's
``static_*``, ``decay_*`` and ``damping_*`` numbers (relative errors, Hz) when it is written.

The structural damping, α (1/s) and γ (s) of f_d = α M q̇ + γ D̄(q) q̇, is what the deck states
(PARAM G/W3, MAT1 GE/W4, TABDMP1 selected by SDAMPING: :mod:`torchrom.fe.damping_cards`) or
``--damping-ratio`` (:mod:`torchrom.rom.rayleigh`), the paper's Eq. 46 values for the heavy
Goland deck, else none; it is printed in one line, recorded in ``rom.npz`` (metadata
``structural_damping``, which ``flutter`` and ``sweep`` use) and in ``--json``
(``structural_damping``: alpha, gamma, source, description, frequencies_hz, zeta_target,
zeta_fit).
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

from ..progress import info
from ._common import (
    add_force_option,
    add_json_option,
    add_units_option,
    add_wing_axes_options,
    apply_wing_axes,
    check_outputs,
    finite_float,
    maybe_write_json,
    nonnegative_float,
    nonnegative_int,
    positive_float,
    positive_int,
)
from ._damping import add_damping_ratio_option, damping_ratio_of

NAME = "identify"
HELP = "identify the nonlinear ROM (stiffness + Kelvin-Voigt damping) of an FE model"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser) -> None:
    parser.add_argument("model", type=Path, help="Nastran BDF of the structure")
    add_wing_axes_options(parser)
    parser.add_argument("--linear", type=positive_int, default=9,
                        help="number of linear modes (default 9)")
    parser.add_argument("--dual", type=nonnegative_int, default=None,
                        help="number of dual modes (default 12, and 0 with --stiffness "
                             "condensed; 0: a ROM of the linear modes only)")
    parser.add_argument("--combinations", default="transverse", metavar="SET",
                        help="linear-mode pairs loaded for the dual modes: 'transverse' "
                             "(default, from the modes' kinds: the first two transverse, i.e. "
                             "bending or torsion, modes, each alone and with the next "
                             "transverse modes up to the third one or the second bending "
                             "mode, whichever comes later; in-plane modes left out), 'paper' "
                             "(the paper's nine pairs of modes 1-5), 'bending-torsion' "
                             "((1,1),(1,2),(1,3),(2,2),(2,3)) or J:L,J:L,...")
    parser.add_argument("--damping", choices=("decomposition", "exact"),
                        default="decomposition",
                        help="damping identification: the paper's optimum decomposition, or "
                             "exact from the FE material tangent")
    add_damping_ratio_option(parser, "the ROM's structural damping instead of the deck's "
                             "(PARAM G/W3, MAT1 GE/W4, TABDMP1 by SDAMPING; none: α = γ = 0): ")
    parser.add_argument("--stiffness", choices=("tangent", "step", "condensed"),
                        default="tangent",
                        help="stiffness identification: tangent matrices (Eqs. 37-41), STEP "
                             "(enforced displacements), or condensed (implicit condensation: "
                             "modal loads solved by the FE, the in-plane motion relaxed by it; "
                             "linear modes only, for thin wings that bend to large deflections)")
    parser.add_argument("--amplitude", type=positive_float, default=None,
                        help="identification amplitude, fraction of the span (default 0.01; "
                             "with --stiffness condensed the largest load level's linear tip "
                             "deflection, default 0.3: the ROM's envelope)")
    parser.add_argument("--levels", type=positive_int, default=3,
                        help="load levels per direction of --stiffness condensed, in equal "
                             "steps up to --amplitude (default 3)")
    parser.add_argument("--higher-amplitude", type=positive_float, default=None, metavar="F",
                        help="with --stiffness condensed: load the modes after the first to "
                             "this linear tip deflection (fraction of the span) instead of the "
                             "first mode's modal force, which reaches only a few mm of a higher "
                             "mode; for an LCO whose motion lies in those modes")
    parser.add_argument("--condensation-fit", choices=("forces", "forces-and-tangents"),
                        default="forces",
                        help="with --stiffness condensed: fit the cubic terms to each static "
                             "solve's condensed force (default), or to its force and its "
                             "condensed tangent (exact where the condensed force is a cubic; "
                             "the tangent about a deformed state, which flutter at an angle of "
                             "attack uses, is the one such a fit aims at)")
    parser.add_argument("--nonlinear-modes", type=positive_int, default=None, metavar="K",
                        help="with --stiffness condensed: load only the first K linear modes "
                             "(default all); the ROM's nonlinear terms are those of their "
                             "coordinates, the plan's static solves grow as K cubed")
    parser.add_argument("--out", type=Path, required=True, metavar="ROM.npz",
                        help="ROM file to write, e.g. rom.npz")
    parser.add_argument("--report", type=Path, metavar="DIR",
                        help="also validate the ROM against the FE and write DIR/report.md")
    parser.add_argument("--gamma", type=nonnegative_float, default=1e-3,
                        help="Kelvin-Voigt gamma (s) of the report's free decay (default 1e-3)")
    parser.add_argument("--decay-tip", type=positive_float, default=0.15,
                        help="initial tip deflection of the report's free decay, fraction of "
                             "the span (default 0.15)")
    parser.add_argument("--no-decay", action="store_true",
                        help="leave the free decay out of the report (its FE transient runs "
                             "10 periods of mode 1 at 200 steps a period: on a large "
                             "co-rotational deck such as the Pazy wing, hours); the static "
                             "curves and the damping comparison stay")
    parser.add_argument("--step-x", type=finite_float, default=None,
                        help="chordwise mid-line (basic x) of the report's step pressure "
                             "(default: the wing's mid-chord when the deck is known, e.g. 3 ft "
                             "for the Goland deck, else the middle of the grid)")
    parser.add_argument("--output", action="append", default=[], metavar="[NAME=]G<grid>:<C>",
                        help="also keep this point of the deck as a ROM output (repeatable): "
                             "grid id and component T1 T2 T3 R1 R2 R3 (the grid's CD frame), "
                             "e.g. --output G1001:T3 --output tip=G1002:T3; the ROM always "
                             "has the deck's named points and max_mode1, the translation that "
                             "moves most in mode 1")
    parser.add_argument("--linear-skin", type=positive_int, action="append", default=[],
                        metavar="PID",
                        help="with --stiffness condensed: a foil skin (the PSHELL/PCOMP id of "
                             "its CQUAD4/CTRIA3, repeatable) that adds its linear stiffness and "
                             "mass to the ROM but nothing to its nonlinear terms, which are "
                             "condensed on the structure without it (a thin skin wrinkles: "
                             "modelled as shells it stops every static solve)")
    g = parser.add_argument_group(
        "about a deformed state (with --stiffness condensed)",
        "the ROM about the static aeroelastic equilibrium of a root angle of attack at one "
        "speed: its coordinates are x = q - q_ref, its linear stiffness the exact condensed "
        "tangent there, its cubic terms the condensed potential's Taylor terms, fitted to the "
        "forces and exact tangents of solves about it (--amplitude default 0.015)")
    g.add_argument("--about-aero", type=Path, default=None, metavar="AERO.npz",
                   help="the deck's aerodynamics (torchrom aero DECK --modes N, N <= --linear): "
                        "its steady loads hold the reference state")
    g.add_argument("--about-aoa", type=finite_float, default=None, metavar="DEG",
                   help="the reference state's root angle of attack (deg)")
    g.add_argument("--about-velocity", type=positive_float, default=None, metavar="V",
                   help="the reference state's speed (the aero file's unit)")
    g.add_argument("--about-density", type=positive_float, default=None, metavar="RHO",
                   help="the reference state's air density (the aero file's unit)")
    add_units_option(parser, "the deck")
    add_json_option(parser)
    add_force_option(parser)


class _Progress:
    """Progress of each FE stage (:class:`torchrom.progress.Progress`)."""

    def __init__(self):
        self.bars = {}

    def __call__(self, stage, done, total):
        from ..progress import Progress

        bar = self.bars.get(stage)
        if bar is None:
            bar = self.bars[stage] = Progress(total, f"  {stage}", unit="FE solves")
        bar.update_to(done)
        if done >= total:
            bar.close()


def _skeleton(args, fe, backend):
    """The condensation's structure: the deck already read (``fe``) without its --linear-skin
    shells; its FE work counts in ``backend``'s counters."""
    from ..fe.bdf_read import from_pynastran
    from ..fe.deck_units import declare_units
    from ..identify.build import as_backend
    from ..identify.condensation import skeleton_of

    skel = from_pynastran(fe.bdf, source=fe.source, name=fe.name,
                          without_properties=args.linear_skin)
    declare_units(skel, args.units, str(args.model))
    n_left = len(fe.mesh.quads) + len(fe.mesh.trias) - len(skel.mesh.quads) - len(skel.mesh.trias)
    pids = ", ".join(map(str, args.linear_skin))
    what = (f"without the {n_left} shells of property {pids} (a linear skin: its stiffness and "
            f"mass in the linear part only); {skel.n_dof} of {fe.n_dof} DOFs")
    print(f"  condensation on the structure {what}")
    skel_backend = as_backend(skel)
    skel_backend.counters = backend.counters
    return skeleton_of(fe, skel, skel_backend, what)


def _structural_damping(fe, basis, cards, ratio):
    """α, γ of the ROM (module docstring) on its elastic linear modes: ``ratio``
    (--damping-ratio) if given, else the deck's ``cards`` (:func:`torchrom.fe.damping_cards.
    rom_damping`: the Goland wing's values, or none, where the deck states nothing)."""
    import numpy as np

    from ..fe.damping_cards import rom_damping

    cols = [i for i, k in enumerate(basis.kinds) if k == "linear"][basis.n_rigid:]
    f = np.asarray(basis.frequencies_hz, dtype=float)[cols]
    cols = [c for c, fi in zip(cols, f) if np.isfinite(fi) and fi > 0]
    f = np.asarray(basis.frequencies_hz, dtype=float)[cols]
    free = basis.n_rigid > 0
    if ratio is not None:
        return ratio.rayleigh(f, free)
    return rom_damping(fe, cards, basis.Phi[:, cols], f, free)


ABOUT = ("about_aero", "about_aoa", "about_velocity", "about_density")


def _about(args):
    """The modal load law of ``--about-*`` (the steady aerodynamic load −q∞ (Q_α α + Q(0) q)
    on the first --linear modes), or None without those options."""
    given = [name for name in ABOUT if getattr(args, name) is not None]
    if not given:
        return None
    from ..errors import InputError

    missing = [f"--{name.replace('_', '-')}" for name in ABOUT if name not in given]
    if missing:
        raise InputError(f"--about-*: a reference state needs {', '.join(missing)} as well")
    if args.stiffness != "condensed":  # before the aero file is read
        raise InputError(f"--about-aero: the ROM about a deformed state is a condensation; "
                         f"use --stiffness condensed, not {args.stiffness!r}")
    import math

    from ..aero.files import load_aero
    from ..checks import expect_file_kind
    from ..trim.condensed import steady_load_law
    from ..trim.reduced import SteadyModalAero

    expect_file_kind(args.about_aero, "aero", "--about-aero")
    aero = load_aero(args.about_aero)
    where = f"--about-aero {args.about_aero}"
    if aero.n_modes > args.linear:
        raise InputError(f"{where}: {aero.n_modes} modes, more than the ROM's --linear "
                         f"{args.linear}; build it with --modes {args.linear} or fewer")
    steady = SteadyModalAero.from_aero(aero, args.linear, where)
    return steady_load_law(steady, 0.5 * args.about_density * args.about_velocity**2,
                           math.radians(args.about_aoa), args.linear,
                           {"aoa_deg": args.about_aoa, "velocity": args.about_velocity,
                            "density": args.about_density, "aero": str(args.about_aero)})


def run(args) -> int:
    from ..identify.build import IdentifyOptions, as_backend, identify

    check_outputs(args, [args.out, *([args.report / "report.md"] if args.report else [])])
    from ..checks import expect_text_file

    expect_text_file(args.model, "a Nastran deck", "model.bdf")
    from ..fe import read_bdf
    from ..identify import DualModeOptions
    from ..identify.basis import parse_combinations
    from ..rom.points import parse_named_point

    if args.dual is None:
        args.dual = 0 if args.stiffness == "condensed" else 12
    # bad option combinations before the deck is read and its modes computed
    opt = IdentifyOptions(n_linear=args.linear, n_dual=args.dual, damping=args.damping,
                          stiffness=args.stiffness, amplitude=args.amplitude,
                          levels=args.levels, nonlinear_modes=args.nonlinear_modes,
                          higher_amplitude=args.higher_amplitude,
                          condensation_fit=args.condensation_fit, about=_about(args))
    opt.validate()
    if args.linear_skin and args.stiffness != "condensed":
        from ..errors import InputError

        raise InputError(f"--linear-skin: an option of --stiffness condensed (the skin is left "
                         f"out of the condensation's static solves), not of --stiffness "
                         f"{args.stiffness}")
    if args.combinations != "transverse":
        parse_combinations(args.combinations)  # bad input before the work
    extra_points = dict(parse_named_point(o) for o in args.output)
    ratio = damping_ratio_of(args, beside_alpha_gamma=False)  # bad values before the work
    t0 = time.perf_counter()
    info(f"reading {args.model}")
    fe = read_bdf(args.model)
    from ..fe.deck_units import declare_units, describe_units

    declare_units(fe, args.units, str(args.model))
    print(f"  {describe_units(fe)}")
    from ..fe.damping_cards import read_deck_damping

    # the deck's damping cards checked before the work (--damping-ratio replaces them)
    cards = read_deck_damping(fe.bdf, args.model.name) if ratio is None else None
    apply_wing_axes(args, fe)
    kinds = None
    if args.combinations == "transverse" and args.dual:
        # a free structure's rigid-body modes come first in the basis (0 Hz, as in SOL 145);
        # without dual modes there are no combinations to choose
        m = fe.modes(args.linear)
        kinds = (["rigid-body"] * m.n_rigid + list(m.kinds))[:args.linear]
        if "unknown" in kinds:  # the kinds need the wing's up axis
            from ..fe.wing_frame import WingFrameError

            try:
                fe.wing_frame()
            except WingFrameError as exc:
                raise WingFrameError(f"{exc}; or name the dual-mode pairs with --combinations "
                                     f"J:L,... or use --dual 0") from None
    combinations = parse_combinations(args.combinations, kinds=kinds) if args.dual else []
    if kinds is not None:
        print(f"  dual-mode combinations from the mode kinds ({', '.join(kinds)}): "
              f"{', '.join(f'{j}:{l}' for j, l in combinations)}")
    backend = as_backend(fe)
    if args.step_x is not None:
        backend.step_x = float(args.step_x)
    if extra_points:
        backend.add_output_points(extra_points)
    if args.linear_skin:
        backend.skeleton = _skeleton(args, fe, backend)
    info(f"  {backend.n_dof} DOFs, span {backend.reference_length:g}, "
          f"outputs {sorted(backend.outputs)}")
    opt = replace(opt, dual=DualModeOptions(combinations=combinations))
    info(f"identifying {args.linear}L{args.dual}D ROM: stiffness {args.stiffness}, damping "
          f"{args.damping}")
    res = identify(backend, opt, progress=_Progress())
    from ..rom.rayleigh import METADATA_KEY

    damping = _structural_damping(fe, res.basis, cards, ratio)
    res.rom.metadata[METADATA_KEY] = damping.as_metadata()
    res.rom.save(args.out)
    s = res.summary()
    s[METADATA_KEY] = damping.as_metadata()
    print(f"wrote {args.out}  (n = {res.rom.n})")
    print(f"  {damping.description}")
    from ..rom.points import describe_outputs

    print(f"  outputs: {describe_outputs(res.rom)}")
    print(f"  FE: {s['fe_static_solves']} static solves ({s['fe_newton_iterations']} Newton "
          f"iterations), {s['fe_tangent_evaluations']} tangents, "
          f"{s['fe_material_tangent_evaluations']} material tangents, "
          f"{s['fe_force_evaluations']} forces")
    print("  time: " + ", ".join(f"{k} {v:.1f} s" for k, v in res.timings.items()))
    resid = dict(res.stiffness.residuals)
    if res.stiffness.method == "condensed":
        plan = res.stiffness.plan_info
        if "condensation_asymmetry" in resid:
            fit = (f"misfit {resid['condensation_fit']:.1e} (the condensed force's departure "
                   f"from a cubic over the load levels), asymmetry "
                   f"{resid['condensation_asymmetry']:.1e} before the potential's symmetry "
                   "was imposed")
        else:  # about a state: the potential's Taylor terms (identify.potential_fit)
            fit = (f"the quartic potential's misfit {resid['condensation_fit']:.1e} of the "
                   "forces")
        if "condensation_tangent_fit" in resid:
            fit += f"; tangent misfit {resid['condensation_tangent_fit']:.1e}"
        print(f"  condensation: {plan['static_solves']} static solves converged, "
              f"{plan['failed_solves']} failed; {fit}")
    else:
        from ..identify.stiffness import residual_wording

        largest = max(resid.values())
        print(f"  largest identification residual {largest:.1e} ({residual_wording(largest)})")
    if "damping_min_eig_scaled_final" in s:
        print(f"  extended damping matrix, smallest scaled eigenvalue "
              f"{s['damping_min_eig_scaled_final']:.3e}"
              + (f" (symmetric split {s['damping_min_eig_scaled_symmetric_split']:.3e})"
                 if "damping_min_eig_scaled_symmetric_split" in s else ""))
    s["time_read_s"] = time.perf_counter() - t0 - res.timings["total"]
    if args.report is not None:
        from ..identify.report import write_report

        info(f"validating against the FE -> {args.report}")
        nums = write_report(res, backend, args.report, gamma=args.gamma,
                            decay_tip_fraction=args.decay_tip, dynamic=not args.no_decay)
        s.update(nums)
        for k, v in nums.items():
            if k.endswith("_error"):
                print(f"  {k}: {v:.3e}")
        print(f"wrote {args.report / 'report.md'}")
    s["time_command_s"] = time.perf_counter() - t0
    s["out"] = str(args.out)
    maybe_write_json(args, s)
    print(f"done in {s['time_command_s']:.1f} s")
    return 0
