"""The model a sweep runs: a structural ROM, or a ROM with its aerodynamics (aeroelastic).

:class:`AeroelasticModel` joins a :class:`~torchrom.rom.NonlinearROM` and the
:class:`~torchrom.aero.AeroData` (GAF + RFA) computed on its first m basis functions, with what
the paper's study needs beyond the per-case matrices (Sec. IV):

- the *baseline* damping of the FE model, α0 = 0.2565 1/s and β0 = 1.338e-4 s (Eq. 46), which
  with D̄1 = K1 is the nonlinear Rayleigh model at α = α0, γ = β0 (Eq. 54 in the linear regime);
- the *reference altitude*: the flutter altitude of that baseline (state-space eigenvalues of
  Eqs. 49–50 at the GAF Mach number), unless given;
- the *matched* α(γ): for each γ, the α that keeps the flutter point at the reference altitude
  (paper Fig. 9), so that varying γ isolates the effect of the nonlinear damping.

Glue over :mod:`torchrom.aero.flutter` (eigenvalues, Brent's method).
"""

from __future__ import annotations

import hashlib
from collections.abc import Callable
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from ..aero.build import BASELINE_ALPHA, BASELINE_GAMMA
from ..aero.files import AeroData
from ..aero.flutter import (
    AeroTable,
    MatchedPointResult,
    ModalStructure,
    alpha_for_gammas,
    flutter_altitude_state_space,
    rigid_body_modes,
    state_space_matrix,
)
from ..aero.flutter_speed import FlutterSpeed, flutter_speed_at_density
from ..errors import ConvergenceError, InputError
from ..rom import NonlinearROM
from ..sim.aeroelastic import check_aero_matches_rom
from ..units import ALTITUDE_UNITS, LEGACY_SYSTEM, UnitSystem, altitude_column, file_units

#: default altitude range (ft) searched for the baseline flutter point (in a model whose
#: altitudes are in m: the same heights in m, 0 .. 12,192)
ALTITUDE_RANGE_FT = (0.0, 40000.0)


def aero_content_hash(aero: AeroData) -> str:
    """SHA-256 (hex, first 16) of the RFA and GAF arrays: identifies the aerodynamics."""
    h = hashlib.sha256()
    r = aero.rfa
    for name, arr in (("A0", r.A0), ("A1", r.A1), ("A2", r.A2), ("D", r.D), ("R", r.R),
                      ("E", r.E), ("k", aero.gaf.k), ("Q", aero.gaf.Q)):
        h.update(name.encode())
        h.update(np.ascontiguousarray(arr).tobytes())
    h.update(repr((float(aero.mach), float(aero.semichord))).encode())
    return h.hexdigest()[:16]


