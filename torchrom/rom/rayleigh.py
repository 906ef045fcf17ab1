"""Rayleigh structural damping of a ROM (mass- and stiffness-proportional), as users state it.

The ROM's damping force is f_d = α M q̇ + γ (D̄1 + D̄2(q) + D̄3(q, q)) q̇ (DESIGN, Eq. 54), with
D̄1 = K1 for a Kelvin–Voigt material: on a mass-normalised mode of circular frequency
ω = 2π f its damping ratio (fraction of critical) is

    ζ(ω) = α / (2 ω) + γ ω / 2           α in 1/time, γ in time, f in cycles per time

(the model's time unit: s for every unit system torchrom reads). This module maps what a user
states onto α and γ, and records the result in a ROM's metadata (:data:`METADATA_KEY`):

- ``--damping-ratio ZETA``: ζ at every elastic mode of the ROM. α, γ ≥ 0 minimise
  Σ_i ((ζ(ω_i) − ζ_i) / ζ_i)² (scipy's NNLS; each mode's error relative to its ratio, a zero
  ratio weighted as 1 % of the largest). With one elastic frequency: α = ζ ω, γ = ζ / ω, the
  Rayleigh curve whose minimum, ζ, lies at ω.
- ``--damping-ratio Z1@F1 Z2@F2``: the two equations ζ(2π F_k) = Z_k solved exactly,
  α = 2 ω1 ω2 (Z1 ω2 − Z2 ω1) / (ω2² − ω1²), γ = 2 (Z2 ω2 − Z1 ω1) / (ω2² − ω1²); refused where
  α or γ would be negative (a ratio that no Rayleigh curve passes through).
- per-mode ratios from a deck's cards (:mod:`torchrom.fe.damping_cards`): the same fit; the
  stiffness-proportional cards alone (PARAM G/W3, GE/W4) fit γ only, α = 0.

A free structure's fits keep α = 0: α M also damps its rigid-body modes, which structural
damping does not (the two-frequency form is the user's own curve and kept as given).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: the ROM metadata key of the structural damping that ``identify`` states
METADATA_KEY = "structural_damping"
#: a zero target ratio counts in the relative fit as this fraction of the largest
ZERO_RATIO_WEIGHT = 1e-2
#: damping ratios at or above this are refused (critical damping: no oscillation left)
MAX_RATIO = 1.0


def rayleigh_zeta(alpha: float, gamma: float, frequencies_hz) -> np.ndarray:
    """ζ(ω) = α/(2ω) + γω/2 at ``frequencies_hz`` (ω = 2π f; infinite at f = 0 with α > 0)."""
    w = 2 * np.pi * np.asarray(frequencies_hz, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(w > 0, alpha / (2 * w) + gamma * w / 2, np.inf if alpha > 0 else 0.0)


@dataclass(frozen=True)
class RayleighDamping:
    """α (1/time), γ (time) and what they came from.

    Attributes:
        source: "deck" (damping cards), "damping-ratio" (--damping-ratio), "goland" (the
            paper's Eq. 46 values for the heavy Goland wing), "none" (nothing stated),
            "options" (--alpha/--gamma), or "rom" (a ROM file's record).
        description: one line saying what was used (printed, and kept in the metadata).
        frequencies_hz, zeta_target: the modes and ratios α, γ were fitted to (empty when
            stated directly).
    """

    alpha: float
    gamma: float
    source: str
    description: str
    frequencies_hz: tuple[float, ...] = ()
    zeta_target: tuple[float, ...] = ()

    def zeta(self, frequencies_hz) -> np.ndarray:
        return rayleigh_zeta(self.alpha, self.gamma, frequencies_hz)

    def as_metadata(self) -> dict:
        """The ROM metadata record (JSON-ready), with the fitted ratios beside the targets."""
        return {"alpha": float(self.alpha), "gamma": float(self.gamma), "source": self.source,
                "description": self.description,
                "frequencies_hz": [float(f) for f in self.frequencies_hz],
                "zeta_target": [float(z) for z in self.zeta_target],
                "zeta_fit": [float(z) for z in self.zeta(self.frequencies_hz)]}

    @classmethod
    def from_metadata(cls, metadata, where: str = "rom.npz") -> RayleighDamping | None:
        """The record of a ROM's ``metadata`` (None where it has none: a ROM written before
        the record existed, or not by ``identify``); InputError for a damaged one."""
        rec = (metadata or {}).get(METADATA_KEY)
        if rec is None:
            return None
        try:
            alpha, gamma = float(rec["alpha"]), float(rec["gamma"])
        except (KeyError, TypeError, ValueError):
            raise InputError(f"{where}: metadata {METADATA_KEY}: expected numbers alpha and "
                             f"gamma, got {rec!r}") from None
        if not (np.isfinite(alpha) and np.isfinite(gamma) and alpha >= 0 and gamma >= 0):
            raise InputError(f"{where}: metadata {METADATA_KEY}: expected finite alpha, gamma "
                             f">= 0, got {alpha!r}, {gamma!r}")
        return cls(alpha, gamma, str(rec.get("source", "rom")),
                   str(rec.get("description", "")),
                   tuple(float(f) for f in rec.get("frequencies_hz", [])),
                   tuple(float(z) for z in rec.get("zeta_target", [])))


def no_damping(why: str) -> RayleighDamping:
    """α = γ = 0, saying why (``why``: e.g. "no damping cards in the deck")."""
    return RayleighDamping(0.0, 0.0, "none", f"structural damping: none ({why}): α = γ = 0; "
                           "state one with --damping-ratio ZETA (or Z1@F1 Z2@F2)")


def goland_damping() -> RayleighDamping:
    """The heavy Goland wing's Rayleigh damping of the paper (Eq. 46; data/paper_reference)."""
    from ..reference import paper_reference

    ref = paper_reference()
    return RayleighDamping(ref.alpha0_per_s, ref.beta0_s, "goland",
                           f"structural damping: the heavy Goland wing's Rayleigh damping of "
                           f"the paper (Eq. 46): α = {ref.alpha0_per_s:g} 1/s, "
                           f"γ = {ref.beta0_s:g} s")


def _weights(zeta: np.ndarray) -> np.ndarray:
    floor = ZERO_RATIO_WEIGHT * float(zeta.max())
    return 1.0 / np.maximum(zeta, floor)


def fit_rayleigh(frequencies_hz, zeta, *, mass_proportional: bool = True
                 ) -> tuple[float, float]:
    """(α, γ) ≥ 0 fitting ratios ``zeta`` at ``frequencies_hz`` (> 0) in the relative least
    squares of the module docstring; ``mass_proportional=False`` fits γ alone (α = 0)."""
    f = np.asarray(frequencies_hz, dtype=float)
    z = np.asarray(zeta, dtype=float)
    if f.size == 0 or f.shape != z.shape:
        raise InputError(f"damping fit: expected ratios at one or more frequencies, got "
                         f"{z.size} ratios at {f.size} frequencies")
    if np.any(~np.isfinite(f)) or np.any(f <= 0) or np.any(~np.isfinite(z)) or np.any(z < 0):
        raise InputError(f"damping fit: expected ratios >= 0 at frequencies > 0, got "
                         f"{z.tolist()} at {f.tolist()} Hz")
    if z.max() == 0:
        return 0.0, 0.0
    w = 2 * np.pi * f
    wt = _weights(z)
    if not mass_proportional:
        a = wt * w / 2  # rows of the one-column system, weighted
        return 0.0, float(a @ (wt * z) / (a @ a))
    if w.max() <= w.min() * (1 + 1e-9):  # one frequency: the curve whose minimum is there
        zm, w0 = float(np.mean(z)), float(w[0])
        return zm * w0, zm / w0
    from scipy.optimize import nnls

    A = np.column_stack([wt / (2 * w), wt * w / 2])
    scale = np.linalg.norm(A, axis=0)  # unit columns: α and γ differ by ω² in size
    x, _ = nnls(A / scale, wt * z)
    alpha, gamma = x / scale
    return float(alpha), float(gamma)


def two_point(z1: float, f1: float, z2: float, f2: float) -> tuple[float, float]:
    """(α, γ) with ζ = z1 at f1 and z2 at f2 (Hz) exactly; InputError where one is < 0."""
    w1, w2 = 2 * np.pi * f1, 2 * np.pi * f2
    den = w2**2 - w1**2
    alpha = 2 * w1 * w2 * (z1 * w2 - z2 * w1) / den
    gamma = 2 * (z2 * w2 - z1 * w1) / den
    tol = 1e-12 * max(z1, z2, 1e-300)  # rounding of a curve that is exactly 1/f or f
    if alpha < -tol * w1 or gamma < -tol / w2:
        need = "γ < 0: a ratio falling faster than 1/f" if gamma < 0 else \
            "α < 0: a ratio rising faster than f"
        raise InputError(f"--damping-ratio {z1:g}@{f1:g} {z2:g}@{f2:g}: no Rayleigh curve "
                         f"ζ = α/(2ω) + γω/2 passes through both ({need}); give ratios "
                         f"that fall no faster than 1/f and rise no faster than f")
    return max(float(alpha), 0.0), max(float(gamma), 0.0)


@dataclass(frozen=True)
class DampingRatio:
    """What ``--damping-ratio`` states: ``points`` = ((ζ, None),) for every mode, or
    ((ζ1, f1), (ζ2, f2)) at two frequencies (Hz)."""

    points: tuple[tuple[float, float | None], ...]

    @property
    def text(self) -> str:
        return " ".join(f"{z:g}" if f is None else f"{z:g}@{f:g}" for z, f in self.points)

    def rayleigh(self, frequencies_hz, free: bool = False) -> RayleighDamping:
        """α, γ of the ratio on a model whose elastic modes are at ``frequencies_hz``;
        ``free``: the model has rigid-body modes (module docstring)."""
        f = np.asarray(frequencies_hz, dtype=float)
        if len(self.points) == 2:
            (z1, f1), (z2, f2) = self.points
            alpha, gamma = two_point(z1, f1, z2, f2)
            how = f"ζ = {z1:g} at {f1:g} Hz and {z2:g} at {f2:g} Hz"
            if free and alpha > 0:
                how += " (α damps the rigid-body modes too)"
            return _stated(alpha, gamma, "damping-ratio", f"--damping-ratio {self.text}",
                           how, f, None)
        if f.size == 0:
            raise InputError(f"--damping-ratio {self.text}: the model has no elastic mode to "
                             "state a ratio at (give --alpha/--gamma)")
        return fit_modal_ratios(f"--damping-ratio {self.text}", f,
                                np.full(f.shape, self.points[0][0]), free=free,
                                source="damping-ratio")


def _fit_words(f: np.ndarray, alpha_zero: str | None = None) -> str:
    """How α, γ were fitted: at which modes, and why α = 0 where it is kept so."""
    n = f"{f.size} elastic mode{'s' if f.size > 1 else ''}"
    span = f"{f.min():.4g} Hz" if f.size == 1 else f"{f.min():.4g}..{f.max():.4g} Hz"
    if alpha_zero is None:
        return f"α, γ fitted at the {n} ({span})"
    return f"γ fitted at the {n} ({span}), α = 0 ({alpha_zero})"


#: why a fit keeps α = 0
FREE_ALPHA_ZERO = "a free structure: its rigid-body modes stay undamped"
STIFFNESS_ALPHA_ZERO = "stiffness-proportional cards"


def fit_quality(alpha: float, gamma: float, f: np.ndarray, zeta: np.ndarray) -> float:
    """Largest |ζ(ω_i)/ζ_i − 1| over the modes with ζ_i > 0 (0 where there are none)."""
    z = np.asarray(zeta, dtype=float)
    sel = z > 0
    if not sel.any():
        return 0.0
    return float(np.max(np.abs(rayleigh_zeta(alpha, gamma, np.asarray(f)[sel]) / z[sel] - 1)))


def _stated(alpha, gamma, source, what, how, f, zeta) -> RayleighDamping:
    """The record and its line: "structural damping: WHAT; HOW: α = .., γ = .. (ζ .. at the
    modes, fitted within x %)"."""
    tail = ""
    if zeta is not None and len(zeta):
        q = fit_quality(alpha, gamma, f, zeta)
        fit = "exactly" if q < 1e-8 else f"within {100 * q:.2g} %"
        lo, hi = float(np.min(zeta)), float(np.max(zeta))
        z = f"ζ = {lo:.4g}" if hi - lo <= 1e-12 * hi else f"ζ {lo:.4g}..{hi:.4g}"
        tail = f" ({z} at the modes, fitted {fit})"
    return RayleighDamping(
        float(alpha), float(gamma), source,
        f"structural damping: {what}; {how}: α = {alpha:.6g} 1/s, γ = {gamma:.6g} s{tail}",
        tuple(float(x) for x in f), () if zeta is None else tuple(float(z) for z in zeta))


def fit_modal_ratios(what: str, frequencies_hz, zeta, *, free: bool,
                     mass_proportional: bool = True, source: str = "deck") -> RayleighDamping:
    """α, γ fitted to per-mode ratios ``zeta`` at the elastic ``frequencies_hz`` (γ alone for
    a free structure or ``mass_proportional=False``), with the line naming ``what``."""
    f = np.asarray(frequencies_hz, dtype=float)
    z = np.asarray(zeta, dtype=float)
    alpha_zero = (STIFFNESS_ALPHA_ZERO if not mass_proportional
                  else FREE_ALPHA_ZERO if free else None)
    alpha, gamma = fit_rayleigh(f, z, mass_proportional=alpha_zero is None)
    return _stated(alpha, gamma, source, what, _fit_words(f, alpha_zero), f, z)


def parse_ratio_token(value: str) -> tuple[float, float | None]:
    """``ZETA`` or ``ZETA@FREQ_HZ`` → (ζ, f or None); ValueError with what was expected."""
    text = str(value).strip()
    head, at, tail = text.partition("@")
    try:
        z = float(head)
        f = float(tail) if at else None
    except ValueError:
        raise ValueError(f"expected ZETA or ZETA@FREQ_HZ (e.g. 0.02 or 0.02@5.0), got "
                         f"{value!r}") from None
    if not np.isfinite(z) or not 0 <= z < MAX_RATIO:
        raise ValueError(f"expected a damping ratio 0 <= ZETA < {MAX_RATIO:g} (fraction of "
                         f"critical, e.g. 0.02 for 2 %), got {head!r}")
    if at and (f is None or not np.isfinite(f) or f <= 0):
        raise ValueError(f"expected a frequency > 0 (Hz) after @, got {tail!r}")
    return z, f


def damping_ratio(tokens) -> DampingRatio:
    """The ``--damping-ratio`` values (each parsed by :func:`parse_ratio_token`): one ratio
    for every mode, or two at distinct frequencies; InputError naming the option otherwise."""
    points = []
    for t in tokens:
        try:
            points.append(t if isinstance(t, tuple) else parse_ratio_token(t))
        except ValueError as exc:
            raise InputError(f"--damping-ratio: {exc}") from None
    given = " ".join(f"{z:g}" if f is None else f"{z:g}@{f:g}" for z, f in points)
    with_f = [f is not None for _, f in points]
    if len(points) == 1 and not with_f[0]:
        return DampingRatio(tuple(points))
    if len(points) == 2 and all(with_f):
        if points[0][1] == points[1][1]:
            raise InputError(f"--damping-ratio {given}: the two frequencies must differ")
        (z1, f1), (z2, f2) = sorted(points, key=lambda p: p[1])
        two_point(z1, f1, z2, f2)  # a pair no Rayleigh curve passes through: refused now
        return DampingRatio(((z1, f1), (z2, f2)))
    raise InputError(f"--damping-ratio {given}: expected ZETA (every mode) or ZETA1@F1 "
                     "ZETA2@F2 (two frequencies in Hz)")


def elastic_frequencies(frequencies_hz, kinds=None, n_rigid: int = 0) -> np.ndarray:
    """The elastic linear modes' frequencies (Hz): basis functions of kind "linear" (all
    when ``kinds`` is None) with a finite frequency, past the first ``n_rigid`` (a free
    structure's rigid-body modes) and above 0."""
    f = np.asarray(frequencies_hz, dtype=float)
    keep = np.isfinite(f) & (f > 0)
    if kinds is not None:
        keep &= np.array([k == "linear" for k in kinds], dtype=bool)[: f.size]
    keep[: int(n_rigid)] = False
    return f[keep]


def rom_modes(rom) -> tuple[np.ndarray, bool]:
    """(elastic frequencies in Hz, free) of a :class:`~torchrom.rom.NonlinearROM`: its basis
    metadata's rigid-body count where it records one, else its modes at 0 Hz."""
    f = np.asarray(rom.frequencies_hz, dtype=float)
    basis = (rom.metadata or {}).get("basis", {}) or {}
    n_rigid = int(basis.get("n_rigid", 0) or 0)
    if not n_rigid:
        linear = np.array([k == "linear" for k in rom.mode_kinds], dtype=bool)[: f.size]
        n_rigid = int(np.sum(linear & np.isfinite(f) & (f <= 0)))
    return elastic_frequencies(f, rom.mode_kinds, n_rigid), n_rigid > 0
