"""Modal structural damping of a flutter subcase: case control SDAMP → TABDMP1 (Nastran).

Hand-written from the card definitions (MSC QRG TABDMP1, PARAM KDAMP, SDAMPING):

- TABDMP1 gives g(f) (TYPE G, the default), ζ(f) (CRIT) or Q(f) (Q) at natural frequencies f
  (cycles per unit time): linear between the points, linear extrapolation from the two first or
  two last points outside them, the mean of both sides at a discontinuity (a repeated f).
- PARAM KDAMP = +1 (the default) puts it in the viscous modal damping matrix, B_ii = 2 ζ_i ω_i
  M_ii with ζ = g/2 (G), ζ (CRIT) or 1/(2Q) (Q); a rigid-body mode (ω = 0) gets none. KDAMP = -1
  (complex stiffness) is refused, and so is SDAMP with the K and KE methods (their damping
  is not the PK equation's B), rather than dropped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

KINDS = ("G", "CRIT", "Q")


@dataclass(frozen=True)
class ModalDamping:
    """A TABDMP1 table selected by SDAMP: ``kind`` G, CRIT or Q at frequencies ``f`` (Hz)."""

    tid: int
    kind: str
    f: np.ndarray
    value: np.ndarray

    def at(self, freqs_hz) -> np.ndarray:
        """The table's value at ``freqs_hz`` (see the module docstring)."""
        x = np.asarray(freqs_hz, dtype=float)
        f, v = self.f, self.value
        if len(f) == 1:
            return np.full_like(x, v[0])
        out = np.interp(x, f, v)
        # np.interp takes the right-hand value at a repeated f: Nastran the mean of both sides
        for i in np.flatnonzero(np.diff(f) == 0):
            out = np.where(x == f[i], 0.5 * (v[i] + v[i + 1]), out)
        lo, hi = x < f[0], x > f[-1]
        slope0 = (v[1] - v[0]) / (f[1] - f[0])
        slope1 = (v[-1] - v[-2]) / (f[-1] - f[-2])
        out = np.where(lo, v[0] + slope0 * (x - f[0]), out)
        return np.where(hi, v[-1] + slope1 * (x - f[-1]), out)

    def zeta(self, freqs_hz) -> np.ndarray:
        """Fraction of critical damping of modes at ``freqs_hz``."""
        v = self.at(freqs_hz)
        if self.kind == "G":
            return 0.5 * v
        if self.kind == "CRIT":
            return v
        with np.errstate(divide="ignore"):
            return np.where(v != 0.0, 0.5 / v, 0.0)

    def viscous(self, freqs_hz) -> np.ndarray:
        """Diagonal of the modal damping matrix B = 2 ζ ω (mass-normalised modes)."""
        w = 2 * np.pi * np.asarray(freqs_hz, dtype=float)
        return 2.0 * self.zeta(freqs_hz) * w

    def describe(self) -> str:
        return (f"SDAMP = {self.tid}: TABDMP1 {self.tid} ({self.kind}) as viscous modal "
                "damping, B_ii = 2 ζ_i ω_i (PARAM KDAMP = +1)")


def sdamp_of(sub) -> int | None:
    """The subcase's SDAMP (pyNastran stores it as SDAMPING), or None."""
    if sub is None:
        return None
    for key in ("SDAMPING", "SDAMP"):
        if sub.has_parameter(key)[0]:
            return int(sub.get_parameter(key)[0])
    return None


def subcase_sdamp(model) -> dict[int, int]:
    """FMETHOD → SDAMP of each subcase that has both (a global SDAMP applies to all)."""
    cc = model.case_control_deck
    out: dict[int, int] = {}
    if cc is None:
        return out
    default = sdamp_of(cc.subcases.get(0))
    for sub in cc.subcases.values():
        if not sub.has_parameter("FMETHOD")[0]:
            continue
        sdamp = sdamp_of(sub)
        sdamp = default if sdamp is None else sdamp
        if sdamp is not None:
            out[int(sub.get_parameter("FMETHOD")[0])] = sdamp
    return out


def modal_damping(model, where: str, tid: int, method: str) -> ModalDamping:
    """The TABDMP1 ``tid`` selected for a FLUTTER card of ``method``, checked."""
    if method not in ("PK", "PKNL"):
        raise InputError(f"{where}: case control SDAMP = {tid}: modal damping is supported with "
                         f"the PK and PKNL methods only, got {method}")
    kdamp = model.params.get("KDAMP")
    if kdamp is not None and kdamp.values and int(kdamp.values[0]) < 0:
        raise InputError(f"{where}: PARAM KDAMP = {kdamp.values[0]}: modal damping as complex "
                         "stiffness is not supported (expected KDAMP = +1, viscous)")
    return read_tabdmp1(model, where, tid)


def read_tabdmp1(model, where: str, tid: int) -> ModalDamping:
    """The TABDMP1 ``tid`` that case control SDAMP selects, its fields checked (InputError
    naming ``where``, the table and the field)."""
    table = getattr(model, "tables_sdamping", {}).get(tid)
    if table is None or table.type != "TABDMP1":
        raise InputError(f"{where}: case control SDAMP = {tid}: TABDMP1 {tid} not found")
    kind = str(table.Type or "G").upper()
    f = np.asarray(table.x, dtype=float)
    v = np.asarray(table.y, dtype=float)
    if kind not in KINDS:
        raise InputError(f"TABDMP1 {tid}: field TYPE: expected one of {', '.join(KINDS)}, "
                         f"got {kind}")
    if len(f) < 1 or not np.all(np.isfinite(f)) or not np.all(np.isfinite(v)):
        raise InputError(f"TABDMP1 {tid}: expected finite (f, g) pairs, got {list(f)}, {list(v)}")
    if len(f) > 1 and np.any(np.diff(f) < 0):
        if np.all(np.diff(f) <= 0):
            f, v = f[::-1], v[::-1]
        else:
            raise InputError(f"TABDMP1 {tid}: frequencies must be ascending or descending, got "
                             f"{list(f)}")
    if len(f) > 1 and (f[1] == f[0] or f[-1] == f[-2]):
        raise InputError(f"TABDMP1 {tid}: a discontinuity at the first or last frequency leaves "
                         "the extrapolation undefined")
    return ModalDamping(int(tid), kind, f, v)