@dataclass
class AeroelasticModel:
    """A ROM with its aerodynamics and the study's reference damping (see the module docstring).

    Attributes:
        rom: the structural ROM (n basis functions, the first m the aerodynamic modes).
        aero: GAFs and RFA on the first m basis functions (one Mach number).
        baseline_alpha, baseline_gamma: the FE model's Rayleigh damping (1/s, s), Eq. 46.
        matched_altitude: altitude the matched α(γ) keep the flutter point at (None: the
            baseline flutter altitude, :meth:`reference_altitude`).
        altitude_range: where the baseline flutter point is searched (None:
            :data:`ALTITUDE_RANGE_FT` in the altitude unit).
        span: reference length of amplitudes in % of span (None: the ROM's metadata "span").
        units: the unit system of the ROM and the aerodynamics (None: what their files record,
            which must agree, :func:`torchrom.units.file_units`); after construction it
            carries the altitude unit too (:meth:`~torchrom.units.UnitSystem.with_altitude`).
            Speeds, densities and lengths are in the system's units.
        rigid_body_support_hz: the frequency (Hz) of the soft support the ROM's rigid-body
            coordinates were put on (:func:`with_rigid_body_support`; None: free or none).
        altitude_unit: the unit ("m" or "ft") of every altitude of the model — its cases'
            ``altitude_<unit>`` (:attr:`altitude_column`), ``matched_altitude``,
            ``altitude_range`` and the flutter altitudes it reports — (None: the unit system's,
            m for si and mm-t-s, ft for ft-slug-s and in-lbf-s). The atmosphere takes the
            altitude in it; nothing is converted.
        damping_note: where the baseline damping came from, one line (:func:`build_model`:
            the ROM file's record of its structural damping, :mod:`torchrom.rom.rayleigh`,
            when ``[aeroelastic]`` states none); None when stated.
    """

    rom: NonlinearROM
    aero: AeroData
    baseline_alpha: float = BASELINE_ALPHA
    baseline_gamma: float = BASELINE_GAMMA
    matched_altitude: float | None = None
    altitude_range: tuple[float, float] | None = None
    span: float | None = None
    units: UnitSystem | None = None
    rigid_body_support_hz: float | None = None
    altitude_unit: str | None = None
    damping_note: str | None = None
    _flutter: MatchedPointResult | None = field(default=None, init=False, repr=False)
    _alpha: dict = field(default_factory=dict, init=False, repr=False)

    def __post_init__(self):
        check_aero_matches_rom(self.rom, self.aero)
        if self.units is None:
            self.units, _ = file_units({"the ROM": self.rom.metadata,
                                        "the aero file": self.aero.metadata})
        self.units = self.units.with_altitude(self.altitude_unit, "aeroelastic model: "
                                                                  "altitude_unit")
        self.altitude_unit = self.units.altitude
        if self.altitude_range is None:
            scale = ALTITUDE_UNITS["ft"] / ALTITUDE_UNITS[self.altitude_unit]
            self.altitude_range = tuple(h * scale for h in ALTITUDE_RANGE_FT)
        if self.span is None:
            span = self.rom.metadata.get("span")
            self.span = None if span is None else float(span)

    @property
    def mach(self) -> float:
        return float(self.aero.mach)

    @property
    def altitude_column(self) -> str:
        """The case parameter and table column of the model's altitudes: ``altitude_<unit>``."""
        return altitude_column(self.altitude_unit)

    def structure(self, alpha: float = 0.0, gamma: float = 0.0) -> ModalStructure:
        """Linear structure (M, K1, D̄1) on the m aerodynamic modes with damping α, γ."""
        return ModalStructure.from_rom(self.rom, self.aero.n_modes, alpha, gamma)

    @property
    def free(self) -> bool:
        """Whether the aerodynamic modes include rigid-body (0 Hz) modes: a free aircraft."""
        f = np.nan_to_num(np.asarray(self.rom.frequencies_hz[: self.aero.n_modes], dtype=float))
        rigid = rigid_body_modes(f)
        return bool(rigid.any() and not rigid.all())

    def rigid_body_growth(self, velocity: float, density: float, alpha: float,
                          gamma: float) -> float:
        """The largest real root (1/s) of the linear state space (Eqs. 49–50) at one speed,
        density and damping: a free (or soft-supported) aircraft's rigid-body divergence where
        positive (its elastic roots are oscillatory). A periodic orbit about that state has
        the Floquet multiplier exp(root T) in that direction, to first order."""
        a = state_space_matrix(self.structure(alpha, gamma), self.aero.rfa, velocity, density)
        s = np.linalg.eigvals(a)
        real = s[np.abs(s.imag) <= 1e-9 * max(float(np.abs(s).max()), 1.0)].real
        return float(real.max()) if len(real) else float("nan")

    def baseline_flutter(self) -> MatchedPointResult:
        """Flutter point of the baseline damping (state space, Eqs. 49–50), computed once."""
        if self._flutter is None:
            st = self.structure(self.baseline_alpha, self.baseline_gamma)
            res = flutter_altitude_state_space(
                st, self.aero.rfa, self.mach, tuple(float(h) for h in self.altitude_range),
                units=self.units.name, altitude_unit=self.altitude_unit)
            if res.altitude is None:
                lo, hi = self.altitude_range
                raise ConvergenceError(f"aeroelastic model: no flutter point between {lo:g} and "
                                       f"{hi:g} {self.altitude_unit} at Mach {self.mach:g} with "
                                       f"the baseline "
                                       f"damping (α = {self.baseline_alpha:g} 1/s, γ = "
                                       f"{self.baseline_gamma:g} s)")
            self._flutter = res
        return self._flutter

    def flutter_speed(self, density: float, alpha: float | None = None,
                      gamma: float | None = None) -> FlutterSpeed:
        """Flutter point on the speed axis of a wind tunnel: the speed (the system's, e.g. ft/s)
        at which the critical root's growth rate crosses zero at air density ``density`` (the
        system's, e.g. slug/ft³), state
        space at the GAF Mach number (Eqs. 49–50; :func:`~torchrom.aero.flutter_speed.
        flutter_speed_at_density`), with damping α, γ (default the baseline)."""
        st = self.structure(self.baseline_alpha if alpha is None else alpha,
                            self.baseline_gamma if gamma is None else gamma)
        res = flutter_speed_at_density(st, self.aero.rfa, AeroTable.from_gaf(self.aero.gaf),
                                       density, mach=self.mach)
        res.units = self.units.name
        return res

    def reference_altitude(self) -> float:
        """Altitude (:attr:`altitude_unit`) the matched α(γ) keep the flutter point at."""
        if self.matched_altitude is not None:
            return float(self.matched_altitude)
        return float(self.baseline_flutter().altitude)

    def matched_alpha(self, gamma: float) -> float:
        """α (1/s) that puts the flutter point at the reference altitude for this γ (Fig. 9)."""
        return self.matched_alphas([gamma])[0]

    def matched_alphas(self, gammas) -> list[float]:
        """:meth:`matched_alpha` of many γ: those not known yet solved together
        (:func:`~torchrom.aero.flutter.alpha_for_gammas`, one stacked eigenvalue solve per
        iteration instead of a root search per γ)."""
        keys = [float(g) for g in gammas]
        missing = sorted({k for k in keys if k not in self._alpha})
        if self.matched_altitude is None and self.baseline_gamma in missing:
            # by definition of the reference
            self._alpha[float(self.baseline_gamma)] = float(self.baseline_alpha)
            missing.remove(self.baseline_gamma)
        if missing:
            found = alpha_for_gammas(self.structure(), self.aero.rfa, missing, self.mach,
                                     self.reference_altitude(), self.units.name,
                                     altitude_unit=self.altitude_unit)
            self._alpha.update(zip(missing, (float(a) for a in found)))
        return [self._alpha[k] for k in keys]

    def content_hash(self) -> str:
        """Hash of the ROM, the aerodynamics and the reference damping: the model's identity."""
        text = repr((self.rom.content_hash(), aero_content_hash(self.aero),
                     float(self.baseline_alpha), float(self.baseline_gamma),
                     self.matched_altitude, tuple(self.altitude_range)))
        if self.units.name != LEGACY_SYSTEM:  # ft-slug-s models keep their former identity
            text += self.units.name
        if self.altitude_unit != "ft":  # ... and models at altitudes in ft too
            text += f" altitude {self.altitude_unit}"
        return hashlib.sha256(text.encode()).hexdigest()[:16]


