"""Reproducible eigenvectors: a fixed ARPACK start and a tie-proof sign convention.

Used by every modal analysis (built-in FE, FE backends) and by the dual modes, so that the same
model gives the same basis — bit for bit on one machine — from run to run.
"""

from __future__ import annotations

import numpy as np


def orient_columns(V: np.ndarray) -> np.ndarray:
    """Columns of V with a reproducible sign: the first entry (in DOF order) whose magnitude is
    at least half the column's largest is made positive.

    "The largest entry positive" is not reproducible for symmetric structures: mirror-image DOFs
    carry entries of equal magnitude and opposite sign, and rounding (a different eigensolver
    start, thread count or platform) decides which one is the largest — flipping whole modes
    between runs. The first entry above half the maximum is immune to such ties.
    """
    V = np.asarray(V, dtype=float)
    if V.ndim != 2 or V.shape[1] == 0:
        return V
    mag = np.abs(V)
    first = np.argmax(mag >= 0.5 * mag.max(axis=0), axis=0)
    sign = np.sign(V[first, np.arange(V.shape[1])])
    return V * np.where(sign == 0, 1.0, sign)


def arpack_start(n: int) -> np.ndarray:
    """A fixed ARPACK starting vector (ARPACK's default is random: results would change in the
    last digits from run to run)."""
    return np.random.default_rng(12345).uniform(0.5, 1.5, n)
