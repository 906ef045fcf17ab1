"""Helpers shared by the sub-commands: --json/--force/--workers options and result reporting."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..io import write_figure as write_figure  # noqa: F401 - the commands' name for it
from ..io import write_json_atomic

#: the sweep solvers' names (torchrom.study.solvers.SOLVERS; spelled out here so that building
#: the parser imports no torch)
METHODS = ("newmark", "hb", "shooting")


def add_precision_options(parser: argparse.ArgumentParser) -> None:
    """--device and --dtype of the batched integration."""
    parser.add_argument("--device", default="cpu", help="torch device, e.g. cpu or cuda:0")
    parser.add_argument("--dtype", choices=("float64", "float32"), default="float64",
                        help="floating-point precision of the integration (default float64)")


#: device types the integrators run on (meta, xla, ... hold no values to compute with)
DEVICE_TYPES = ("cpu", "cuda")


def torch_device(name: str):
    """The torch device ``name`` (InputError when it is not one, not a type in
    :data:`DEVICE_TYPES`, or a CUDA device this machine does not have)."""
    import torch

    from ..errors import InputError

    try:
        dev = torch.device(name)
    except (RuntimeError, ValueError) as exc:
        raise InputError(f"--device: not a torch device: {name!r} ({exc})") from None
    if dev.type not in DEVICE_TYPES:
        raise InputError(f"--device: expected a device of type {' or '.join(DEVICE_TYPES)} "
                         f"(e.g. cpu, cuda:0), got {name!r}")
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise InputError(f"--device: {name} requested but CUDA is not available")
    if dev.type == "cuda" and dev.index is not None and dev.index >= torch.cuda.device_count():
        raise InputError(f"--device: {name}: this machine has {torch.cuda.device_count()} CUDA "
                         f"device(s)")
    return dev


def cpu_workers(value: str) -> int:
    """``--workers`` value: a positive integer or 'auto' (one worker process per core this
    process may use: affinity and cgroup CPU quota, :func:`torchrom.limits.usable_cpus`)."""
    from ..limits import usable_cpus

    n = usable_cpus() if value == "auto" else (int(value) if value.isdigit() else 0)
    if n < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer or 'auto', got {value!r}")
    return n


def _integer(value: str, minimum: int, what: str) -> int:
    try:
        n = int(value)
    except ValueError:
        n = minimum - 1
    if n < minimum:
        raise argparse.ArgumentTypeError(f"expected {what}, got {value!r}")
    return n


def _number(value: str, ok, what: str) -> float:
    import math

    try:
        x = float(value)
    except ValueError:
        x = math.nan
    if not (math.isfinite(x) and ok(x)):
        raise argparse.ArgumentTypeError(f"expected {what}, got {value!r}")
    return x


# argparse types of the numeric options (argparse names the option, exits with 2)
def positive_int(value: str) -> int:
    return _integer(value, 1, "a positive integer")


def nonnegative_int(value: str) -> int:
    return _integer(value, 0, "an integer >= 0")


def thread_count(value: str) -> int:
    """A number of torch threads: 1 to the machine's cores (more only multiplies threads
    contending for the same cores; at 100000 the thread stacks exhausted the memory). Cores:
    those this process may use (:func:`torchrom.limits.usable_cpus`)."""
    from ..limits import usable_cpus

    cores = usable_cpus()
    n = _integer(value, 1, f"a number of threads from 1 to {cores} (the cores of this machine)")
    if n > cores:
        raise argparse.ArgumentTypeError(f"expected a number of threads from 1 to {cores} (the "
                                         f"cores of this machine), got {value!r}")
    return n


def positive_float(value: str) -> float:
    return _number(value, lambda x: x > 0, "a positive finite number")


def nonnegative_float(value: str) -> float:
    return _number(value, lambda x: x >= 0, "a finite number >= 0")


def finite_float(value: str) -> float:
    return _number(value, lambda x: True, "a finite number")


class OrderedRange(argparse.Action):
    """``--option LO HI`` (nargs=2) whose LO < HI is checked when it is parsed: a reversed or
    empty range is refused naming the option, before any work."""

    def __call__(self, parser, namespace, values, option_string=None):
        lo, hi = values
        if not lo < hi:
            parser.error(f"argument {option_string}: expected LO < HI, got {lo:g} {hi:g}")
        setattr(namespace, self.dest, values)


def case_parameter(name: str):
    """argparse type of an option that sets case parameter ``name``: a finite number in its
    physical range (:data:`torchrom.checks.PHYSICAL_RANGES`, the table every entry point uses)."""
    def parse(value: str) -> float:
        from ..checks import physical
        from ..errors import InputError

        x = finite_float(value)
        try:
            return physical(name, x)
        except InputError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None

    parse.__name__ = name  # argparse names the type in its message
    return parse


def figure_file(value: str) -> Path:
    """argparse type of a figure file option: a name whose suffix is a format matplotlib
    writes (:func:`torchrom.io.check_figure_path`)."""
    from ..errors import InputError
    from ..io import check_figure_path

    try:
        return check_figure_path(value, "")
    except InputError as exc:
        raise argparse.ArgumentTypeError(str(exc).strip()) from None


def add_executor_options(parser: argparse.ArgumentParser) -> None:
    """--workers N | --scheduler ADDR and --chunk-size (commands that run many cases; see
    :mod:`torchrom.study.runner`). Default: in-process."""
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--workers", type=cpu_workers, default=None, metavar="N",
                       help="run chunks on a local Dask cluster of N single-threaded worker "
                            "processes ('auto': one per core)")
    group.add_argument("--scheduler", default=None, metavar="ADDR",
                       help="run chunks on the existing Dask cluster at ADDR "
                            "(e.g. tcp://host:8786); refused when a worker runs another "
                            "torchrom (version or files), torch, dask or Python than this "
                            "command")
    parser.add_argument("--chunk-size", type=positive_int, default=None, metavar="N",
                        help="cases per chunk of work, one chunk per worker at a time "
                             "(default: [run] chunk_size, else at most 8 chunks up to 4,096 "
                             "cases, or chunks of [run] batch_size with method hb or shooting; "
                             "a cluster of more workers needs it)")


def add_json_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json",
        metavar="FILE",
        type=Path,
        help="also write the results machine-readably to FILE (JSON; keys and units documented)",
    )


def add_unsupported_option(parser: argparse.ArgumentParser, what: str = "") -> None:
    """--unsupported error|warn of the commands that read a structural deck (``what``: a prefix
    of the help text, e.g. which of a command's forms reads the deck)."""
    parser.add_argument("--unsupported", choices=("error", "warn"), default="error",
                        help=f"{what}what to do with unsupported structural cards (default error)")


def add_wing_axes_options(parser: argparse.ArgumentParser) -> None:
    """--up-axis/--span-axis: the wing's directions where the deck cannot tell them (see
    :mod:`torchrom.fe.wing_frame`)."""
    parser.add_argument("--up-axis", default=None, metavar="AXIS",
                        help="the wing's up direction in basic axes: x, y, z, -x, ... or a,b,c "
                             "(default: the AERO card's system where the deck has CAERO panels, "
                             "else the structure's thinnest direction, else the beams' weakest "
                             "bending direction)")
    parser.add_argument("--span-axis", default=None, metavar="AXIS",
                        help="the wing's span direction, root to tip (default: the structure's "
                             "longest direction, pointing away from the constraints)")


def apply_wing_axes(args: argparse.Namespace, fe, say: bool = True) -> None:
    """Give ``fe`` the user's --up-axis/--span-axis and, with ``say``, print the wing's axes
    (or that they cannot be told: kinds are then "unknown")."""
    from ..fe.wing_frame import SPAN_OPTION, UP_OPTION, WingFrameError, parse_axis

    up = parse_axis(getattr(args, "up_axis", None), UP_OPTION)
    span = parse_axis(getattr(args, "span_axis", None), SPAN_OPTION)
    fe.set_wing_axes(up, span)
    try:
        frame = fe.wing_frame()
    except WingFrameError as exc:
        if say:
            print(f"note: {exc}")
        return
    if say:
        print(f"wing axes: {frame.describe()}")


def unit_system_name(value: str) -> str:
    """A ``--units`` value: the name of a system of :mod:`torchrom.units`."""
    from ..units import SYSTEMS

    if value not in SYSTEMS:
        raise argparse.ArgumentTypeError(f"expected one of {', '.join(SYSTEMS)}, got {value!r}")
    return value


def add_units_option(parser: argparse.ArgumentParser, what: str) -> None:
    """--units: the unit system of the model (see :mod:`torchrom.units`)."""
    parser.add_argument("--units", type=unit_system_name, default=None,
                        metavar="si|ft-slug-s|in-lbf-s|mm-t-s",
                        help=f"unit system of {what} (default: read from the deck's AERO "
                             f"RHOREF, GRAV or PARAM WTMASS; refused when they disagree)")


def add_force_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--force", action="store_true", help="overwrite outputs that already exist"
    )