@dataclass(frozen=True)
class ModelProvider:
    """A built-in model with aerodynamics that a configuration names by ``[model] builtin =
    NAME`` (the heavy Goland wing is one). Providers are found through the package entry point
    group :data:`PROVIDER_GROUP` (``torchrom.models``), so that this layer needs no import of
    the packages that build them (and another package can add its own wing).

    Attributes:
        check: ``check(table)`` validates the ``[model]`` keys (all but ``builtin`` and
            ``cache``), InputError naming a bad one.
        build: ``build(table, cache_folder)`` -> :class:`AeroelasticModel`, the model's files
            cached in ``cache_folder``.
    """

    check: Callable[[dict[str, Any]], Any]
    build: Callable[[dict[str, Any], Path], AeroelasticModel]


#: entry point group of the model providers
PROVIDER_GROUP = "torchrom.models"


def provider_names() -> list[str]:
    """Names of the installed model providers (without importing them)."""
    return sorted({ep.name for ep in metadata.entry_points(group=PROVIDER_GROUP)})


def model_provider(name: str) -> ModelProvider:
    """The provider ``name`` (InputError naming the installed ones otherwise)."""
    for ep in metadata.entry_points(group=PROVIDER_GROUP):
        if ep.name == name:
            provider = ep.load()
            if not isinstance(provider, ModelProvider):
                raise InputError(f"model provider {name!r} ({ep.value}) is not a ModelProvider")
            return provider
    raise InputError(f"builtin model {name!r}: not installed; model providers: "
                     f"{provider_names()}")


@dataclass(frozen=True)
class ModelSpec:
    """A validated ``[model]`` table with its ``[aeroelastic]`` options: what a sweep's model
    is built from (:func:`build_model`; parsed by :func:`torchrom.study.config.parse_model`).

    Attributes:
        source: the configuration file (named by the errors of the build).
        rom, aero: the ROM file and its aerodynamics (absolute paths), or None.
        span: reference length of amplitudes in % of span (the model's length unit).
        builtin: a model of :data:`torchrom.rom.analytic.BUILTIN` or a provider's name.
        options: the builtin's keyword arguments (the provider's ``[model]`` table).
        cache: a provider's cache folder.
        aeroelastic: :class:`AeroelasticModel` keyword arguments (``[aeroelastic]``).
        units: ``[model] units``: the unit system of ROM and aero files that record none.
        rigid_body_support_hz: ``[model] rigid_body_support_hz``: a free ROM's rigid-body
            coordinates on a soft support of this frequency (:func:`with_rigid_body_support`).
    """

    source: Path
    rom: Path | None = None
    aero: Path | None = None
    span: float | None = None
    builtin: str | None = None
    options: dict[str, Any] = field(default_factory=dict)
    cache: Path | None = None
    aeroelastic: dict[str, Any] = field(default_factory=dict)
    units: str | None = None
    rigid_body_support_hz: float | None = None

    @property
    def provided(self) -> bool:
        """Whether a model provider builds it (a built-in model with aerodynamics)."""
        return self.builtin is not None and self.builtin in provider_names()

    @property
    def has_aero(self) -> bool:
        return self.aero is not None or self.provided


