"""``torchrom update DECK --targets FILE.toml --out UPDATED.bdf``: FE model updating.

Fits the declared parameters of the deck (properties' NSM or dimensions, densities, CONM2
masses/offsets/inertias, each bounded) to target natural frequencies, paired with the modes by
kind or by MAC (:mod:`torchrom.fe.update`; the targets file format:
:mod:`torchrom.fe.update_config`), and writes the updated deck.

JSON (``--json FILE``): ``parameters`` (name → card, ids, field, initial, final, lower, upper,
at_bound; model units), ``targets`` (name, target_hz, initial_hz, final_hz, initial_diff_pct,
final_diff_pct (100 (model − target)/target), mode (1-based, of the updated model), kind,
kind_wanted, kind_ok, mac: of the final mode against the initially paired mode or the reference
mode), ``history`` (per iteration: cost, rms_diff_pct, max_abs_diff_pct, frequencies_hz,
parameters), ``mac`` (targets × computed modes, the same MAC), ``final_modes``,
``total_mass_initial``/``total_mass_final`` (rigid-body mass of the whole model, mass units of
the deck), ``rms_diff_pct``, ``max_abs_diff_pct``, ``converged``,
``message``, ``n_iterations``, ``n_evaluations``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import (
    add_force_option,
    add_json_option,
    add_unsupported_option,
    maybe_write_json,
)

NAME = "update"
HELP = "update deck parameters (NSM, densities, masses, offsets, dimensions) to target frequencies"
#: checks the bounds of torchrom.bounds (the command line offers --allow-large)
BOUNDED = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("deck", type=Path, help="Nastran bulk data deck to update")
    parser.add_argument("--targets", type=Path, required=True, metavar="FILE.toml",
                        help="targets and parameters (TOML; see torchrom.fe.update_config)")
    parser.add_argument("--out", type=Path, required=True, metavar="UPDATED.bdf",
                        help="the updated deck")
    add_unsupported_option(parser)
    add_json_option(parser)
    add_force_option(parser)


def report_lines(result) -> list[str]:
    """Plain-text tables of an :class:`~torchrom.fe.update.UpdateResult`."""
    lines = [f"{'target':<22} {'target Hz':>10} {'initial Hz':>10} {'diff %':>8} "
             f"{'final Hz':>10} {'diff %':>8} {'mode':>4} {'kind':<9} {'MAC':>5}"]
    for t in result.targets:
        lines.append(f"{t['name'][:22]:<22} {t['target_hz']:10.4f} {t['initial_hz']:10.4f} "
                     f"{t['initial_diff_pct']:+8.2f} {t['final_hz']:10.4f} "
                     f"{t['final_diff_pct']:+8.2f} {t['mode']:>4} {t['kind']:<9} "
                     f"{t['mac']:5.3f}" + ("" if t["kind_ok"] else "  (kind differs)"))
    lines.append("")
    lines.append(f"{'parameter':<22} {'card':<6} {'field':<5} {'initial':>12} {'final':>12} "
                 f"{'bounds':>24}")
    for name, p in result.parameters.items():
        bounds = f"[{p['lower']:.4g}, {p['upper']:.4g}]"
        lines.append(f"{name[:22]:<22} {p['card']:<6} {p['field']:<5} {p['initial']:12.6g} "
                     f"{p['final']:12.6g} {bounds:>24}" + ("  at bound" if p["at_bound"] else ""))
    s = result.summary()
    lines.extend(f"note: {n}" for n in result.notes)
    lines.append("")
    lines.append(f"{result.n_iterations} iterations, {result.n_evaluations} evaluations: "
                 f"{result.message}; rms {s['rms_diff_pct']:.3g} %, max |diff| "
                 f"{s['max_abs_diff_pct']:.3g} %; total mass {result.total_mass_initial:.6g} → "
                 f"{result.total_mass_final:.6g}")
    return lines


def run(args: argparse.Namespace) -> int:
    from ..fe import read_bdf, write_bdf
    from ..fe.update import check_final_misfit, update_model
    from ..fe.update_config import load_update_spec
    from ..io import check_can_write

    check_can_write(args.out, args.force, "deck")
    if args.json is not None:
        check_can_write(args.json, args.force, "JSON file")
    spec = load_update_spec(args.targets)
    fe = read_bdf(args.deck, unsupported=args.unsupported)
    reference = (read_bdf(spec.reference_deck, unsupported=args.unsupported)
                 if spec.reference_deck is not None else None)
    print(f"{args.deck}: {fe.n_dof} free DOFs; {len(spec.targets)} targets, "
          f"{len(spec.parameters)} parameters")
    new, result = update_model(fe, spec, reference=reference)
    print("\n".join(report_lines(result)))
    check_final_misfit(result)
    write_bdf(new, args.out, force=args.force)
    print(f"wrote {args.out}")
    maybe_write_json(args, result.as_dict())
    return 0
