"""Calibration of the Kelvin–Voigt factor γ (s, Eq. 53–54) from an observed LCO amplitude.

Batched bracketing; the simulations go through any ``evaluate(cases) -> table``
(e.g. :func:`torchrom.study.sweep.run_sweep` in-process or on Dask workers).

For every *base case* (a case of the configuration: altitude, α, ...) :func:`calibrate_gamma`
looks for the γ at which the LCO amplitude (or another table column) equals ``target``:

1. **Scan**: ``num`` values of γ, log-spaced over ``gamma_range``, for every base case in one
   batch. The response is the amplitude of an LCO, 0 for a decay (no LCO), +∞ for a divergence;
   other statuses (unconverged, failed) are skipped. Every sign change of response − target
   between neighbouring γ is a bracket (all are kept: a non-monotone response can have several
   roots).
2. **Refine**: ``num`` new γ inside every bracket of every base case, again one batch; the
   bracket shrinks by a factor ``num + 1`` per round, until its relative width is below
   ``rtol`` (default 2e-3: finer is rarely meaningful, the LCO detection tolerance [lco] rtol
   limits the amplitudes).
   With a derivative column in the table (``<column>_dgamma``: harmonic balance with
   ``[hb] sensitivity``, dA/dγ by the implicit-function theorem), the refinement is Newton
   on γ inside the bracket instead (:func:`_newton_rounds`): a few single-case rounds.
3. **Root and sensitivity**: γ̂ by linear interpolation of the last bracket in ln γ; the
   sensitivity from a least-squares cubic in ln γ through the converged LCOs within half a
   scan step of γ̂ (the refinement points, spread over a finite width, so the LCO detection
   noise of single amplitudes averages out instead of being divided by a tiny step; on the
   closed-form response A = 2 sqrt(1 − α/γ) near its onset this is good to 2e-4, a quadratic
   over a whole step only to 2e-2): ``dA/dγ`` (output units per s) and ``dlnA/dlnγ``.

``alpha_for_gamma`` (γ -> α) supports calibrations in which α is tied to γ, e.g. matched so
that flutter stays at a given altitude; without it α is the base case's (fixed).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from ..errors import InputError

Evaluate = Callable[[list[dict[str, Any]]], pd.DataFrame]


@dataclass
class CalibrationResult:
    """``table``: one row per root and base case (see :func:`calibrate_gamma`);
    ``evaluations``: every simulated case with its base-case index and round."""

    table: pd.DataFrame
    evaluations: pd.DataFrame


def response(table: pd.DataFrame, column: str = "amplitude") -> np.ndarray:
    """The calibrated quantity per row: ``column`` for an LCO, 0 for a decay, +inf for a
    divergence, NaN for an undecided case."""
    status = table["status"].to_numpy()
    y = np.full(len(table), np.nan)
    lco = status == "lco"
    y[lco] = table[column].to_numpy(dtype=float)[lco]
    y[status == "decay"] = 0.0
    y[status == "diverged"] = np.inf
    return y


def _brackets(g: np.ndarray, y: np.ndarray, target: float) -> list[tuple[int, int]]:
    """Index pairs (i, j) of neighbouring decided points (γ ascending) where y − target
    changes sign (NaN points are skipped)."""
    ok = np.nonzero(~np.isnan(y))[0]
    d = y[ok] - target
    out = []
    for a, b in zip(range(len(ok) - 1), range(1, len(ok))):
        if d[a] == 0:
            out.append((ok[a], ok[a]))
        elif d[a] * d[b] < 0:
            out.append((ok[a], ok[b]))
    if len(ok) and d[-1] == 0:
        out.append((ok[-1], ok[-1]))
    return out


def _interpolate(g0, g1, y0, y1, target) -> float:
    """Root of y − target on [g0, g1], linear in ln γ (midpoint when an end diverged)."""
    if g0 == g1:
        return g0
    l0, l1 = math.log(g0), math.log(g1)
    if not (math.isfinite(y0) and math.isfinite(y1)):
        return math.exp(0.5 * (l0 + l1))
    t = (target - y0) / (y1 - y0)
    return math.exp(l0 + t * (l1 - l0))


def _slope(points: pd.DataFrame, gamma: float, width: float, column: str, target: float):
    """(dA/dγ, dlnA/dlnγ, points used) from a least-squares cubic in ln γ through the LCOs
    within ``width`` (in ln γ) of ``gamma`` (NaN with fewer than 5 points)."""
    sel = points[(points["status"] == "lco")
                 & (np.abs(np.log(points["gamma"]) - math.log(gamma)) <= width)]
    if len(sel) < 5:
        return math.nan, math.nan, len(sel)
    x = np.log(sel["gamma"].to_numpy()) - math.log(gamma)
    c = np.polynomial.polynomial.polyfit(x, sel[column].to_numpy(dtype=float), 3)
    return c[1] / gamma, c[1] / target, len(sel)


def _newton_rounds(run, points, active, target: float, rtol: float, max_rounds: int,
                   derivative: str, log) -> tuple[list, int]:
    """Newton on γ inside every bracket with the evaluated derivative column (harmonic balance
    with ``[hb] sensitivity``: dA/dγ by the implicit-function theorem, one extra linear solve
    per case): γ ← γ − (A − target) / (dA/dγ) from the bracket end closest to the target,
    kept inside the bracket (else its log-midpoint), one batch per round. A bracket is done
    when its point is within ``rtol``/10 of the target (Newton converges quadratically: one
    more round costs little); it then collapses to that γ."""
    rounds = 0
    while rounds < max_rounds:
        todo, requests = [], []
        done = []
        for b, gl, gh in active:
            p = points(b)
            p = p[(p["gamma"] >= gl) & (p["gamma"] <= gh) & (p["status"] == "lco")]
            if p.empty:
                done.append((b, gl, gh))
                continue
            best = p.iloc[int(np.argmin(np.abs(p["response"].to_numpy() - target)))]
            if abs(best["response"] / target - 1) <= 0.1 * rtol:
                done.append((b, float(best["gamma"]), float(best["gamma"])))
                continue
            slope = float(best[derivative])
            g = float(best["gamma"]) - (float(best["response"]) - target) / slope \
                if np.isfinite(slope) and slope != 0 else math.nan
            if not (gl < g < gh):
                g = math.sqrt(gl * gh)
            todo.append((b, gl, gh))
            requests.append((b, g))
        if not requests:
            return done, rounds
        rounds += 1
        log(f"calibrate: Newton round {rounds}: {len(requests)} case(s)")
        run(requests, rounds)
        for (b, gl, gh), (_, g) in zip(todo, requests):
            p = points(b)
            y = float(p.loc[p["gamma"] == g, "response"].iloc[0])
            yl = float(p.loc[p["gamma"] == gl, "response"].iloc[0])
            if not np.isfinite(y):
                done.append((b, gl, gh))
            elif (y - target) * (yl - target) <= 0:
                done.append((b, gl, g))
            else:
                done.append((b, g, gh))
        active = done
    return active, rounds


def calibrate_gamma(evaluate: Evaluate, base_cases: Sequence[dict[str, Any]], target: float, *,
                    gamma_range: tuple[float, float], column: str = "amplitude", num: int = 16,
                    rtol: float = 2e-3, max_rounds: int = 6,
                    alpha_for_gamma: Callable[[float], float] | None = None,
                    verify: bool = True,
                    log: Callable[[str], None] | None = None) -> CalibrationResult:
    """γ giving ``target`` (in the units of ``column``) for every base case; see the module
    docstring. Returns a :class:`CalibrationResult` whose table has, per base case and root,
    the base parameters, ``target``, ``gamma``, ``gamma_low``/``gamma_high`` (final bracket),
    ``alpha`` (the α used at γ̂), ``damplitude_dgamma`` (output units per s),
    ``sensitivity`` (dlnA/dlnγ), ``slope_points``, ``rounds``, ``roots`` and ``status``
    ('ok', or 'not bracketed' with the range of the response in ``note``). With ``verify``
    every γ̂ is simulated once more (one batch): ``check_status``, ``check_value`` (the
    response there) and ``check_error`` (its relative deviation from the target)."""
    lo, hi = (float(x) for x in gamma_range)
    if not (0 < lo < hi and math.isfinite(hi)):
        raise InputError(f"gamma range: expected 0 < low < high, got {gamma_range}")
    if not (target > 0 and math.isfinite(target)):
        raise InputError(f"target: expected a positive amplitude, got {target}")
    if num < 3:
        raise InputError(f"num: expected at least 3 values of gamma per batch, got {num}")
    log = log or (lambda _m: None)
    base_cases = [dict(b) for b in base_cases]

    evaluated: list[pd.DataFrame] = []

    def run(requests: list[tuple[int, float]], round_no: int) -> None:
        cases = []
        for b, gamma in requests:
            case = {**base_cases[b], "gamma": float(gamma)}
            if alpha_for_gamma is not None:
                case["alpha"] = float(alpha_for_gamma(gamma))
            cases.append(case)
        table = evaluate(cases).reset_index(drop=True)
        if column not in table.columns:
            raise InputError(f"column {column!r}: not in the results table; it has "
                             f"{list(table.columns)}")
        table["base_case"] = [b for b, _ in requests]
        table["gamma"] = [float(g) for _, g in requests]
        table["round"] = round_no
        table["response"] = response(table, column)
        evaluated.append(table)

    def points(b: int) -> pd.DataFrame:
        allp = pd.concat(evaluated, ignore_index=True)
        return allp[allp["base_case"] == b].sort_values("gamma").drop_duplicates("gamma")

    scan = np.geomspace(lo, hi, num)
    log(f"calibrate: scanning {num} values of gamma in [{lo:g}, {hi:g}] for {len(base_cases)} "
        f"base case(s)")
    run([(b, g) for b in range(len(base_cases)) for g in scan], 0)
    step = math.log(hi / lo) / (num - 1)
    # active brackets: (base case, gamma_low, gamma_high)
    active = []
    for b in range(len(base_cases)):
        p = points(b)
        g, y = p["gamma"].to_numpy(), p["response"].to_numpy()
        active += [(b, g[i], g[j]) for i, j in _brackets(g, y, target)]
    rounds = 0
    derivative = f"{column}_dgamma"
    if any(derivative in t.columns for t in evaluated):
        active, rounds = _newton_rounds(run, points, active, target, rtol, max_rounds,
                                        derivative, log)
    while rounds < max_rounds and any(gh / gl - 1 > rtol for _, gl, gh in active):
        rounds += 1
        requests = [(b, x) for b, gl, gh in active if gh / gl - 1 > rtol
                    for x in np.geomspace(gl, gh, num + 2)[1:-1]]
        log(f"calibrate: round {rounds}: {len(requests)} cases in "
            f"{sum(gh / gl - 1 > rtol for _, gl, gh in active)} bracket(s)")
        run(requests, rounds)
        refined = []
        for b, gl, gh in active:
            if gh / gl - 1 <= rtol:
                refined.append((b, gl, gh))
                continue
            p = points(b)
            p = p[(p["gamma"] >= gl) & (p["gamma"] <= gh)]
            g, y = p["gamma"].to_numpy(), p["response"].to_numpy()
            inner = _brackets(g, y, target)
            # noise can make several sign changes inside a tiny bracket: keep the first
            refined.append((b, g[inner[0][0]], g[inner[0][1]]) if inner else (b, gl, gh))
        active = refined

    rows = []
    for b, base in enumerate(base_cases):
        mine = [(gl, gh) for bb, gl, gh in active if bb == b]
        p = points(b)
        if not mine:
            finite = p["response"].dropna()
            note = (f"response from {finite.min():.4g} to {finite.max():.4g} for gamma in "
                    f"[{lo:g}, {hi:g}]" if len(finite) else "no decided case")
            rows.append({**base, "base_case": b, "target": target, "status": "not bracketed",
                         "roots": 0, "rounds": rounds, "note": note})
            continue
        for gl, gh in mine:
            yl = float(p.loc[p["gamma"] == gl, "response"].iloc[0])
            yh = float(p.loc[p["gamma"] == gh, "response"].iloc[0])
            gamma = _interpolate(gl, gh, yl, yh, target)
            dadg, sens, used = _slope(p, gamma, 0.5 * step, column, target)
            exact = p[(p["gamma"] == gl) | (p["gamma"] == gh)]
            if derivative in p.columns and gl == gh and np.isfinite(
                    exact[derivative].to_numpy(dtype=float)).all():
                # a Newton root: the implicit-function derivative at the root itself
                dadg = float(exact[derivative].iloc[0])
                sens, used = dadg * gamma / target, 1
            alpha = float(alpha_for_gamma(gamma)) if alpha_for_gamma else base.get("alpha")
            rows.append({**base, "base_case": b, "target": target, "gamma": gamma,
                         "gamma_low": gl, "gamma_high": gh, "alpha": alpha,
                         "damplitude_dgamma": dadg, "sensitivity": sens, "slope_points": used,
                         "rounds": rounds, "roots": len(mine), "status": "ok", "note": ""})
    table = pd.DataFrame(rows)
    found = [i for i, r in enumerate(rows) if r["status"] == "ok"]
    if verify and found:
        log(f"calibrate: verifying {len(found)} root(s)")
        run([(rows[i]["base_case"], rows[i]["gamma"]) for i in found], rounds + 1)
        check = evaluated[-1]
        table.loc[found, "check_status"] = check["status"].to_numpy()
        table.loc[found, "check_value"] = check["response"].to_numpy()
        table.loc[found, "check_error"] = check["response"].to_numpy() / target - 1.0
    return CalibrationResult(table, pd.concat(evaluated, ignore_index=True))