def _recorded_damping(rom: NonlinearROM, spec: ModelSpec) -> dict[str, Any]:
    """The baseline damping a ROM file brings (its structural damping, recorded by identify:
    :mod:`torchrom.rom.rayleigh`; none recorded: α = γ = 0), where ``[aeroelastic]`` states
    neither baseline_alpha nor baseline_gamma; as keyword arguments with its line."""
    from ..rom.rayleigh import RayleighDamping, no_damping

    stated = {"baseline_alpha", "baseline_gamma"} & spec.aeroelastic.keys()
    if stated == {"baseline_alpha", "baseline_gamma"}:
        return {}
    rec = RayleighDamping.from_metadata(rom.metadata, str(spec.rom))
    if rec is None:
        rec = no_damping(f"{spec.rom.name} records no structural damping")
    missing = sorted({"baseline_alpha", "baseline_gamma"} - stated)
    note = (f"baseline damping ([aeroelastic] {' and '.join(missing)} not given): "
            f"{spec.rom.name}'s {rec.description}")
    return {"baseline_alpha": rec.alpha, "baseline_gamma": rec.gamma, "damping_note": note}


def build_model(spec: ModelSpec):
    """The model ``spec`` describes: a NonlinearROM (a ROM file or an analytic builtin) or an
    :class:`AeroelasticModel` (a ROM with its aero file, in the unit system they record, or a
    provider's model); InputError naming the configuration file."""
    where = f"{spec.source}: [model]"
    if spec.provided:
        m = model_provider(spec.builtin).build(spec.options, spec.cache)
        own = {"baseline_alpha": m.baseline_alpha, "baseline_gamma": m.baseline_gamma,
               "altitude_unit": m.altitude_unit}
        if spec.aeroelastic.get("altitude_unit", m.altitude_unit) == m.altitude_unit:
            own["altitude_range"] = m.altitude_range  # in its own unit: kept with it
        return AeroelasticModel(m.rom, m.aero, **{**own, **spec.aeroelastic})
    if spec.rom is not None:
        rom = NonlinearROM.load(spec.rom)
        if spec.span is not None:
            rom.metadata["span"] = spec.span
        if spec.aero is None:
            return rom
        from ..aero.files import load_aero

        aero = load_aero(spec.aero)
        try:
            units, _ = file_units({spec.rom.name: rom.metadata, spec.aero.name: aero.metadata},
                                  spec.units)
            damping = _recorded_damping(rom, spec)
            if spec.rigid_body_support_hz is not None:
                rom = with_rigid_body_support(rom, spec.rigid_body_support_hz, aero.n_modes)
            return AeroelasticModel(rom, aero, units=units,
                                    rigid_body_support_hz=spec.rigid_body_support_hz,
                                    **{**damping, **spec.aeroelastic})
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None
    from ..rom.analytic import BUILTIN

    try:
        return BUILTIN[spec.builtin](**spec.options)
    except InputError as exc:
        raise InputError(f"{where} ({spec.builtin}): {exc}") from None
    except (TypeError, ValueError) as exc:
        raise InputError(f"{where} ({spec.builtin}): bad value ({exc})") from None


#: a soft support's frequency must stay below this fraction of the lowest elastic frequency
#: (the wind-tunnel rule for a free-flying model's suspension: rigid-body frequencies well below
#: the elastic ones, so that the elastic dynamics are those of the free aircraft)
SUPPORT_FRACTION = 1 / 3


