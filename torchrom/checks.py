"""Checks of public parameters: type, sign and finiteness, with the parameter named.

Every public constructor and entry point checks its scalars here, so that a string, a bool where
a number belongs, a NaN or a zero batch raises one :class:`~torchrom.errors.InputError` naming
the parameter and what was expected — never a ``TypeError`` from deep inside, nor a silent run.
"""

from __future__ import annotations

import math
import numbers

from .errors import InputError

#: geometric altitude range of ambiance's USSA-76 model, m (torchrom.aero.atmosphere's)
ALTITUDE_RANGE_M = (-5004.0, 81020.0)


def real(name: str, value, *, positive: bool = False, nonnegative: bool = False,
         finite: bool = True) -> float:
    """``value`` as a float: a real number (not a bool or a string), finite unless ``finite`` is
    False, and > 0 or ≥ 0 when asked."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise InputError(f"{name}: expected a number, got {value!r} ({type(value).__name__})")
    x = float(value)
    if math.isnan(x) or (finite and not math.isfinite(x)):
        raise InputError(f"{name}: expected a finite number, got {value!r}")
    if positive and not x > 0:
        raise InputError(f"{name}: expected a positive number, got {value!r}")
    if nonnegative and not x >= 0:
        raise InputError(f"{name}: expected a number >= 0, got {value!r}")
    return x


def integer(name: str, value, *, minimum: int | None = None) -> int:
    """``value`` as an int: an integer (not a bool, float or string), ≥ ``minimum`` if given."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise InputError(f"{name}: expected an integer, got {value!r} ({type(value).__name__})")
    if minimum is not None and value < minimum:
        raise InputError(f"{name}: expected an integer >= {minimum}, got {value!r}")
    return int(value)


def real_array(name: str, value):
    """``value`` (a number, sequence or array) as a float64 numpy array; InputError naming the
    parameter when it holds something that is not a number (a string, a ragged list)."""
    import numpy as np

    if isinstance(value, (str, bytes)):
        raise InputError(f"{name}: expected numbers, got {value!r}")
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: expected numbers ({exc})") from None


#: Physical range of every case parameter, checked in one place (:func:`physical`) by every
#: entry point: sweep / branch / calibrate configurations, the flutter command's options and the
#: Python API (:meth:`torchrom.sim.CaseSystem.build`, the flutter structure, the aeroelastic
#: model). name -> (lowest, highest (excluded unless infinite), units, why). α may be negative
#: (a matched α of a large γ is), γ may not: a negative Kelvin-Voigt factor feeds energy into
#: every mode, which is no damping model at all.
PHYSICAL_RANGES = {
    "gamma": (0.0, math.inf, "s", "the Kelvin-Voigt factor (stiffness-proportional damping) "
              "cannot be negative"),
    "stiffness_nl": (0.0, math.inf, "", "a scale of the nonlinear stiffness (0 off, 1 as "
                     "identified)"),
    "damping_nl": (0.0, math.inf, "", "a scale of the nonlinear damping (0 off, 1 as "
                   "identified)"),
    "mach": (0.0, 1.0, "", "the doublet-lattice method is subsonic"),
    "aoa_deg": (-30.0, 30.0, "deg", "the steady loads are linear in the root angle of attack: "
                "a wing past ~15 deg has stalled"),
}


def _range(name: str) -> tuple[float, float, str, str]:
    """The physical range of ``name``: :data:`PHYSICAL_RANGES`, or for ``altitude_ft`` and
    ``altitude_m`` the atmosphere model's (:data:`ALTITUDE_RANGE_M`, which the atmosphere
    module uses too) in the column's unit."""
    metres = {"altitude_ft": 0.3048, "altitude_m": 1.0}.get(name)
    if metres is not None:
        lo, hi = (h / metres for h in ALTITUDE_RANGE_M)
        return (lo, math.nextafter(hi, math.inf), name.split("_")[1],
                "the USSA-76 atmosphere's range")
    return PHYSICAL_RANGES.get(name, (-math.inf, math.inf, "", ""))


