"""Sweep configurations in TOML or in a dict of the same tables (validation written here;
parsing by tomllib / tomli): :func:`load_sweep_config` reads a file into a dict and validates it
with :func:`config_from_dict`, the one entry point a notebook calls too.

Tables ``[model]``, ``[aeroelastic]``, ``[initial]``, ``[integrator]``, ``[hb]``, ``[lco]``,
``[certificate]``, ``[cases]``, ``[history]``, ``[branch]``, ``[plot]``, ``[run]``,
``[variants.NAME]``, ``[points]`` (output names of one's own for points of the deck,
``tip_le = "G1001:T3"``, that ``[lco] outputs`` may use, as it may ``"G1001:T3"`` itself:
:mod:`torchrom.rom.points`) and the keys ``title`` and ``method`` ("newmark", "hb" or
"shooting": the solvers of :mod:`.solvers`); the keys each
table accepts are :data:`TABLE_KEYS` (the user guide's table is generated from them).
Everything is checked when the file is read, before any output is written — keys, values
(:data:`VALUE_CHECKS`, the Newmark and LCO options' own checks, physical ranges, the work and
memory bounds of :mod:`torchrom.bounds`, dt ≤ t_end, at most
:data:`torchrom.sim.newmark.MAX_STEPS` steps), the initial state and outputs against the model
— and a bad one is a one-line :class:`~torchrom.errors.InputError` naming the file, the table
and the key. Paths are relative to the configuration file; units: dt, t_end and γ in s, α in
1/s; a wind tunnel's speed and density, and lengths, in the model's unit system (that its ROM
and aero files record, or ``[model] units`` for files that record none:
:mod:`torchrom.units`). Altitudes: one unit per run (:func:`run_altitude_unit`), named by the
keys that hold them (``altitude_ft`` or ``altitude_m`` in ``[cases]``,
``reference_altitude_<unit>`` and ``altitude_range_<unit>`` in ``[aeroelastic]``) or by
``[aeroelastic] altitude_unit``, else the unit system's (m for si, ft for ft-slug-s).

This module parses and validates only: ``[model]`` and ``[aeroelastic]`` become a
:class:`~torchrom.study.models.ModelSpec` (:func:`parse_model`), which
:func:`torchrom.study.models.build_model` alone turns into the model.
"""

from __future__ import annotations

import dataclasses
import datetime
import inspect
import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..checks import expect_file_kind, physical
from ..errors import InputError
from ..io import read_toml
from ..periodic import HarmonicBalanceMethod, HBOptions
from ..periodic.certify import Certificate
from ..rom import NonlinearROM
from ..rom.analytic import BUILTIN
from ..rom.points import check_point_table
from ..sim import LCOCriteria, Newmark
from ..units import (
    ALTITUDE_COLUMNS,
    ALTITUDE_UNITS,
    SYSTEMS,
    altitude_unit,
    is_air_density,
    unit_system,
)
from .cases import (
    STRUCTURAL_PARAMETERS,  # noqa: F401 - re-exported (public name of this module)
    HistorySpec,
    case_parameters,
    check_case_values,
)
from .grid import config_hash, expand_cases
from .models import (
    AeroelasticModel,
    ModelSpec,
    build_model,
    model_provider,
    model_rom,
    provider_names,
    with_named_outputs,
)
from .solvers import DEFAULT_METHOD, SOLVERS, Solver, make_solver
from .starts import check_start

SECTIONS = ("title", "method", "model", "aeroelastic", "initial", "integrator", "hb", "lco",
            "certificate", "cases", "history", "plot", "run", "branch", "variants", "points")
_HB_OPTION_KEYS = ("start_harmonics", "harmonics", "max_harmonics", "amplitude_rtol",
                   "residual_tol", "start_amplitude", "amplitude_scale", "max_stages",
                   "metric_points")
_HB_METHOD_KEYS = ("stability", "floquet_steps", "start", "sensitivity", "seed")
#: [aeroelastic] keys (AeroelasticModel fields; the altitudes in the unit their name says)
AEROELASTIC_KEYS = ("baseline_alpha", "baseline_gamma", "altitude_unit",
                    "reference_altitude_ft", "reference_altitude_m", "altitude_range_ft",
                    "altitude_range_m")
_NEWMARK_KEYS = ("scheme", "rho_inf", "solver", "iterations", "startup_iterations", "tol",
                 "predictor", "check_every", "refresh_every", "sample_every", "compile", "threads",
                 "cuda_graphs", "adaptive", "step_tol", "dt_min", "dt_max", "extrapolate")
_LCO_KEYS = ("rtol", "cycles", "decay_ratio", "max_amplitude", "ring")
#: the keys each table accepts (add a new key here, and its value check to VALUE_CHECKS)
TABLE_KEYS = {
    "initial": ("q0", "v0", "mode", "start", "along", "static_manifold"),
    "integrator": ("dt", "t_end", *_NEWMARK_KEYS),
    "lco": ("outputs", *_LCO_KEYS),
    "plot": ("x", "y", "hue"),
    "run": ("batch_size", "chunk_size", "allow_large"),
}