def with_rigid_body_support(rom: NonlinearROM, frequency_hz: float, n_aero: int
                            ) -> NonlinearROM:
    """The ROM with its rigid-body coordinates (the 0 Hz modes among the first ``n_aero``,
    :func:`~torchrom.aero.flutter.rigid_body_modes`) on a soft support: K1 += ω_s² M on
    them, ω_s = 2π ``frequency_hz``, as a free-flying wind-tunnel model hangs on its soft
    suspension. A mass-orthonormal rigid pair (plunge, pitch about the CG) gets the same ω_s in
    any combination; the elastic coordinates, the nonlinear terms, the damping (D1) and
    ``frequencies_hz`` (the free modes the GAFs were computed on) are untouched.

    Why: a free aircraft's altitude is an exact double root s = 0 (a climb at constant speed
    is force-free), which leaves a periodic orbit's mean plunge undetermined (harmonic balance
    does not converge); a support far below the elastic frequencies fixes it and moves the
    flutter point little (bah_plane at 0.05 Hz: 393.90 -> 393.93 m/s). It takes the free climb
    away, though: the supported aircraft's pitch stability is its static margin, which a
    flexible aircraft can lose before its free (manoeuvre) stability (docs/guide/bah.md).
    InputError where the ROM has no rigid-body coordinate or the support is not below
    :data:`SUPPORT_FRACTION` of the lowest elastic frequency."""
    f = np.asarray(rom.frequencies_hz[:n_aero], dtype=float)
    rigid = rigid_body_modes(np.nan_to_num(f))
    where = "rigid_body_support_hz"
    if not rigid.any() or rigid.all():
        raise InputError(f"{where}: the ROM has no rigid-body (0 Hz) basis function to support "
                         f"(frequencies {', '.join(f'{x:.4g}' for x in f)} Hz); leave it out")
    lowest = float(f[~rigid].min())
    if not (np.isfinite(frequency_hz) and 0 < frequency_hz < SUPPORT_FRACTION * lowest):
        raise InputError(f"{where}: expected a frequency between 0 and "
                         f"{SUPPORT_FRACTION * lowest:.4g} Hz ({SUPPORT_FRACTION:.2g} of the "
                         f"lowest elastic mode, {lowest:.4g} Hz), got {frequency_hz!r}")
    idx = np.flatnonzero(rigid)
    K1 = rom.K1.numpy().copy()
    w2 = (2 * np.pi * float(frequency_hz)) ** 2
    K1[np.ix_(idx, idx)] += w2 * rom.M.numpy()[np.ix_(idx, idx)]
    # frequencies_hz stay the free basis functions' (those the GAFs were computed on)
    meta = {**rom.metadata, "rigid_body_support_hz": float(frequency_hz)}
    return rom.replace(K1=K1, metadata=meta)


def model_rom(model) -> NonlinearROM:
    """The structural ROM of a sweep model (a NonlinearROM or an AeroelasticModel)."""
    if isinstance(model, AeroelasticModel):
        return model.rom
    if isinstance(model, NonlinearROM):
        return model
    raise InputError(f"sweep model: expected a NonlinearROM or an AeroelasticModel, got "
                     f"{type(model).__name__}")


def with_named_outputs(model, outputs, points=None, where: str = "output"):
    """The model with the outputs a configuration names by a point (``"G1001:T3"``) or by a
    ``[points]`` name added to its ROM as aliases of the ROM's own rows (the model itself when
    every name is already an output or a generalized coordinate q1..qn); InputError naming an
    output the ROM does not have, with the outputs it has
    (:func:`torchrom.rom.points.resolve_output`)."""
    import dataclasses

    from ..rom.points import resolve_output

    rom = model_rom(model)
    aliases = {}
    for name in outputs or []:
        if name.startswith("q") and name[1:].isdigit() and 1 <= int(name[1:]) <= rom.n:
            continue
        found = resolve_output(rom, name, points, where)
        if found != name:
            aliases[name] = rom.outputs[found]
    if not aliases:
        return model
    named = rom.replace(outputs={**rom.outputs, **aliases})
    if isinstance(model, AeroelasticModel):
        return dataclasses.replace(model, rom=named)
    return named


def alpha_gamma_table(model: AeroelasticModel, gammas):
    """Paper Fig. 9: the matched α for each γ (s), with the reference altitude (column
    ``reference_altitude_<unit>``, the model's altitude unit: ft for the Goland wing), the
    baseline damping and the flutter frequency (Hz) of each pair at the reference altitude."""
    import pandas as pd

    from ..aero.atmosphere import flight_condition
    from ..aero.flutter import critical_root

    h = model.reference_altitude()
    fc = flight_condition(model.mach, h, model.units.name, model.altitude_unit)
    rows = []
    for g in sorted({float(g) for g in gammas}):
        a = model.matched_alpha(g)
        root = critical_root(model.structure(a, g), model.aero.rfa, fc.velocity, fc.density)
        rows.append({"gamma": g, "alpha": a, f"reference_{model.altitude_column}": h,
                     "mach": model.mach,
                     "flutter_frequency_hz": root.imag / (2 * np.pi),
                     "growth_rate_at_reference": root.real,
                     "baseline_alpha": model.baseline_alpha,
                     "baseline_gamma": model.baseline_gamma})
    return pd.DataFrame(rows)