def physical(name: str, value, where: str = "") -> float:
    """``value`` of case parameter ``name`` checked against :data:`PHYSICAL_RANGES` (and
    finite); InputError naming ``where`` and ``name`` otherwise."""
    label = f"{where} {name}".strip()
    x = real(label, value)
    lo, hi, units, why = _range(name)
    if not (lo <= x and (x < hi or hi == math.inf)):
        span = (f">= {lo:g}" if hi == math.inf else f"in [{lo:.6g}, {hi:.6g})"
                if lo > -math.inf else f"<= {hi:g}")
        raise InputError(f"{label}: expected a value {span}{' ' + units if units else ''}, got "
                         f"{value!r} ({why})")
    return x


def physical_values(name: str, values, where: str = "") -> None:
    """:func:`physical` of every value of a sequence (or array) of case parameter ``name``."""
    import numpy as np

    flat = np.asarray(values, dtype=np.float64).reshape(-1)
    lo, hi = _range(name)[:2]
    bad = np.flatnonzero(~((flat >= lo) & ((flat < hi) | (hi == math.inf))))
    if bad.size:
        k = int(bad[0])
        suffix = f" (case {k})" if flat.size > 1 else ""
        try:
            physical(name, float(flat[k]), where)
        except InputError as exc:
            raise InputError(f"{exc}{suffix}") from None


#: what each file kind of :func:`file_kind` is, in a refusal
FILE_KINDS = {
    "rom": "a ROM file (torchrom identify's rom.npz)",
    "aero": "an aerodynamics file (torchrom aero's aero.npz)",
    "npz": "a NumPy .npz archive",
    "zip": "a zip archive",
    "parquet": "a parquet table",
    "binary": "a binary file",
    "empty": "an empty file",
    "directory": "a folder",
    "missing": "missing",
    "text": "a text file (a deck or a configuration?)",
}


def file_kind(path) -> str:
    """What a file is, from its content (not its name): "missing", "directory", "empty",
    "rom" / "aero" (the .npz files of :mod:`torchrom.rom.storage` and
    :mod:`torchrom.aero.files`, told apart by their arrays), "npz" (another .npz), "zip",
    "parquet", "binary" (a NUL byte or not UTF-8 in its first 64 kB) or "text"."""
    import zipfile
    from pathlib import Path

    p = Path(path)
    if not p.exists():
        return "missing"
    if p.is_dir():
        return "directory"
    try:
        with open(p, "rb") as f:
            head = f.read(65536)
    except OSError:
        return "missing"
    if not head:
        return "empty"
    if head.startswith(b"PAR1"):
        return "parquet"
    if head.startswith(b"PK\x03\x04"):
        try:
            with zipfile.ZipFile(p) as z:
                names = {n.removesuffix(".npy") for n in z.namelist()}
        except (zipfile.BadZipFile, OSError):
            return "binary"
        if not names or not all(n.endswith(".npy") for n in z.namelist()):
            return "zip"
        if "rfa_kind" in names:
            return "aero"
        if {"M", "K1", "K2", "K3"} <= names:
            return "rom"
        return "npz"
    if b"\x00" in head:
        return "binary"
    try:
        head.decode("utf-8")
    except UnicodeDecodeError as exc:
        if exc.start < len(head) - 4:  # not a multi-byte character cut at the 64 kB mark
            return "binary"
    return "text"


def expect_text_file(path, what: str, example: str) -> None:
    """InputError naming ``path`` unless it is a non-empty text file (a Nastran deck, a TOML
    configuration): one line saying what it is instead and what was expected (``what``, e.g.
    "a Nastran deck", ``example`` e.g. "model.bdf")."""
    kind = file_kind(path)
    if kind == "text":
        return
    if kind == "missing":
        raise InputError(f"{path}: file not found (expected {what}, e.g. {example})")
    raise InputError(f"{path}: this is {FILE_KINDS[kind]}, not {what} (expected a text file, "
                     f"e.g. {example})")


def expect_file_kind(path, kind: str, where: str) -> None:
    """InputError unless ``path`` is a file of ``kind`` (:func:`file_kind`: "rom" or "aero"):
    one line naming ``where`` (e.g. a configuration key), what the file is and what was
    expected; a missing file is left to the reader's own message."""
    found = file_kind(path)
    if found not in (kind, "missing"):
        raise InputError(f"{where}: {path} is {FILE_KINDS[found]}, expected {FILE_KINDS[kind]}")
