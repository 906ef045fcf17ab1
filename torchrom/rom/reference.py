"""The deformed state a ROM is expanded about (``torchrom identify --about-*``).

A ROM identified about a reference state has the coordinates x = q − q_ref, q the deck's modal
coordinates: its K1 is the condensed tangent stiffness there, and its K2, K3 give the change of
the structural force, f(q_ref + x) = f_ref + K1 x + K2(x,x) + K3(x,x,x). Whatever loads the
structure adds the constant part of its equilibrium: a steady aerodynamic load −q∞ Q(0) q on the
deck's coordinates becomes −q∞ Q(0) x on the ROM's plus the constant −q∞ Q(0) q_ref − f_ref, and
a physical output C q becomes C x + C q_ref (:func:`output_offsets`).

Without a reference (every other ROM) q_ref = 0 and f_ref = 0: the same formulas hold.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError


@dataclass(frozen=True)
class ReferenceState:
    """``q`` (n,) the reference state's modal coordinates, ``force`` (n,) the structural force
    there (the files' force unit per modal coordinate), ``condition`` the load case that holds it
    (JSON: e.g. ``{"aoa_deg": 5.0, "velocity": 45.0, "density": 1.225}``)."""

    q: np.ndarray
    force: np.ndarray
    condition: dict = field(default_factory=dict)

    def __post_init__(self):
        q = np.asarray(self.q, dtype=float).reshape(-1)
        f = np.asarray(self.force, dtype=float).reshape(-1)
        if q.shape != f.shape:
            raise InputError(f"reference state: q has {q.size} entries, force {f.size}")
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(f))):
            raise InputError("reference state: q and force must be finite")
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "force", f)
        object.__setattr__(self, "condition", dict(self.condition))


def reference_of(rom) -> ReferenceState | None:
    return getattr(rom, "reference", None)


def reference_q(rom) -> np.ndarray:
    """q_ref (n,): zero for a ROM about its undeformed state."""
    ref = reference_of(rom)
    return np.zeros(rom.n) if ref is None else ref.q


def structural_force(rom, x) -> np.ndarray:
    """The whole structural force at the ROM's coordinates ``x`` (n,): f_ref + the ROM's
    stiffness force (its change from the reference), in the deck's modal coordinates."""
    import torch

    f = rom.stiffness_force(torch.as_tensor(np.asarray(x, dtype=float))).numpy()
    ref = reference_of(rom)
    return f if ref is None else f + ref.force


def output_offsets(rom, rows: np.ndarray) -> np.ndarray:
    """C q_ref of output rows ``rows`` (k, n): what each output reads at x = 0."""
    return np.asarray(rows, dtype=float) @ reference_q(rom)


def reference_load(rom, steady_stiffness: np.ndarray, dynamic_pressure) -> np.ndarray | None:
    """(B, n) the constant generalized force that the reference adds to a case at
    ``dynamic_pressure`` (B,) with the steady aerodynamic stiffness Q(0) (n, n) per unit dynamic
    pressure (sign F = −q∞ Q q): −q∞ Q(0) q_ref − f_ref. None without a reference."""
    ref = reference_of(rom)
    if ref is None:
        return None
    q = np.asarray(dynamic_pressure, dtype=float).reshape(-1)
    return -(q[:, None] * (np.asarray(steady_stiffness) @ ref.q)[None]) - ref.force[None]


def to_arrays(ref: ReferenceState | None) -> dict:
    """The arrays that ``rom.npz`` keeps of a reference (none without one)."""
    if ref is None:
        return {}
    import json

    return {"reference_q": ref.q, "reference_force": ref.force,
            "reference_condition_json": np.array(json.dumps(ref.condition))}


def from_arrays(data: dict, where: str) -> ReferenceState | None:
    """The reference kept in ``rom.npz``'s arrays ``data``, or None (older files, other ROMs)."""
    if "reference_q" not in data:
        return None
    import json

    try:
        condition = json.loads(str(data.get("reference_condition_json", "{}")))
        return ReferenceState(data["reference_q"], data["reference_force"], condition)
    except (KeyError, json.JSONDecodeError, InputError) as exc:
        raise InputError(f"{where}: a broken reference state ({exc})") from None
