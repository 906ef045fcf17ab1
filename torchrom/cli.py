"""The ``torchrom`` command.

Each sub-command lives in its own module under :mod:`torchrom.commands` and exposes
``NAME`` (the sub-command), ``HELP`` (one line), ``add_arguments(parser)`` and ``run(args)``,
and ``BOUNDED = True`` when it checks the bounds of :mod:`torchrom.bounds` (``--allow-large``).
Modules are discovered automatically, so adding a command never touches this file.

Bad input raises :class:`torchrom.errors.TorchromError`; it is printed as one line
(``torchrom <cmd>: error: ...``) and the exit status is 2; so is an ``OSError`` of the file
system (a full disk, no permission), which is not a bug either, and a ``MemoryError`` (a problem
too large for this machine even after the up-front bounds of :mod:`torchrom.bounds`, or torch's
allocation failure, its RuntimeError).
Everything a command prints goes through :class:`torchrom.text.SafeStream` (no terminal control
sequence from a title or a file name reaches the terminal) and :class:`torchrom.progress.AboveBars`
(a line printed while a progress bar is drawn goes above the bar), and a Python warning is one
line ``torchrom <cmd>: warning: ...``. pyNastran's logger (cpylog) is kept from colouring the
terminal (:func:`_uncoloured_pynastran_log`): the command line writes no colour at all.
"""

from __future__ import annotations

import argparse
import atexit
import importlib
import pkgutil
import sys
import warnings

from . import __version__
from .errors import TorchromError
from .text import SafeStream, printable


def _command_modules():
    from . import commands

    mods = []
    for info in pkgutil.iter_modules(commands.__path__):
        if info.name.startswith("_"):
            continue
        mods.append(importlib.import_module(f"{commands.__name__}.{info.name}"))
    order = getattr(commands, "ORDER", [])
    mods.sort(key=lambda m: (order.index(m.NAME) if m.NAME in order else len(order), m.NAME))
    return mods