def _finite_numbers(value) -> bool:
    """A finite number or a non-empty list of finite numbers (not bools)."""
    items = value if isinstance(value, list) and value else [value]
    return all(not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
               for v in items)


def _positive_integer(value) -> bool:
    return not isinstance(value, bool) and isinstance(value, int) and value >= 1


#: (table, key) -> (check, what is expected): the value checks done when the file is read,
#: before anything is built or written (the Newmark and LCO options check themselves)
VALUE_CHECKS = {
    ("initial", "q0"): (_finite_numbers, "a finite number or a list of finite numbers"),
    ("initial", "v0"): (_finite_numbers, "a finite number or a list of finite numbers"),
    ("initial", "mode"): (_positive_integer, "a basis function number >= 1"),
    ("run", "batch_size"): (_positive_integer, "a positive integer"),
    ("run", "chunk_size"): (_positive_integer, "a positive integer"),
    ("run", "allow_large"): (lambda v: isinstance(v, bool), "true or false"),
}


def _checked_table(raw: dict, name: str, source: Path) -> dict:
    """Table ``name`` with its keys (:data:`TABLE_KEYS`) and values (:data:`VALUE_CHECKS`)
    checked."""
    table = _table(raw, name, source)
    _check_keys(table, TABLE_KEYS[name], source, f"[{name}]")
    for key, value in table.items():
        check = VALUE_CHECKS.get((name, key))
        if check is not None and not check[0](value):
            raise _err(source, f"[{name}] {key}", f"expected {check[1]}, got {value!r}")
    return table


@dataclass
class PlotSpec:
    x: str
    y: str = "amplitude"
    hue: str | None = None


@dataclass
class SweepConfig:
    """A validated sweep configuration (see the module docstring)."""

    source: Path
    title: str
    model: dict[str, Any]
    initial: dict[str, Any]
    integrator: Newmark
    t_end: float
    lco: LCOCriteria
    outputs: list[str] | None
    cases: list[dict[str, Any]]
    plot: PlotSpec
    batch_size: int = 512
    chunk_size: int | None = None
    raw: dict[str, Any] = field(default_factory=dict, repr=False)
    aeroelastic: dict[str, Any] | None = None
    history: HistorySpec | None = None
    method: str = DEFAULT_METHOD
    hb: HarmonicBalanceMethod = field(default_factory=HarmonicBalanceMethod)
    certificate: Certificate = field(default_factory=Certificate)
    allow_large: bool = False
    #: [points]: output names of the configuration's own -> "G1001:T3"
    points: dict[str, str] = field(default_factory=dict)
    #: [model] and [aeroelastic], validated: what the model is built from
    model_spec: ModelSpec | None = None

    @property
    def solver(self) -> Solver:
        """What runs the cases (:mod:`.solvers`): the solver named by ``method``, built from the
        integrator and the ``[hb]`` method."""
        return make_solver(self.method, self.integrator, self.hb)

    @property
    def hash(self) -> str:
        """Hash of everything but the case grid (cases carry their own ``case_id``)."""
        return config_hash({k: v for k, v in self.raw.items() if k not in ("cases", "plot")})

    def build_model(self):
        """The sweep's model: a NonlinearROM, or an AeroelasticModel when it has aerodynamics
        (:func:`torchrom.study.models.build_model` of :attr:`model_spec`)."""
        model = build_model(self.model_spec)
        try:
            return with_named_outputs(model, self.outputs, self.points)
        except InputError as exc:
            raise _err(self.source, "[lco] outputs", str(exc)) from None

    def build_rom(self) -> NonlinearROM:
        return model_rom(self.build_model())


def _err(source: Path, where: str, msg: str) -> InputError:
    return InputError(f"{source}: {where}: {msg}")


def _table(raw: dict, name: str, source: Path) -> dict:
    value = raw.get(name, {})
    if not isinstance(value, dict):
        raise _err(source, f"[{name}]", f"expected a table, got {type(value).__name__}")
    return dict(value)


def _check_keys(table: dict, allowed, source: Path, where: str) -> None:
    unknown = sorted(set(table) - set(allowed))
    if unknown:
        raise _err(source, where, f"unknown key {unknown[0]!r}; expected one of {sorted(allowed)}")


def _positive(table: dict, key: str, source: Path, where: str, default=None) -> float:
    if key not in table:
        if default is None:
            raise _err(source, f"{where} {key}", "missing (expected a positive number)")
        return default
    x = table[key]
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not (x > 0 and math.isfinite(x)):
        raise _err(source, f"{where} {key}", f"expected a positive number, got {x!r}")
    return float(x)


