"""Modal Assurance Criterion and the pairing of target modes with computed modes.

Formulas; the assignment problem is delegated to SciPy
(``scipy.optimize.linear_sum_assignment``, the Hungarian/Jonker–Volgenant algorithm).

MAC(a, b) = (aᵀ W b)² / ((aᵀ W a)(bᵀ W b)), W the mass matrix (mass-weighted, so that
mass-normalised modes of one model are exactly orthogonal: MAC = δ) or the identity.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..errors import InputError
from .kinds import KINDS

#: Kinds a target may ask for: a mode kind of :mod:`torchrom.fe.kinds`, "transverse" (bending
#: or torsion: out of the wing plane) or "any".
TARGET_KINDS = KINDS + ("transverse", "any")


def mac_matrix(A: np.ndarray, B: np.ndarray, W=None) -> np.ndarray:
    """MAC between the columns of A (n, p) and B (n, q): a (p, q) matrix in [0, 1]."""
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    WB = B if W is None else W @ B
    WA = A if W is None else W @ A
    cross = A.T @ WB
    na = np.einsum("ij,ij->j", A, WA)
    nb = np.einsum("ij,ij->j", B, WB)
    return cross**2 / np.maximum(np.outer(na, nb), 1e-300)


def pair_by_mac(mac: np.ndarray) -> np.ndarray:
    """For each row (reference shape) the column (computed mode) of a one-to-one pairing that
    maximises the sum of MACs."""
    rows, cols = linear_sum_assignment(-np.asarray(mac))
    out = np.empty(mac.shape[0], dtype=int)
    out[rows] = cols
    return out


def kind_matches(kind: str, wanted: str) -> bool:
    if wanted == "any":
        return True
    if wanted == "transverse":
        return kind in ("bending", "torsion")
    return kind == wanted


def pair_by_kind(kinds: list[str], wanted: list[str | None], fixed=None,
                 strict: bool = True) -> np.ndarray:
    """Pair targets with modes by kind: in target order, each takes the lowest-frequency mode
    not yet taken whose kind matches (``kinds`` in ascending frequency). ``fixed[i]``, when not
    None, is a mode index already chosen for target i (taken first). A target without a mode
    of its kind left is an error if ``strict``, else it takes the lowest free mode."""
    fixed = list(fixed) if fixed is not None else [None] * len(wanted)
    taken = {m for m in fixed if m is not None}
    out = []
    for i, want in enumerate(wanted):
        if fixed[i] is not None:
            out.append(int(fixed[i]))
            continue
        want = want or "any"
        choice = next((k for k, kind in enumerate(kinds)
                       if k not in taken and kind_matches(kind, want)), None)
        if choice is None and not strict:
            choice = next(k for k in range(len(kinds)) if k not in taken)
        if choice is None:
            have = ", ".join(f"{k + 1}:{kind}" for k, kind in enumerate(kinds))
            raise InputError(f"update: target {i + 1}: no {want} mode left among the "
                             f"{len(kinds)} computed modes ({have}); compute more modes "
                             "([modes] n) or change the target's kind")
        taken.add(choice)
        out.append(choice)
    return np.array(out, dtype=int)