def _add_common_options(parser: argparse.ArgumentParser, bounded: bool) -> None:
    """--quiet / --verbose (:mod:`torchrom.progress`) of every command, and --allow-large
    (:mod:`torchrom.bounds`) of those that check a bound (``BOUNDED = True`` in the command's
    module): an option that can change nothing is not offered."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("-q", "--quiet", action="store_true",
                       help="no progress output and no stage messages (results and errors only)")
    group.add_argument("-v", "--verbose", action="store_true",
                       help="a progress line at every update (instead of a bar or one per 10 %%)")
    if bounded:
        parser.add_argument("--allow-large", action="store_true",
                            help="run even when the up-front estimate of cases x steps or memory "
                                 "is over the bound (see torchrom.bounds)")


def _mark_required(parser: argparse.ArgumentParser) -> None:
    """Every required option's help says so, so that an example in it (``rom.npz``) does not
    read as a default."""
    for action in parser._actions:
        if action.required and action.option_strings and action.help and \
                "(required)" not in action.help:
            action.help = f"{action.help} (required)"


class _Parser(argparse.ArgumentParser):
    """argparse with the command line's one-line errors: ``torchrom <cmd>: error: ...`` and
    where to read the usage, instead of the usage block and the message (exit status 2)."""

    def error(self, message: str):
        self.exit(2, f"{self.prog}: error: {printable(message)} (see {self.prog} --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="torchrom",
        description=(
            "Nonlinear reduced-order models with Kelvin-Voigt damping, flutter and batched "
            "post-flutter LCO studies."
        ),
    )
    parser.add_argument("--version", action="version", version=f"torchrom {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for mod in _command_modules():
        p = sub.add_parser(mod.NAME, help=mod.HELP, description=mod.HELP)
        mod.add_arguments(p)
        _mark_required(p)
        _add_common_options(p, getattr(mod, "BOUNDED", False))
        p.set_defaults(_run=mod.run, _name=mod.NAME)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "command", None):
        parser.print_help()
        return 0
    from .bounds import set_allow_large
    from .progress import NORMAL, QUIET, VERBOSE, AboveBars, set_verbosity

    set_verbosity(QUIET if args.quiet else VERBOSE if args.verbose else NORMAL)
    set_allow_large(getattr(args, "allow_large", False))
    _uncoloured_pynastran_log()
    streams = sys.stdout, sys.stderr
    sys.stdout = AboveBars(SafeStream(sys.stdout))
    sys.stderr = AboveBars(SafeStream(sys.stderr))
    try:
        with warnings.catch_warnings():
            warnings.showwarning = _one_line_warning(args._name)
            return _run(args)
    finally:
        sys.stdout, sys.stderr = streams
        set_allow_large(False)  # the option is this run's; the API keeps its own bounds


def _uncoloured_pynastran_log() -> None:
    """Import pyNastran's logger (cpylog) now and undo what it does on a terminal.

    Imported with stdout a terminal, cpylog calls ``colorama.init(autoreset=True)``, which
    replaces ``sys.stdout``/``sys.stderr`` by wrappers writing a colour reset (ESC [0m) after
    every write and once more at exit, and it colours its own messages. Behind
    :class:`SafeStream` each reset would show as the text ``\\x1b[0m`` and push a progress
    bar past the terminal's edge. Here the wrappers are removed (only if they are still the
    streams: nothing else is undone), the exit reset unregistered, and cpylog writes plain
    text. Without pyNastran (or colorama) installed, nothing to do.
    """
    try:
        import colorama.initialise as colorama_init
        import cpylog
        from cpylog.screen_utils import write_screen
    except ImportError:
        return
    wrapped = False
    if sys.stdout is not None and sys.stdout is colorama_init.wrapped_stdout:
        sys.stdout, wrapped = colorama_init.orig_stdout, True
    if sys.stderr is not None and sys.stderr is colorama_init.wrapped_stderr:
        sys.stderr, wrapped = colorama_init.orig_stderr, True
    if wrapped:
        atexit.unregister(colorama_init.reset_all)
    cpylog._write = write_screen
    cpylog.USE_COLORAMA = False


def _one_line_warning(command: str):
    """``warnings.showwarning`` of the command line: one line, no source line; a warning that
    a command also reports as a note (an ignored card) is not printed twice."""
    def show(message, category, filename, lineno, file=None, line=None):
        from .fe.bdf_read import UnsupportedCardWarning

        if issubclass(category, UnsupportedCardWarning):
            return
        text = " ".join(str(message).split())
        print(f"torchrom {command}: warning: {printable(text)}", file=sys.stderr)

    return show


def _run(args: argparse.Namespace) -> int:
    from .progress import close_bars

    try:
        try:
            rc = args._run(args)
        finally:
            close_bars()  # a bar left open by a failure is not redrawn under its error line
    except TorchromError as exc:
        print(f"torchrom {args._name}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        # the file system refused (disk full, permission, a folder that is a file): not a bug
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"torchrom {args._name}: error: {printable(where)}{exc.strerror or exc}",
              file=sys.stderr)
        return 2
    except MemoryError:
        print(f"torchrom {args._name}: error: out of memory; the problem is too large for this "
              f"machine (fewer cases, a smaller batch_size or fewer harmonics)", file=sys.stderr)
        return 2
    except RuntimeError as exc:
        if not _allocation_failure(exc):
            raise  # a bug: its traceback
        print(f"torchrom {args._name}: error: out of memory ({_allocation_size(exc)}); the "
              f"problem is too large for this machine (fewer cases, a smaller batch_size, a "
              f"larger dt or fewer harmonics)", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"torchrom {args._name}: interrupted; finished results were kept", file=sys.stderr)
        return 130
    return int(rc or 0)


def _allocation_failure(exc: RuntimeError) -> bool:
    """Whether ``exc`` is torch's refusal to allocate (CPU: "DefaultCPUAllocator: can't allocate
    memory"; CUDA: torch.OutOfMemoryError), which the up-front bounds estimate but cannot
    always foresee: a MemoryError by another name."""
    text = str(exc)
    return ("can't allocate memory" in text or "CUDA out of memory" in text
            or type(exc).__name__ == "OutOfMemoryError")


def _allocation_size(exc: RuntimeError) -> str:
    import re

    m = re.search(r"allocate (\d+) bytes", str(exc))
    if m is None:
        return "an allocation failed"
    from .bounds import format_bytes

    return f"an allocation of {format_bytes(float(m.group(1)))} failed"


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