def parse_model(model: dict[str, Any], source: Path,
                aeroelastic: dict[str, Any] | None = None) -> ModelSpec:
    """The ``[model]`` table (with its ``[aeroelastic]`` options) validated into a
    :class:`~torchrom.study.models.ModelSpec` (InputError naming the key): which files or
    builtin, with what options; built by :func:`torchrom.study.models.build_model`."""
    where = "[model]"
    if ("rom" in model) == ("builtin" in model):
        raise _err(source, where, "give exactly one of rom = 'file.npz' or builtin = 'name'")
    name = model.get("builtin")
    if name in provider_names():
        _check_provided(model, source)
        return ModelSpec(source, builtin=name, options=_provider_table(model),
                         cache=goland_cache_folder(model, source),
                         aeroelastic=_aeroelastic_options(aeroelastic, source))
    if "rom" in model:
        _check_keys(model, ("rom", "aero", "span", "units", "rigid_body_support_hz"), source,
                    where)
        rom = _relative(model["rom"], source)
        expect_file_kind(rom, "rom", f"{source}: [model] rom")
        aero = None
        if "aero" in model:
            aero = _relative(model["aero"], source)
            expect_file_kind(aero, "aero", f"{source}: [model] aero")
        elif aeroelastic:
            raise _err(source, "[aeroelastic]", "needs a model with aerodynamics ([model] aero "
                       "= 'aero.npz' or builtin = 'goland')")
        units = model.get("units")
        if units is not None:
            try:
                unit_system(units, f"{source}: [model] units")
            except InputError:
                raise _err(source, f"{where} units", f"expected one of {', '.join(SYSTEMS)}, "
                           f"got {units!r}") from None
        span = _positive(model, "span", source, where) if "span" in model else None
        support = None
        if "rigid_body_support_hz" in model:
            if aero is None:
                raise _err(source, f"{where} rigid_body_support_hz", "needs a model with "
                           "aerodynamics ([model] aero = 'aero.npz')")
            support = _positive(model, "rigid_body_support_hz", source, where)
        return ModelSpec(source, rom=rom, aero=aero, span=span, units=units,
                         aeroelastic=_aeroelastic_options(aeroelastic, source) if aero else {},
                         rigid_body_support_hz=support)
    if name not in BUILTIN:
        raise _err(source, f"{where} builtin", f"expected one of "
                   f"{sorted([*BUILTIN, *provider_names()])}, "
                   f"got {name!r}")
    kwargs = {k: v for k, v in model.items() if k != "builtin"}
    _check_keys(kwargs, inspect.signature(BUILTIN[name]).parameters, source, f"{where} ({name})")
    if aeroelastic:
        raise _err(source, "[aeroelastic]", "needs a model with aerodynamics ([model] aero = "
                   "'aero.npz' or builtin = 'goland')")
    return ModelSpec(source, builtin=name, options=kwargs)


def _relative(path: str, source: Path) -> Path:
    p = Path(path)
    return p if p.is_absolute() else source.parent / p


def _aeroelastic_options(table: dict[str, Any] | None, source: Path) -> dict[str, Any]:
    """The ``[aeroelastic]`` table as :class:`~.models.AeroelasticModel` keyword arguments:
    ``reference_altitude_<unit>`` → ``matched_altitude``, ``altitude_range_<unit>`` →
    ``altitude_range``, with ``altitude_unit`` the unit they (or ``altitude_unit``) name
    (:func:`run_altitude_unit` checks that it is one)."""
    table = dict(table or {})
    _check_keys(table, AEROELASTIC_KEYS, source, "[aeroelastic]")
    out: dict[str, Any] = {}
    # the baseline damping: the physical ranges of the case parameters
    for key, name in (("baseline_alpha", "alpha"), ("baseline_gamma", "gamma")):
        if key in table:
            out[key] = physical(name, table[key], f"{source}: [aeroelastic] {key}:")
    for unit in ALTITUDE_UNITS:
        key = f"altitude_range_{unit}"
        if key in table:
            rng = table[key]
            if not (isinstance(rng, list) and len(rng) == 2 and _finite_numbers(rng)
                    and rng[0] < rng[1]):
                raise _err(source, f"[aeroelastic] {key}", f"expected [LO, HI], got {rng!r}")
            out["altitude_range"] = tuple(physical(f"altitude_{unit}", h, f"{source}: "
                                                   f"[aeroelastic] {key}:") for h in rng)
        key = f"reference_altitude_{unit}"
        if key in table and table[key] is not None:
            out["matched_altitude"] = physical(f"altitude_{unit}", table[key],
                                               f"{source}: [aeroelastic] {key}:")
    try:
        named = altitude_unit_sources(table, [])
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    if named:
        out["altitude_unit"] = named[0][0]
    return out


