"""Uncertainty sampling of case parameters (seeded) and amplitude distributions.

Inverse-CDF sampling on numpy's PCG64 generator (``numpy.random.default_rng``;
SciPy's ``ndtr``/``ndtri`` for the normal CDF and its inverse); pandas for the summaries.

In a ``[cases]`` table a parameter may be a distribution instead of values::

    gamma = { distribution = "lognormal", median = 1e-3, sigma = 0.2 }
    alpha = { distribution = "uniform", low = 0.0, high = 0.05 }
    samples = 200          # number of draws (required with a distribution)
    seed = 7               # required: the same configuration and seed give the same cases
    sampling = "random"    # or "lhs" (Latin hypercube: one draw per 1/samples quantile band)

Distributions: ``uniform`` (low, high), ``loguniform`` (low, high > 0), ``normal`` (mean,
std) and ``lognormal`` (median, sigma = standard deviation of ln x), the last two optionally
truncated to [low, high]. The sampled parameters are drawn jointly (independently of each
other) into ``samples`` cases numbered by a ``sample`` parameter; that block combines with the
other swept parameters like one swept parameter (product: every altitude sees the same draws,
so differences between altitudes are not sampling noise). Draw i uses the i-th row of uniforms
of the generator (parameters in name order), so with ``sampling = "random"`` a study extended
from 200 to 500 samples keeps its first 200 cases — and their case ids, so they are resumed.

:func:`amplitude_distribution` summarises an amplitude column per group (e.g. per altitude):
an LCO counts with its amplitude, a decay with 0 (no LCO), other statuses are only counted.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd
import scipy

from ..errors import InputError

#: distribution name -> (required keys, optional keys)
DISTRIBUTIONS = {
    "uniform": (("low", "high"), ()),
    "loguniform": (("low", "high"), ()),
    "normal": (("mean", "std"), ("low", "high")),
    "lognormal": (("median", "sigma"), ("low", "high")),
}
SAMPLING = ("random", "lhs")
#: keys of a [cases] table that control sampling (not parameters)
SAMPLING_KEYS = ("samples", "seed", "sampling")
# rng.random() returns k 2**-53, k = 0 .. 2**53 - 1: shifted by half a step, u is in (0, 1)
_HALF_STEP = 2.0**-54


def is_distribution(spec: Any) -> bool:
    return isinstance(spec, Mapping) and "distribution" in spec


def _number(spec: Mapping, key: str, where: str) -> float:
    x = spec[key]
    if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
        raise InputError(f"{where}.{key}: expected a finite number, got {x!r}")
    return float(x)


def check_distribution(spec: Mapping[str, Any], where: str) -> dict[str, float | str]:
    """The validated distribution ``spec`` (InputError naming the key otherwise)."""
    name = spec.get("distribution")
    if name not in DISTRIBUTIONS:
        raise InputError(f"{where}.distribution: expected one of {sorted(DISTRIBUTIONS)}, got "
                         f"{name!r}")
    required, optional = DISTRIBUTIONS[name]
    extra = sorted(set(spec) - {"distribution", *required, *optional})
    if extra:
        raise InputError(f"{where}: unknown key {extra[0]!r} for a {name} distribution; expected "
                         f"{', '.join(required + optional)}")
    missing = [k for k in required if k not in spec]
    if missing:
        raise InputError(f"{where}: missing {', '.join(missing)} (a {name} distribution needs "
                         f"{', '.join(required)})")
    out: dict[str, float | str] = {"distribution": name}
    out.update({k: _number(spec, k, where) for k in required + optional if k in spec})
    low, high = out.get("low", -math.inf), out.get("high", math.inf)
    if not low < high:
        raise InputError(f"{where}: expected low < high, got {low} and {high}")
    if name == "loguniform" and low <= 0:
        raise InputError(f"{where}.low: a loguniform distribution needs low > 0, got {low}")
    for key in ("std", "sigma", "median"):
        if key in out and not out[key] > 0:
            raise InputError(f"{where}.{key}: expected a positive number, got {out[key]}")
    if name == "lognormal" and "low" in out and out["low"] < 0:
        raise InputError(f"{where}.low: a lognormal variable is positive, got low = {out['low']}")
    return out


def inverse_cdf(spec: Mapping[str, Any], u: np.ndarray) -> np.ndarray:
    """Quantiles of a checked distribution at probabilities u in (0, 1)."""
    name = spec["distribution"]
    if name == "uniform":
        return spec["low"] + u * (spec["high"] - spec["low"])
    if name == "loguniform":
        lo, hi = math.log(spec["low"]), math.log(spec["high"])
        return np.exp(lo + u * (hi - lo))
    if name == "normal":
        loc, scale, to_x = spec["mean"], spec["std"], (lambda z: z)
    else:  # lognormal: ln x is normal with mean ln(median) and standard deviation sigma
        loc, scale, to_x = math.log(spec["median"]), spec["sigma"], np.exp
    # truncation: map u onto the CDF interval [Φ(a), Φ(b)] of the bounds
    a = scipy.special.ndtr((_ln_bound(spec, "low", name) - loc) / scale)
    b = scipy.special.ndtr((_ln_bound(spec, "high", name) - loc) / scale)
    if not b > a:
        raise InputError(f"{name} distribution: [low, high] holds no probability mass")
    return to_x(loc + scale * scipy.special.ndtri(a + u * (b - a)))


def _ln_bound(spec: Mapping[str, Any], key: str, name: str) -> float:
    default = -math.inf if key == "low" else math.inf
    x = spec.get(key, default)
    if name == "lognormal" and math.isfinite(x):
        return math.log(x) if x > 0 else -math.inf
    return x


def sample_block(specs: Mapping[str, Mapping[str, Any]], samples: Any, seed: Any,
                 sampling: Any = "random", where: str = "[cases]") -> list[dict[str, Any]]:
    """``samples`` joint draws of the distributions ``specs`` (name -> spec) as case dicts,
    each with its ``sample`` number (see the module docstring)."""
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise InputError(f"{where} samples: expected a positive integer (the number of draws), "
                         f"got {samples!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError(f"{where} seed: expected a non-negative integer, got {seed!r}")
    if sampling not in SAMPLING:
        raise InputError(f"{where} sampling: expected one of {SAMPLING}, got {sampling!r}")
    names = sorted(specs)
    checked = {k: check_distribution(specs[k], f"{where} {k}") for k in names}
    rng = np.random.default_rng(seed)
    if sampling == "random":
        u = rng.random((samples, len(names)))
    else:  # Latin hypercube: a random point in each of the `samples` bands, bands shuffled
        u = np.stack([(rng.permutation(samples) + rng.random(samples)) / samples
                      for _ in names], axis=1)
    u = u + _HALF_STEP
    columns = {k: inverse_cdf(checked[k], u[:, j]) for j, k in enumerate(names)}
    return [{"sample": i, **{k: float(columns[k][i]) for k in names}} for i in range(samples)]


def sampled_parameters(cases_table: Mapping[str, Any]) -> list[str]:
    """Names of the parameters a raw ``[cases]`` table samples from distributions."""
    return [k for k, v in cases_table.items() if is_distribution(v)]


def group_parameters(cases: Sequence[Mapping[str, Any]], sampled: Sequence[str]) -> list[str]:
    """The parameters that vary between cases but are not sampled (e.g. altitude): the groups
    a distribution is shown for."""
    keys = dict.fromkeys(k for c in cases for k in c)
    return [k for k in keys if k not in sampled and k != "sample"
            and len({repr(c.get(k)) for c in cases}) > 1]


# ----------------------------------------------------------------------------------------------
# amplitude distributions
# ----------------------------------------------------------------------------------------------
def distribution_values(table: pd.DataFrame, value: str = "amplitude") -> pd.Series:
    """The sampled quantity per case: ``value`` for an LCO, 0 for a decay, NaN otherwise."""
    out = pd.Series(np.nan, index=table.index, dtype=float)
    out[table["status"] == "lco"] = table.loc[table["status"] == "lco", value].astype(float)
    out[table["status"] == "decay"] = 0.0
    return out


def amplitude_distribution(table: pd.DataFrame, by: Sequence[str] = (),
                           value: str = "amplitude",
                           quantiles: Sequence[float] = (0.05, 0.5, 0.95)) -> pd.DataFrame:
    """Per group of ``by`` (e.g. altitude): counts by status, the probability of an LCO and the
    mean, standard deviation, quantiles, min and max of :func:`distribution_values`."""
    if value not in table.columns:
        raise InputError(f"distribution: no column {value!r} in the results table")
    vals = distribution_values(table, value)
    groups = table.groupby(list(by), sort=True) if by else [((), table)]
    rows = []
    for key, grp in groups:
        key = key if isinstance(key, tuple) else (key,)
        v = vals[grp.index].dropna().to_numpy()
        n_lco = int((grp["status"] == "lco").sum())
        n_decay = int((grp["status"] == "decay").sum())
        row: dict[str, Any] = dict(zip(by, key))
        row.update({"cases": len(grp), "lco": n_lco, "decay": n_decay,
                    "other": len(grp) - n_lco - n_decay,
                    "p_lco": n_lco / max(n_lco + n_decay, 1),
                    "mean": float(v.mean()) if len(v) else np.nan,
                    "std": float(v.std(ddof=1)) if len(v) > 1 else np.nan})
        for q in quantiles:
            row[f"q{round(100 * q):02d}"] = float(np.quantile(v, q)) if len(v) else np.nan
        row["min"] = float(v.min()) if len(v) else np.nan
        row["max"] = float(v.max()) if len(v) else np.nan
        rows.append(row)
    return pd.DataFrame(rows)
