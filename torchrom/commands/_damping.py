"""The structural damping a command uses: ``--damping-ratio``, ``--alpha``/``--gamma`` and a
ROM's record (:mod:`torchrom.rom.rayleigh`; the deck's cards: :mod:`torchrom.fe.damping_cards`).

Precedence: ``--alpha``/``--gamma`` (each one given replaces that coefficient), else
``--damping-ratio`` mapped on the model's elastic modes, else what the ROM records (``identify``
writes it: the deck's cards, the ratio it was given, the Goland wing's Eq. 46 values, or none),
else none. ``--damping-ratio`` together with ``--alpha``/``--gamma`` is refused.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

from ..errors import InputError

if TYPE_CHECKING:
    from ..rom.rayleigh import DampingRatio, RayleighDamping


def damping_ratio_value(value: str) -> tuple[float, float | None]:
    """argparse type of ``--damping-ratio``: ``ZETA`` or ``ZETA@FREQ_HZ``."""
    from ..rom.rayleigh import parse_ratio_token

    try:
        return parse_ratio_token(value)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


damping_ratio_value.__name__ = "damping_ratio"  # argparse names the type in its message


def add_damping_ratio_option(parser, what: str) -> None:
    parser.add_argument(
        "--damping-ratio", type=damping_ratio_value, nargs="+", default=None,
        metavar="ZETA[@F]",
        help=f"{what}modal damping ratio (fraction of critical): ZETA at every elastic mode "
             "(e.g. 0.02), or ZETA1@F1 ZETA2@F2 at two frequencies in Hz (e.g. 0.01@2 "
             "0.03@20); mapped to the mass- and stiffness-proportional α, γ of the model, "
             "ζ(ω) = α/(2ω) + γω/2 (a least-squares fit over the modes, or the two points "
             "exactly), and the line printed says what was used")


def damping_ratio_of(args, beside_alpha_gamma: bool = True) -> DampingRatio | None:
    """The parsed ``--damping-ratio`` (:class:`~torchrom.rom.rayleigh.DampingRatio`) or None;
    InputError for a bad combination of values, or beside ``--alpha``/``--gamma`` (where the
    command's ``--alpha``/``--gamma`` are the damping: ``beside_alpha_gamma``; identify's
    ``--gamma`` is its report's free decay)."""
    from ..rom.rayleigh import damping_ratio

    given = getattr(args, "damping_ratio", None)
    if given is None:
        return None
    explicit = [o for o, v in (("--alpha", getattr(args, "alpha", None)),
                               ("--gamma", getattr(args, "gamma", None)))
                if v is not None and beside_alpha_gamma]
    if explicit:
        raise InputError(f"--damping-ratio: not with {' and '.join(explicit)} (each states the "
                         "structural damping; give one of them)")
    return damping_ratio(given)


def with_options(args, base: RayleighDamping) -> RayleighDamping:
    """``base`` (:class:`~torchrom.rom.rayleigh.RayleighDamping`) with ``--alpha``/``--gamma``
    where given, its line saying which came from where."""
    from ..rom.rayleigh import RayleighDamping

    alpha, gamma = getattr(args, "alpha", None), getattr(args, "gamma", None)
    if alpha is None and gamma is None:
        return base
    a = base.alpha if alpha is None else float(alpha)
    g = base.gamma if gamma is None else float(gamma)
    rest = ""
    if alpha is None or gamma is None:  # the other one from the base, named
        other = "γ" if alpha is not None else "α"
        rest = f" ({other} from {base.description.removeprefix('structural damping: ')})"
    return RayleighDamping(a, g, "options",
                           f"structural damping: α = {a:g} 1/s"
                           f"{' (--alpha)' if alpha is not None else ''}, γ = {g:g} s"
                           f"{' (--gamma)' if gamma is not None else ''}{rest}")


def damping_for_rom(args, rom, rom_path) -> RayleighDamping:
    """The damping of a ROM-file command (module docstring): a
    :class:`~torchrom.rom.rayleigh.RayleighDamping` whose ``description`` the command prints."""
    from ..rom.rayleigh import RayleighDamping, no_damping, rom_modes

    ratio = damping_ratio_of(args)
    if ratio is not None:
        f, free = rom_modes(rom)
        return ratio.rayleigh(f, free)
    recorded = RayleighDamping.from_metadata(rom.metadata, str(rom_path))
    if recorded is None:
        recorded = no_damping(f"{rom_path} records no structural damping: written before "
                              "identify recorded it, or not by identify")
    elif recorded.description:
        recorded = RayleighDamping(recorded.alpha, recorded.gamma, recorded.source,
                                   f"{recorded.description} [{rom_path}]",
                                   recorded.frequencies_hz, recorded.zeta_target)
    return with_options(args, recorded)


def damping_for_modes(args, frequencies_hz, default: RayleighDamping) -> RayleighDamping:
    """The damping of a model given by its elastic ``frequencies_hz`` (the built-in Goland
    wing: ``default`` its paper values)."""
    ratio = damping_ratio_of(args)
    if ratio is not None:
        return ratio.rayleigh(frequencies_hz, free=False)
    return with_options(args, default)