def altitude_unit_sources(aeroelastic: dict[str, Any], cases: list[dict[str, Any]]
                          ) -> list[tuple[str, str]]:
    """(unit, where) of every key of a configuration that names an altitude unit:
    ``[aeroelastic] altitude_unit``, its ``*_altitude_<unit>`` / ``altitude_range_<unit>``
    keys and the ``altitude_<unit>`` parameters of the cases (the first case with each)."""
    found = []
    if "altitude_unit" in aeroelastic:
        found.append((altitude_unit(aeroelastic["altitude_unit"], "[aeroelastic] altitude_unit"),
                      f"[aeroelastic] altitude_unit = {aeroelastic['altitude_unit']!r}"))
    for unit in ALTITUDE_UNITS:
        for key in (f"reference_altitude_{unit}", f"altitude_range_{unit}"):
            if key in aeroelastic:
                found.append((unit, f"[aeroelastic] {key}"))
    for column, unit in ALTITUDE_COLUMNS.items():
        k = next((k for k, c in enumerate(cases) if column in c), None)
        if k is not None:
            found.append((unit, f"[cases] {column} (case {k})"))
    return found


def run_altitude_unit(aeroelastic: dict[str, Any], cases: list[dict[str, Any]],
                      source: Path) -> str | None:
    """The one altitude unit of a run: the unit that its keys name
    (:func:`altitude_unit_sources`), None when none names one (the model's unit system's);
    InputError naming two keys that name different units."""
    try:
        found = altitude_unit_sources(aeroelastic, cases)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    for unit, where in found[1:]:
        if unit != found[0][0]:
            first_unit, first = found[0]
            raise _err(source, where.split(" (")[0], f"altitudes in {unit}, but {first} "
                       f"names {first_unit}: one altitude unit per run (give every altitude as "
                       f"altitude_{first_unit}, or all in {unit})")
    return found[0][0] if found else None


def goland_cache_folder(model: dict[str, Any], source: Path) -> Path:
    """Cache folder of a built-in model with aerodynamics (e.g. the Goland pipeline):
    ``[model] cache``, else its name under the cache root (--cache-dir, $TORCHROM_CACHE, else the
    user cache folder; :mod:`torchrom.cache_dir`)."""
    from ..cache_dir import cache_folder

    if "cache" in model:
        return _relative(str(model["cache"]), source)
    return cache_folder(str(model.get("builtin", "goland")))


def _provider_table(model: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in model.items() if k not in ("builtin", "cache")}


def _check_provided(model: dict[str, Any], source: Path) -> None:
    try:
        model_provider(model["builtin"]).check(_provider_table(model))
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None