def add_study_options(parser: argparse.ArgumentParser, outputs: str) -> None:
    """--out DIR (holding ``outputs``), --device/--dtype, --workers/--scheduler/--chunk-size,
    --json and --force: the options of the commands that simulate cases of a configuration."""
    parser.add_argument("--out", type=Path, required=True, metavar="DIR",
                        help=f"output folder ({outputs})")
    parser.add_argument("--method", choices=METHODS, default=None,
                        help="time marching (newmark), periodic orbits by harmonic balance "
                             "(hb) or by shooting on the Newmark map from harmonic balance "
                             "(shooting); default: the configuration's 'method' "
                             "(newmark)")
    add_precision_options(parser)
    add_executor_options(parser)
    add_json_option(parser)
    add_force_option(parser)
    add_cache_option(parser)


def add_cache_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--cache-dir", type=Path, default=None, metavar="DIR",
                        help="cache root for built-in models (default: $TORCHROM_CACHE, else "
                             "the user cache folder, $XDG_CACHE_HOME/torchrom or "
                             "~/.cache/torchrom on Linux; see `torchrom cache info`)")


def apply_cache_dir(args: argparse.Namespace) -> None:
    """``--cache-dir DIR``: the cache root of this run (:func:`torchrom.cache_dir.set_cache_root`);
    InputError when DIR exists and is not a folder."""
    folder = getattr(args, "cache_dir", None)
    if folder is None:
        return
    from ..cache_dir import set_cache_root
    from ..errors import InputError

    if folder.exists() and not folder.is_dir():
        raise InputError(f"--cache-dir: {folder} is a file, expected a folder (created if "
                         f"missing)")
    set_cache_root(folder)


