"""Case grids from TOML tables and stable case identifiers (hand-written; tomllib parses).

A ``[cases]`` table lists parameters. Each value is

- a scalar: the same for every case;
- a list: one case per entry;
- a table ``{start, stop, num}`` (evenly spaced, both ends included) with optional
  ``spacing = "log"`` (geometric), or ``{values = [...]}``.

``combine = "product"`` (default) makes every combination of the swept parameters (the first
one varies slowest); ``combine = "zip"`` pairs them entry by entry (equal lengths required).
``[[cases.list]]`` entries add explicit cases (the scalars of ``[cases]`` fill what they omit).
A list of inline tables is a *bundle*: each table sets several parameters together (e.g.
``curve = [{gamma = 0.0}, {gamma = 1e-3, stiffness_nl = false}]`` swept against ``altitude_ft``);
the bundle's own name is only a label of the axis.
A parameter may also be a distribution (``{distribution = ..., ...}`` with ``samples`` and
``seed``): its seeded draws form one swept block (:mod:`torchrom.study.sampling`).

``case_id`` is a stable hash of a case's parameters: the same parameters give the same id on
any machine and in any order of the keys, and 0, 0.0 and False are the same value.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from ..errors import InputError
from .sampling import SAMPLING_KEYS, is_distribution, sample_block

COMBINE = ("product", "zip")


def _number(x, where: str) -> float:
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise InputError(f"{where}: expected a number, got {x!r}")
    return float(x)


def parameter_values(value: Any, where: str) -> tuple[list[Any], bool]:
    """(values, swept) for one parameter specification (see the module docstring)."""
    if isinstance(value, list):
        if not value:
            raise InputError(f"{where}: expected at least one value, got an empty list")
        return list(value), True
    if isinstance(value, dict):
        if "values" in value:
            extra = set(value) - {"values"}
            if extra:
                raise InputError(f"{where}: unexpected keys {sorted(extra)} beside 'values'")
            return parameter_values(list(value["values"]), where)
        extra = set(value) - {"start", "stop", "num", "spacing"}
        if extra:
            raise InputError(f"{where}: unknown keys {sorted(extra)}; expected start, stop, num "
                             f"and optionally spacing")
        missing = [k for k in ("start", "stop", "num") if k not in value]
        if missing:
            raise InputError(f"{where}: missing {', '.join(missing)} (expected "
                             f"{{start, stop, num}})")
        start = _number(value["start"], f"{where}.start")
        stop = _number(value["stop"], f"{where}.stop")
        num = value["num"]
        if isinstance(num, bool) or not isinstance(num, int) or num < 1:
            raise InputError(f"{where}.num: expected a positive integer, got {num!r}")
        spacing = value.get("spacing", "linear")
        if spacing == "linear":
            vals = np.linspace(start, stop, num)
        elif spacing == "log":
            if start <= 0 or stop <= 0:
                raise InputError(f"{where}: log spacing needs positive start and stop")
            vals = np.geomspace(start, stop, num)
        else:
            raise InputError(f"{where}.spacing: expected 'linear' or 'log', got {spacing!r}")
        return [float(v) for v in vals], True
    return [value], False


def _axis_length(spec: Any) -> int:
    """Entries of one parameter's axis, counted without building it (1 when malformed: the
    expansion then names the problem)."""
    if isinstance(spec, list):
        return max(len(spec), 1)
    if isinstance(spec, dict):
        if is_distribution(spec):
            return 0  # counted with the sampled block
        if isinstance(spec.get("values"), list):
            return max(len(spec["values"]), 1)
        num = spec.get("num")
        if isinstance(num, int) and not isinstance(num, bool) and num >= 1:
            return num
    return 1


def grid_size(table: Mapping[str, Any]) -> int:
    """Number of cases a ``[cases]`` table describes, counted before any case is built (for
    the bound :data:`torchrom.bounds.MAX_CASES`)."""
    table = dict(table)
    explicit = table.pop("list", [])
    combine = table.pop("combine", "product")
    sampling = {k: table.pop(k) for k in SAMPLING_KEYS if k in table}
    lengths = [_axis_length(spec) for spec in table.values()]
    if any(is_distribution(spec) for spec in table.values()):
        samples = sampling.get("samples")
        lengths.append(samples if isinstance(samples, int) and samples >= 1 else 1)
    lengths = [n for n in lengths if n]
    count = (max(lengths, default=1) if combine == "zip" else math.prod(lengths)) if lengths \
        else 0
    return count + (len(explicit) if isinstance(explicit, list) else 0)


def expand_cases(table: Mapping[str, Any], where: str = "[cases]",
                 allowed: Iterable[str] | None = None, *,
                 allow_large: bool = False) -> list[dict[str, Any]]:
    """The list of cases (parameter dicts) described by a ``[cases]`` table; InputError when it
    holds more than :data:`torchrom.bounds.MAX_CASES` (unless ``allow_large`` or
    ``--allow-large``), before any case is built."""
    from ..bounds import MAX_CASES, check_count

    check_count(where, "cases", grid_size(table), MAX_CASES, override=allow_large)
    table = dict(table)
    combine = table.pop("combine", "product")
    if combine not in COMBINE:
        raise InputError(f"{where} combine: expected one of {COMBINE}, got {combine!r}")
    explicit = table.pop("list", [])
    if not isinstance(explicit, list) or not all(isinstance(c, dict) for c in explicit):
        raise InputError(f"{where} list: expected an array of tables ([[cases.list]])")
    allowed = None if allowed is None else set(allowed)

    def check_name(name: str, at: str) -> None:
        if allowed is not None and name not in allowed:
            raise InputError(f"{at}: unknown case parameter {name!r}; expected one of "
                             f"{sorted(allowed)}")

    sampling = {k: table.pop(k) for k in SAMPLING_KEYS if k in table}
    fixed: dict[str, Any] = {}
    # one axis per swept parameter, one for the jointly sampled ones (at the first's place)
    axes: dict[str, list[dict[str, Any]]] = {}
    sampled: dict[str, Any] = {}
    for name, spec in table.items():
        if is_distribution(spec):
            check_name(name, f"{where} {name}")
            sampled[name] = spec
            axes.setdefault("(sampled)", [])
            continue
        vals, is_swept = parameter_values(spec, f"{where} {name}")
        if is_swept and all(isinstance(v, dict) for v in vals):
            for k, bundle in enumerate(vals):
                for key in bundle:
                    check_name(key, f"{where} {name}[{k}]")
            axes[name] = [dict(v) for v in vals]
            continue
        check_name(name, f"{where} {name}")
        if is_swept:
            axes[name] = [{name: v} for v in vals]
        else:
            fixed[name] = vals[0]
    if sampled:
        axes["(sampled)"] = sample_block(sampled, sampling.get("samples"),
                                         sampling.get("seed"), sampling.get("sampling", "random"),
                                         where)
    elif sampling:
        raise InputError(f"{where} {next(iter(sampling))}: given, but no parameter is a "
                         f"distribution (e.g. gamma = {{distribution = 'lognormal', ...}})")
    cases: list[dict[str, Any]] = []
    if axes:
        if combine == "zip":
            lengths = {k: len(v) for k, v in axes.items()}
            if len(set(lengths.values())) > 1:
                raise InputError(f"{where}: combine = 'zip' needs lists of equal length, got "
                                 f"{lengths}")
            combos = zip(*axes.values())
        else:
            combos = itertools.product(*axes.values())
        cases = [{**fixed, **{k: v for part in combo for k, v in part.items()}}
                 for combo in combos]
    elif not explicit:
        cases = [dict(fixed)]
    for k, extra in enumerate(explicit):
        for name in extra:
            check_name(name, f"{where} list[{k}]")
        cases.append({**fixed, **extra})
    return cases


def distinct_cases(cases: Iterable[Mapping[str, Any]], drop: Iterable[str] = ()
                   ) -> list[dict[str, Any]]:
    """The distinct cases after removing the parameters ``drop`` (first occurrence order),
    e.g. the base cases of a calibration (``drop=("gamma",)``)."""
    drop = set(drop)
    seen, out = set(), []
    for c in cases:
        base = {k: v for k, v in c.items() if k not in drop}
        key = case_id(base)
        if key not in seen:
            seen.add(key)
            out.append(base)
    return out


def _canonical(value: Any) -> Any:
    if isinstance(value, (bool, int, float, np.integer, np.floating)):
        x = float(value)
        return "nan" if math.isnan(x) else repr(x)
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    return str(value)


def case_id(params: Mapping[str, Any], context: str | None = None) -> str:
    """Stable 16-hex-digit hash of a case's parameters (key order and int/float/bool spelling of
    the same number do not matter).

    ``context`` (e.g. the hash of the model, the configuration and the precision a sweep runs
    with) enters the hash too, so that the same parameters of a different model get another id
    and stored results of one model are never taken for another's."""
    canon = {str(k): _canonical(v) for k, v in params.items()}
    text = json.dumps(canon, sort_keys=True, separators=(",", ":"))
    if context is not None:
        text += "\x00" + str(context)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def config_hash(obj: Any) -> str:
    """Stable 16-hex-digit hash of a JSON-serialisable configuration."""
    text = json.dumps(obj, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def case_label(case: Mapping[str, Any], keys: Iterable[str], empty: str = "") -> str:
    """``"k = v, ..."`` for the ``keys`` present in ``case`` (numbers compactly, anything else,
    e.g. ``alpha = matched``, as is): how messages and figures name a case."""
    def value(v) -> str:
        return f"{v:g}" if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)

    return ", ".join(f"{k} = {value(case[k])}" for k in keys if k in case) or empty