def _merged(base: dict[str, Any], override: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = _merged(out[key], value)
        else:
            out[key] = value
    return out


def apply_variant(raw: dict[str, Any], variant: str | None, source: Path) -> dict[str, Any]:
    """The raw configuration with ``[variants.<variant>]`` merged in (and the variants removed)."""
    variants = raw.get("variants", {})
    if not isinstance(variants, dict):
        raise _err(source, "[variants]", f"expected a table, got {type(variants).__name__}")
    base = {k: v for k, v in raw.items() if k != "variants"}
    if variant is None:
        return base
    if variant not in variants or not isinstance(variants[variant], dict):
        raise _err(source, "[variants]", f"no variant {variant!r}; the file has "
                   f"{sorted(variants)}")
    return _merged(base, variants[variant])


def load_sweep_config(path, variant: str | None = None) -> SweepConfig:
    """Read and validate a sweep configuration (InputError naming the key on any problem);
    ``variant`` merges ``[variants.<variant>]`` over the rest. The file's tables are validated
    by :func:`config_from_dict`, named by the file."""
    source, raw = read_toml(path, "configuration file")
    return config_from_dict(raw, variant, name=source)


#: what a value of a configuration may be: TOML's types (tomllib gives these)
_TOML_SCALARS = (str, bool, int, float, datetime.date, datetime.time)


def _key_path(keys: tuple[str, ...]) -> str:
    """How an error names a key: ``title``, ``[integrator]``, ``[integrator] dt``,
    ``[cases] gamma.median`` (as for a TOML file)."""
    if len(keys) == 1:
        return keys[0] if keys[0] in ("title", "method") else f"[{keys[0]}]"
    return f"[{keys[0]}] {'.'.join(keys[1:])}"


def toml_values(value: Any, source: Path, keys: tuple[str, ...] = ()) -> Any:
    """A copy of ``value`` made of TOML's types only, what :func:`config_from_dict` validates:
    tuples and arrays become lists, NumPy scalars Python numbers, paths strings; a key that
    is not a string or a value TOML cannot hold is an InputError naming its key path. A table
    read from a TOML file comes back equal."""
    import numpy as np

    where = _key_path(keys) if keys else "top level"
    if isinstance(value, Mapping):
        out = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise _err(source, where, f"key {key!r} is a {type(key).__name__}: expected "
                           f"string keys (as in a TOML table)")
            out[key] = toml_values(item, source, (*keys, key))
        return out
    if isinstance(value, np.ndarray):
        value = value.tolist()
    if isinstance(value, (list, tuple)):
        return [toml_values(item, source, keys) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    if isinstance(value, _TOML_SCALARS):
        return value
    raise _err(source, where, f"expected a TOML value (string, number, boolean, date, list or "
               f"table), got {type(value).__name__} {value!r}")


def config_from_dict(raw: Mapping[str, Any], variant: str | None = None, *,
                     name: str | os.PathLike = "<dict>") -> SweepConfig:
    """A sweep configuration from a dict holding what a TOML file would (e.g. in a notebook:
    ``{"model": {"builtin": "van_der_pol_duffing"}, "integrator": {"dt": 0.01, ...}}``),
    validated as a file is — the file loader calls this — with errors naming ``name`` (default
    ``<dict>``), the table and the key. Relative paths are relative to the folder of ``name``
    (for ``<dict>``: the working directory). The dict is copied (:func:`toml_values`)."""
    source = Path(name)
    if not isinstance(raw, Mapping):
        raise _err(source, "top level", f"expected a dict of the configuration's tables, got "
                   f"{type(raw).__name__}")
    raw = toml_values(raw, source)
    _check_keys(raw, SECTIONS, source, "top level")
    raw = apply_variant(raw, variant, source)
    _check_keys(raw, SECTIONS, source, f"top level (variant {variant})")
    title = raw.get("title", source.stem)
    if not isinstance(title, str):
        raise _err(source, "title", f"expected a string, got {title!r}")

    model = _table(raw, "model", source)
    initial = _checked_table(raw, "initial", source)

    method = raw.get("method", DEFAULT_METHOD)
    if method not in SOLVERS:
        raise _err(source, "method", f"expected one of {list(SOLVERS)}, got {method!r}")
    integ = _checked_table(raw, "integrator", source)
    dt = _positive(integ, "dt", source, "[integrator]", 1e-3)
    # periodic-orbit solvers simulate no time: t_end is needed by time marching only
    t_end = _positive(integ, "t_end", source, "[integrator]",
                      None if SOLVERS[method].marches_time else math.inf)
    hb = hb_method(_table(raw, "hb", source), source)
    certificate = certificate_of(_table(raw, "certificate", source), source)
    try:
        newmark = Newmark(dt=dt, **{k: integ[k] for k in _NEWMARK_KEYS if k in integ})
        if SOLVERS[method].marches_time:
            newmark.step_count(t_end)
    except InputError as exc:
        raise _err(source, "[integrator]", str(exc)) from None
    except TypeError as exc:
        raise _err(source, "[integrator]", f"bad value ({exc})") from None

    lco_t = _checked_table(raw, "lco", source)
    try:
        points = check_point_table(_table(raw, "points", source))
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    outputs = lco_t.get("outputs")
    if outputs is not None and (not isinstance(outputs, list) or not outputs
                                or not all(isinstance(o, str) for o in outputs)):
        raise _err(source, "[lco] outputs", f"expected a list of output names, got {outputs!r}")
    try:
        lco = LCOCriteria(**{k: lco_t[k] for k in _LCO_KEYS if k in lco_t})
    except InputError as exc:
        raise _err(source, "[lco]", str(exc)) from None
    except TypeError as exc:
        raise _err(source, "[lco]", f"bad value ({exc})") from None

    aero_t = _table(raw, "aeroelastic", source)
    spec = parse_model(model, source, aero_t)
    aeroelastic = spec.has_aero
    parameters = case_parameters(aeroelastic)
    try:
        check_start(initial, parameters)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    cases_t = _table(raw, "cases", source)
    run_t = _checked_table(raw, "run", source)
    allow_large = run_t.get("allow_large", False)
    try:
        cases = expand_cases(cases_t, "[cases]", allowed=parameters, allow_large=allow_large)
        check_case_values(cases, aeroelastic)
        history = HistorySpec.from_table(_table(raw, "history", source), parameters)
    except InputError as exc:
        raise InputError(f"{source}: {exc}") from None
    if aeroelastic:
        unit = run_altitude_unit(aero_t, cases, source)
        if unit is not None:
            spec = dataclasses.replace(spec, aeroelastic={**spec.aeroelastic,
                                                          "altitude_unit": unit})

    plot_t = _checked_table(raw, "plot", source)
    swept = [k for k in parameters if len({repr(c.get(k)) for c in cases}) > 1]
    x = plot_t.get("x", swept[0] if swept else "alpha")
    hue = plot_t.get("hue")
    for key, value in (("x", x), ("hue", hue)):
        if value is not None and value not in parameters:
            raise _err(source, f"[plot] {key}", f"expected a case parameter "
                       f"{parameters}, got {value!r}")
    present = {k for c in cases for k in c}  # the parameter columns the table will have
    for key, value in (("x", x), ("hue", hue)):
        if value is not None and value not in present:
            how = ("the [cases] table sets no parameter" if not present else
                   f"the cases set only {sorted(present)}")
            raise _err(source, f"[plot] {key}", f"{value!r} is no parameter of the cases "
                       f"({how}): the figure would have no {key}; expected one of "
                       f"{sorted(present)}" if present else
                       f"{value!r} is no parameter of the cases ({how}): give [cases] values "
                       f"(e.g. alpha = [0.0, 0.3]) to plot against")
    y = plot_t.get("y", "amplitude")
    columns = result_columns(parameters, outputs, aeroelastic)
    if not is_result_column(y, columns):
        raise _err(source, "[plot] y", f"expected a column of the results table "
                   f"({', '.join(columns)}), got {y!r}")
    plot = PlotSpec(x=x, y=y, hue=hue)
    if history is not None and history.where and not history.indices(cases):
        raise _err(source, "[history] where", f"{history.where} selects none of the "
                   f"{len(cases)} cases: expected values of the [cases] grid")

    batch = run_t.get("batch_size", 512)

    cfg = SweepConfig(source=source, title=title, model=model, initial=initial,
                      integrator=newmark, t_end=t_end, lco=lco, outputs=outputs, cases=cases,
                      plot=plot, batch_size=batch, chunk_size=run_t.get("chunk_size"), raw=raw,
                      aeroelastic=aero_t,
                      history=history, method=method, hb=hb, certificate=certificate,
                      allow_large=allow_large, points=points, model_spec=spec)
    check_time_scales(cfg)
    check_work(cfg)
    if not spec.provided:  # a provider's model is built (or reused) when the sweep runs
        check_initial(cfg, cfg.build_model())  # fail now, not after a long run
    return cfg


#: the columns of every results table (:func:`torchrom.study.table.result_rows`), those of the
#: certificate (:data:`torchrom.periodic.certify.COLUMNS`) and of the periodic-orbit solvers
#: (:mod:`torchrom.periodic.method`): the numeric columns ``[plot] y`` may name besides the case
#: parameters and ``amplitude_<output>`` (a test checks this list against real sweep tables)
RESULT_COLUMNS = ("amplitude", "amplitude_pct_span", "frequency_hz", "last_amplitude",
                  "last_amplitude_pct_span", "last_frequency_hz", "ratio_q1_q2", "ratio_q1_q4",
                  "steps", "t_end", "amplitude_change", "solver_error",
                  "harmonics", "hb_residual", "truncation", "harmonic_distortion",
                  "floquet_multiplier", "floquet_error", "seeded", "amplitude_dgamma",
                  "frequency_dgamma")
#: the derived columns of an aeroelastic case (its flight condition and matched α)
AEROELASTIC_COLUMNS = ("velocity", "dynamic_pressure", "density", "alpha_matched")


def result_columns(parameters, outputs, aeroelastic: bool) -> list[str]:
    """The columns a sweep's results table can have: the case parameters, the derived
    flight-condition columns, :data:`RESULT_COLUMNS`, the certificate's columns and one
    ``amplitude_<output>`` per tracked output (the placeholder itself when the outputs are the
    model's, not known before it is built: :func:`is_result_column`)."""
    from ..periodic.certify import COLUMNS

    names = outputs if outputs else ["<output>"]  # the model's outputs: known once it is built
    cols = [*parameters, *(AEROELASTIC_COLUMNS if aeroelastic else ()), *RESULT_COLUMNS,
            *COLUMNS, *(f"amplitude_{o}" for o in names)]
    return list(dict.fromkeys(cols))


def is_result_column(name, columns: list[str]) -> bool:
    """Whether ``name`` is one of ``columns`` (:func:`result_columns`), where
    ``amplitude_<output>`` stands for the amplitude of any of the model's outputs."""
    if not isinstance(name, str):
        return False
    return name in columns or ("amplitude_<output>" in columns
                               and name.startswith("amplitude_"))


def hb_method(table: dict[str, Any], source: Path, where: str = "[hb]") -> HarmonicBalanceMethod:
    """The harmonic balance method of a ``[hb]`` table (every key checked)."""
    _check_keys(table, (*_HB_OPTION_KEYS, *_HB_METHOD_KEYS), source, where)
    try:
        options = HBOptions(**{k: table[k] for k in _HB_OPTION_KEYS if k in table})
        return HarmonicBalanceMethod(options, **{k: table[k] for k in _HB_METHOD_KEYS
                                                 if k in table})
    except InputError as exc:
        raise _err(source, where, str(exc)) from None
    except TypeError as exc:
        raise _err(source, where, f"bad value ({exc})") from None


def certificate_of(table: dict[str, Any], source: Path, where: str = "[certificate]"
                   ) -> Certificate:
    """The LCO certificate of a ``[certificate]`` table (every key checked)."""
    _check_keys(table, tuple(f.name for f in dataclasses.fields(Certificate)), source, where)
    try:
        return Certificate(**table)
    except InputError as exc:
        raise _err(source, where, str(exc)) from None


def with_method(cfg: SweepConfig, method: str | None) -> SweepConfig:
    """A copy that runs with ``method`` (a key of :data:`~.solvers.SOLVERS`; None: unchanged).
    The method is part of the configuration's hash, so two never share stored results."""
    if method is None or method == cfg.method:
        return cfg
    if method not in SOLVERS:
        raise InputError(f"--method: expected one of {list(SOLVERS)}, got {method!r}")
    if SOLVERS[method].marches_time and not math.isfinite(cfg.t_end):
        raise InputError(f"{cfg.source}: [integrator] t_end: missing (time marching needs it)")
    return dataclasses.replace(cfg, method=method, raw={**cfg.raw, "method": method})


def check_work(cfg: SweepConfig, n_cases: int | None = None, what: str = "cases") -> None:
    """The bounds of :mod:`torchrom.bounds` that the configuration alone decides: case-steps ×
    iterations of time marching and the integrator's thread count (InputError naming the
    estimate and ``--allow-large``). ``n_cases``: the cases a command will run in all (e.g. a
    calibration's rounds × values × base cases; default the configuration's cases), named
    ``what`` in the message."""
    from ..bounds import MAX_CASES, MAX_ITERATIONS, check_count, check_threads

    check_threads(f"{cfg.source}: [integrator] threads", cfg.integrator.threads,
                  override=cfg.allow_large)
    for key in ("iterations", "startup_iterations"):
        check_count(f"{cfg.source}: [integrator] {key}", "iterations per step",
                    getattr(cfg.integrator, key) or 0, MAX_ITERATIONS, override=cfg.allow_large)
    n = len(cfg.cases) if n_cases is None else n_cases
    if n_cases is not None:
        check_count(f"{cfg.source}", what, n, MAX_CASES, override=cfg.allow_large)
    cfg.solver.check_effort(cfg, n, what)


def check_time_scales(cfg: SweepConfig) -> None:
    """Every time-like setting against the run's length ``t_end`` (when the method marches
    time or the file gives it): the integrator's dt, the certificate's dt and the history
    interval every × dt must each fit in t_end at least once, else nothing is integrated or
    sampled and the run would still exit 0. InputError naming the key."""
    if not math.isfinite(cfg.t_end):
        return
    dt = cfg.integrator.dt
    steps = {"[integrator] dt": dt}
    if cfg.certificate.dt is not None:
        steps["[certificate] dt"] = float(cfg.certificate.dt)
    if cfg.history is not None:
        steps["[history] every"] = cfg.history.every * dt
    for key, length in steps.items():
        if length > cfg.t_end:
            what = (f"every x dt = {cfg.history.every} x {dt:g} s = {length:g} s"
                    if key == "[history] every" else f"{length:g} s")
            raise _err(cfg.source, key, f"{what} is longer than [integrator] t_end = "
                       f"{cfg.t_end:g} s: expected a step <= t_end (the run would take no step)")


def check_orbit_steps(cfg: SweepConfig, model, device=None, dtype=None) -> None:
    """The size of the shooting on the discrete Newmark map (the shooting solver's finish and
    the certificate's, :mod:`torchrom.periodic.shooting`), estimated before any work: a period
    T takes N = T/dt steps and each step stores B × (outputs + 2n + lags + 1) samples (lags
    counted as 2n). T is at
    most about the period of the model's lowest linear mode 1/f₁ (an LCO oscillates near its
    flutter frequency, above f₁), so dt ≥ 1/f₁ resolves no oscillation (refused), and
    N = 1/(f₁ dt) is bounded by :data:`torchrom.sim.newmark.MAX_STEPS` and the memory by
    :func:`torchrom.bounds.check_memory` (InputError naming dt, the steps and the size)."""
    import numpy as np
    import torch

    from .. import bounds
    from ..sim.newmark import MAX_STEPS

    if not (cfg.certificate.enabled or cfg.method == "shooting"):
        return
    rom = model_rom(model)
    freqs = np.asarray(rom.frequencies_hz, dtype=float)
    freqs = freqs[np.isfinite(freqs) & (freqs > 0)]
    if freqs.size == 0:
        return
    key = "[certificate] dt" if cfg.certificate.dt is not None else "[integrator] dt"
    h = float(cfg.certificate.dt if cfg.certificate.dt is not None else cfg.integrator.dt)
    period = 1.0 / float(freqs.min())
    where = f"{cfg.source}: {key}"
    if h >= period:
        raise InputError(f"{where}: {h:g} s is not shorter than the period of the model's lowest "
                         f"mode (1/{freqs.min():.4g} Hz = {period:.4g} s): the step resolves no "
                         f"oscillation; expected dt well below {period:.4g} s")
    steps = period / h
    bounds.check_count(where, f"steps per LCO period (1/f1 / dt = {period:.4g} s / {h:g} s)",
                       steps, MAX_STEPS, override=cfg.allow_large)
    iterations = cfg.certificate.max_iterations
    bounds.check_count(where, f"cases x steps per period x iterations ({len(cfg.cases)} x "
                       f"{steps:.3g} x {iterations})", float(len(cfg.cases)) * steps * iterations,
                       bounds.MAX_WORK, override=cfg.allow_large)
    # lag states of the aerodynamics (not known before the RFA is built): counted as 2n
    na = 0 if isinstance(model, NonlinearROM) else 2 * rom.n
    batch = min(cfg.batch_size, max(len(cfg.cases), 1))
    outputs = len(cfg.outputs) if cfg.outputs else rom.n
    width = outputs + 2 * rom.n + na + 1
    itemsize = torch.empty((), dtype=dtype or torch.float64).element_size()
    bounds.check_memory(where, f"shooting over {steps:.3g} steps per period for {batch} "
                        f"case(s) at once", float(batch) * steps * width * itemsize,
                        device=device, override=cfg.allow_large)


def check_memory(cfg: SweepConfig, model, device=None, dtype=None) -> None:
    """The largest allocation of the run, estimated from the model's size before any work:
    the solver's (harmonic balance: :func:`torchrom.bounds.check_harmonic_balance`; time
    marching: the integrator's B × n² matrices)."""
    import torch

    batch = min(cfg.batch_size, max(len(cfg.cases), 1))
    itemsize = torch.empty((), dtype=dtype or torch.float64).element_size()
    cfg.solver.check_memory(cfg, model_rom(model).n, batch, itemsize, device)
    check_orbit_steps(cfg, model, device, dtype)


def check_aeroelastic_cases(cfg: SweepConfig, model) -> None:
    """Before any case runs, what an aeroelastic case needs from its model: the Mach number of
    the aerodynamic data, and for ``alpha = "matched"`` the baseline flutter point in the
    altitude range (computed once and kept by the model), so that a configuration error is
    refused up front, not after the sweep has started (and left parts to resume)."""
    from ..errors import TorchromError
    from .cases import MATCHED

    if not isinstance(model, AeroelasticModel):
        return
    for k, c in enumerate(cfg.cases):
        if "mach" in c and abs(float(c["mach"]) - model.mach) > 1e-9:
            raise InputError(f"{cfg.source}: [cases] mach: {c['mach']} (case {k}) differs from "
                             f"the Mach number {model.mach:g} of the aerodynamic data")
        if "density" in c and not is_air_density(float(c["density"]), model.units):
            u = model.units
            raise InputError(f"{cfg.source}: [cases] density: {c['density']} (case {k}) is no "
                             f"air density in {u.name}, the model's units ({u.density}; sea "
                             f"level {u.sea_level_density:.4g}): give it in {u.density}")
    if any(c.get("alpha") == MATCHED for c in cfg.cases):
        try:
            model.reference_altitude()
        except TorchromError as exc:
            raise InputError(f"{cfg.source}: [cases] alpha = {MATCHED!r}: {exc}") from None


def check_initial(cfg: SweepConfig, model) -> None:
    """InputError unless the ``[initial]`` state (q0 / v0 sizes, mode number) and the ``[lco]``
    outputs fit the model, and the run's memory estimate is within bounds
    (:func:`check_memory`)."""
    check_memory(cfg, model)
    check_aeroelastic_cases(cfg, model)
    from ..sim import output_matrix
    from .cases import initial_displacement, initial_velocity

    rom = model_rom(model)
    try:
        initial_displacement(rom, cfg.initial, cfg.cases[:1])
        initial_velocity(rom, cfg.initial, 1)
        if cfg.outputs is not None:
            try:
                output_matrix(rom, cfg.outputs)
            except InputError as exc:
                raise InputError(f"[lco] outputs: {exc}") from None
    except InputError as exc:
        raise InputError(f"{cfg.source}: {exc}") from None


def with_overrides(cfg: SweepConfig, **integrator_options) -> SweepConfig:
    """A copy whose integrator has some options replaced (e.g. compile from the command line)."""
    options = {k: v for k, v in integrator_options.items() if v is not None}
    if not options:
        return cfg
    fields = {f.name: getattr(cfg.integrator, f.name) for f in dataclasses.fields(Newmark)
              if f.init}
    fields.update(options)
    return dataclasses.replace(cfg, integrator=Newmark(**fields))
