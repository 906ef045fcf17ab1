"""Checks of public parameters: type, sign and finiteness, with the parameter named.

Every public constructor and entry point checks its scalars here, so that a string, a bool where
a number belongs, a NaN or a zero batch raises one :class:`~torchrom.errors.InputError` naming
the parameter and what was expected — never a ``TypeError`` from deep inside, nor a silent run.
"""

from __future__ import annotations

import math
import numbers

from .errors import InputError


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