def load_study(args: argparse.Namespace):
    """(torch device, torch dtype, SweepConfig) from --device, --dtype and the configuration."""
    import torch

    from ..study.config import load_sweep_config, with_method

    apply_cache_dir(args)
    cfg = with_method(load_sweep_config(args.config), getattr(args, "method", None))
    if getattr(args, "workers", None) is not None:  # processes, bounded like threads
        from ..bounds import check_threads

        check_threads("--workers", args.workers, override=cfg.allow_large)
    return torch_device(args.device), getattr(torch, args.dtype), cfg


def check_outputs(args: argparse.Namespace, paths, may_replace: bool | None = None) -> None:
    """The output policy of every command, applied before any work: refuse (InputError) when an
    output or the --json file exists, unless --force (``may_replace`` overrides --force for
    ``paths``, e.g. a sweep resuming its own), or when the folder of an output (e.g. --out) is a
    file or not writable (:func:`torchrom.io.check_can_write`)."""
    from ..io import check_can_write

    force = bool(getattr(args, "force", False))
    for p in paths:
        check_can_write(p, force if may_replace is None else may_replace, "output")
    if getattr(args, "json", None) is not None:
        check_can_write(args.json, force, "JSON output")


def maybe_write_json(args: argparse.Namespace, obj: Any) -> None:
    path = getattr(args, "json", None)
    if path is not None:
        write_json_atomic(path, obj)
        print(f"wrote {path}")
