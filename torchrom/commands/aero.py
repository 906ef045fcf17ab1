"""``torchrom aero``: doublet-lattice GAFs on the first m modes and their RFA -> aero.npz.

Output JSON (--json): {"out", "mach", "semichord", "n_modes", "k" (list), "n_lags", "rfa_kind",
"fit_error" {rms_relative, max_weighted, max_entry_relative, worst_entry, k_fit (where the RFA
is fitted on part of the table)}, "frequencies_hz", "reduced_frequencies" (deck form: the
reduced frequencies chosen and the RFA's check, :mod:`torchrom.aero.reduced_frequencies`:
k_table, speeds, speeds_source, density, density_source, flutter_speed (the survey's p-k),
matter_speed, k_matter, k_fit, k_check, rfa_error, rfa_error_limit, state_space_speed,
agreement, warnings, ok)}. Each failed check prints a ``warning:`` line saying what to do.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..progress import info
from ._common import (
    OrderedRange,
    add_force_option,
    add_json_option,
    add_units_option,
    case_parameter,
    check_outputs,
    maybe_write_json,
    nonnegative_float,
    nonnegative_int,
    positive_float,
    positive_int,
)

NAME = "aero"
HELP = "unsteady aerodynamics: DLM generalized forces Q(k) on the modes and their RFA (aero.npz)"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "model", help="Nastran deck (.bdf) or 'goland' for the built-in heavy Goland wing"
    )
    p.add_argument("--mach", type=case_parameter("mach"), required=True,
                   help="Mach number (subsonic)")
    p.add_argument("--out", type=Path, required=True, metavar="AERO.npz",
                   help="aerodynamics file to write, e.g. aero.npz")
    p.add_argument("--modes", type=positive_int, default=9,
                   help="number of structural modes m (default 9)")
    p.add_argument("--lags", type=nonnegative_int, default=13, help="RFA lag states (default 13)")
    p.add_argument("--rfa", choices=["minimum-state", "roger"], default="minimum-state")
    p.add_argument(
        "--kernel",
        choices=["quartic", "parabolic"],
        default="quartic",
        help="DLM kernel approximation (PanelAero)",
    )
    p.add_argument(
        "--k",
        type=nonnegative_float,
        nargs="+",
        metavar="K",
        help="reduced frequencies k = ω b / V, the RFA fitted on all of them (default for a "
        "deck: chosen to cover the modes at the speeds of --speeds, the deck's MKAERO k among "
        "them, the RFA fitted on those that matter, from 0.8 x a p-k survey's flutter speed "
        "up, and checked there: see docs/guide/nastran.md; for goland: the Goland list); "
        "k = 0 is always added",
    )
    p.add_argument(
        "--speeds", type=positive_float, nargs=2, action=OrderedRange, metavar=("LO", "HI"),
        help="deck form: the speed range (deck length unit per s) the reduced frequencies "
        "cover and the p-k survey searches (default: the lowest elastic mode at k <= 2 to "
        "the highest at k >= 0.01, widened to the deck's FLUTTER velocities)",
    )
    p.add_argument(
        "--boxes",
        type=positive_int,
        nargs=2,
        metavar=("NCHORD", "NSPAN"),
        default=(8, 20),
        help="Goland planform boxes per half wing (default 8 20)",
    )
    p.add_argument(
        "--planform",
        choices=["deck", "goland"],
        default="deck",
        help="aerodynamic boxes from the deck's CAERO1 cards or the built-in Goland "
        "planform (default: deck; 'goland' for the built-in model)",
    )
    p.add_argument("--panels", type=Path, default=None, metavar="FILE",
                   help="aerodynamic cards to read with the deck as if INCLUDEd (e.g. from "
                        "torchrom panels DECK --out FILE), the deck left as it is")
    add_units_option(p, "the deck")
    add_force_option(p)
    add_json_option(p)


def load_fe(model: str, includes=()):
    """The FE model: built-in Goland or a Nastran deck through torchrom.fe."""
    from ..errors import InputError

    try:
        from .. import fe as fe_mod
    except ImportError as exc:
        raise InputError(f"the FE module (torchrom.fe) is not available: {exc}") from None
    if model == "goland":
        return fe_mod.goland()
    path = Path(model)
    if not path.is_file():
        raise InputError(f"{path}: file not found")
    return fe_mod.read_bdf(path, includes=includes)


def _check_units(args, fe) -> None:
    """--units against the deck's cards (:func:`torchrom.fe.deck_units.declare_units`); the
    built-in Goland planform is in ft, so only for a deck in ft-slug-s (or one that does not
    say)."""
    from ..errors import InputError
    from ..fe.deck_units import declare_units, describe_units
    from ..units import recorded_units

    if args.model == "goland":
        if args.units not in (None, "ft-slug-s"):
            raise InputError(f"--units {args.units}: the built-in Goland wing is in ft-slug-s")
        return
    declare_units(fe, args.units, str(args.model))
    system = recorded_units(fe.units or {})
    if args.planform == "goland" and system is not None and system.name != "ft-slug-s":
        raise InputError(f"{args.model}: --planform goland: the built-in planform is in ft but "
                         f"the deck is in {system.name}; give the deck CAERO1/SPLINE cards")
    info(f"  {describe_units(fe)}")


def _check_panels(path, includes=()) -> None:
    """Before the modal analysis: a deck without CAERO1 boxes needs panels (``torchrom
    panels``, given with ``--panels``) or ``--planform goland``."""
    from ..aero.panels import read_model
    from ..errors import InputError

    if not read_model(Path(path), includes).caeros:
        raise InputError(f"{path}: no CAERO1 cards (no aerodynamic panels in the deck): write "
                         f"them from its structure with torchrom panels {Path(path).name} --out "
                         f"panels.bdf and give --panels panels.bdf (or --planform goland for "
                         f"the built-in Goland planform, 6 x 20 ft)")


def run(args: argparse.Namespace) -> int:
    from ..aero.build import (
        GOLAND_K_LIST,
        build_from_deck,
        build_from_modes,
        modal_data,
        planform_modes,
    )
    from ..aero.panels import goland_panels
    from ..bounds import MAX_LAGS, check_boxes, check_count

    check_outputs(args, [args.out])
    goland = args.model == "goland" or args.planform == "goland"
    if goland:  # sizes before any work (a deck's own boxes are checked when it is read)
        check_boxes("--boxes", 2 * args.boxes[0] * args.boxes[1])
    check_count("--lags", "lag states", args.lags, MAX_LAGS)
    if goland and args.speeds is not None:
        from ..errors import InputError

        raise InputError("--speeds: for a deck's own panels (the built-in Goland planform "
                         "takes the Goland list of reduced frequencies, or --k)")
    includes = [args.panels] if args.panels is not None else []
    if goland and includes:
        from ..errors import InputError

        raise InputError("--panels: the deck's own aerodynamic cards, not with --planform "
                         "goland")
    if not goland:
        _check_panels(args.model, includes)
    info(f"torchrom aero: {args.model}: modal analysis ({args.modes} modes)")
    fe = load_fe(args.model, includes)
    _check_units(args, fe)
    bar = _progress()
    if goland:
        modes = planform_modes(fe, modal_data(fe, args.modes))
        k_list = GOLAND_K_LIST if args.k is None else sorted({0.0, *args.k})
        panels = goland_panels(*args.boxes)
        info(
            f"  {panels.n} boxes (built-in Goland planform, full span), {len(k_list)} reduced "
            f"frequencies, Mach {args.mach:g}, {args.kernel} kernel"
        )
        data = build_from_modes(
            modes, args.mach, args.lags, k_list, panels, None, args.kernel, args.rfa, progress=bar
        )
        data.metadata["source"] = args.model
    else:
        data = build_from_deck(
            args.model,
            fe,
            args.mach,
            args.modes,
            args.lags,
            args.k,
            args.kernel,
            args.rfa,
            progress=bar,
            speeds=args.speeds,
            includes=includes,
        )
    bar(None, None)
    err = data.rfa.fit_error
    print(
        "  modal frequencies (Hz): "
        + ", ".join(f"{f:.4g}" for f in data.metadata["frequencies_hz"])
    )
    print(
        f"  RFA ({data.rfa.kind}, {args.lags} lags): weighted RMS error {err['rms_relative']:.3e}, "
        f"worst entry {err['max_entry_relative']:.3e} "
        f"at Q{tuple(i + 1 for i in err['worst_entry'])}"
    )
    if "rigid_slope_k" in err:
        print(f"  RFA: the rigid-body modes' columns take the DLM's quasi-steady slope "
              f"Im Q / k at k = {err['rigid_slope_k']:g} (a free aircraft's double root s = 0)")
    survey = data.metadata.get("reduced_frequencies")
    if survey is not None:
        _print_survey(survey, data)
    data.save(args.out, force=args.force)
    print(f"wrote {args.out}")
    maybe_write_json(
        args,
        {
            "out": str(args.out),
            "mach": data.mach,
            "semichord": data.semichord,
            "n_modes": data.n_modes,
            "k": data.gaf.k.tolist(),
            "n_lags": args.lags,
            "rfa_kind": data.rfa.kind,
            "fit_error": err,
            "frequencies_hz": data.metadata["frequencies_hz"],
            "reduced_frequencies": data.metadata.get("reduced_frequencies"),
            "unit_system": data.metadata.get("unit_system"),
            "units": {"semichord": _length_unit(data), "frequencies_hz": "Hz", "k": "-"},
        },
    )
    return 0


#: the survey's numbers (None in the JSON record where not finite)
_NUMBERS = ("k_matter", "matter_speed", "k_fit", "k_check", "rfa_error")


def _print_survey(record: dict, data) -> None:
    """The reduced frequencies chosen, the survey and the RFA's check
    (:class:`torchrom.aero.reduced_frequencies.Survey`), and each failed check's warning."""
    from ..aero.reduced_frequencies import Survey

    fields = {k: (float("nan") if record[k] is None and k in _NUMBERS else record[k])
              for k in Survey.__dataclass_fields__ if k in record}
    survey = Survey(**{**fields, "speeds": tuple(record["speeds"])})
    unit = _length_unit(data)
    for line in survey.describe(f"{unit}/s" if unit else "length/s"):
        print(f"  {line}")
    for w in survey.warnings:
        print(f"  warning: {w}")


def _length_unit(data) -> str | None:
    """The length unit of the aero file's reference lengths (None: not recorded)."""
    from ..units import recorded_units

    system = recorded_units(data.metadata)
    return None if system is None else system.length


def _progress():
    """Progress over reduced frequencies (:class:`torchrom.progress.Progress`; closed by calling
    it with None)."""
    from ..progress import Progress

    state = {}

    def update(i, n):
        if i is None:
            if "bar" in state:
                state["bar"].close()
            return
        if "bar" not in state:
            state["bar"] = Progress(n, "  DLM", unit="reduced frequencies")
        state["bar"].update_to(state["bar"].done + 1)

    return update
