"""The paper's stated findings (DIGEST Sec. 9) checked one by one against our tables.

Each check returns a :class:`Finding`: what the paper says, what our numbers say, a verdict
("agree", "differ" or "not assessable" — e.g. when a case needed for it did not reach a converged
LCO) and the numbers behind it. Amplitudes are compared only between cases whose status is
``lco``. The three acceptance checks of Fig. 10 are :func:`gamma_small_matches_zero`,
:func:`amplitude_not_increasing_with_gamma` and :func:`stiffness_matters_little_at_large_gamma`.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from ..reference import paper_reference

#: the γ values (s) of the paper's Fig. 10 curves with both nonlinearities
PAPER_GAMMAS = paper_reference().gammas_s
AGREE, DIFFER, NA = "agree", "differ", "not assessable"


@dataclass
class Finding:
    """One paper statement against our results."""

    key: str
    figure: str
    paper: str
    ours: str
    verdict: str
    numbers: dict[str, Any] = field(default_factory=dict)
    acceptance: bool = False

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _flags(t: pd.DataFrame) -> pd.DataFrame:
    t = t.copy()
    for k, default in (("stiffness_nl", 1.0), ("damping_nl", 1.0), ("gamma", 0.0)):
        t[k] = t[k].astype(float).fillna(default) if k in t else default
    return t


def curve_table(table: pd.DataFrame, column: str = "amplitude", lco_only: bool = True
                ) -> pd.DataFrame:
    """``column`` by altitude (rows) and curve (columns: the γ values with both nonlinearities,
    and "1e-3 only" for γ = 1e-3 without stiffness nonlinearity); NaN where a case is missing or
    (``lco_only``) did not reach a converged LCO."""
    t = _flags(table)
    if lco_only:
        t = t[t["status"] == "lco"]
    out = {}
    for g in PAPER_GAMMAS:
        sel = t[(t["gamma"] == g) & (t["stiffness_nl"] == 1) & ((t["damping_nl"] == 1) | (g == 0))]
        out[g] = sel.groupby("altitude_ft")[column].first()
    sel = t[(t["gamma"] == 1e-3) & (t["stiffness_nl"] == 0) & (t["damping_nl"] == 1)]
    out["1e-3 only"] = sel.groupby("altitude_ft")[column].first()
    alts = sorted(_flags(table)["altitude_ft"].unique())
    return pd.DataFrame(out).reindex(alts)


def _curves_dict(C: pd.DataFrame) -> dict[str, dict[float, float]]:
    """A :func:`curve_table` as JSON-ready {curve: {altitude: value}} without the gaps."""
    return {str(k): {float(h): float(v) for h, v in C[k].dropna().items()} for k in C.columns}


def _fmt_pct(x: float) -> str:
    return "n/a" if not np.isfinite(x) else f"{100 * x:+.1f} %"


def _verdict(ok: list[bool], assessable: int) -> str:
    if assessable == 0:
        return NA
    return AGREE if all(ok) else DIFFER


def gamma_small_matches_zero(table: pd.DataFrame, tol: float = 0.02) -> Finding:
    """Fig. 10: the γ = 1e-5 curve coincides with γ = 0 (within ``tol`` at every altitude)."""
    A = curve_table(table)
    rel = (A[1e-5] / A[0.0] - 1.0).dropna()
    exist = curve_table(table, "status", lco_only=False)[[0.0, 1e-5]].dropna().index
    ok = [abs(r) <= tol for r in rel]
    worst = float(rel.abs().max()) if len(rel) else float("nan")
    return Finding(
        "gamma_1e-5_equals_0", "Fig. 10", "γ = 1e-5 s coincides with γ = 0 (NL stiff only)",
        f"largest relative difference {_fmt_pct(worst)} over {len(rel)} altitudes with LCOs "
        f"in both (tolerance {tol:.0%})", _verdict(ok, len(rel)),
        {"relative_difference": {float(k): float(v) for k, v in rel.items()},
         "altitudes_without_both_lcos": [float(h) for h in exist if h not in rel.index]},
        acceptance=True)


def amplitude_not_increasing_with_gamma(table: pd.DataFrame, tol: float = 0.005) -> Finding:
    """Fig. 10: at each altitude the amplitude does not grow with γ (by more than ``tol``)."""
    A = curve_table(table)
    steps, bad = [], []
    for h in A.index:
        for g0, g1 in zip(PAPER_GAMMAS[:-1], PAPER_GAMMAS[1:]):
            a0, a1 = A.loc[h, g0], A.loc[h, g1]
            if np.isfinite(a0) and np.isfinite(a1):
                r = float(a1 / a0 - 1.0)
                steps.append((float(h), g0, g1, r))
                if r > tol:
                    bad.append((float(h), g0, g1, r))
    worst = max((s[3] for s in steps), default=float("nan"))
    ours = (f"{len(bad)} of {len(steps)} consecutive-γ steps increase the amplitude by more than "
            f"{tol:.1%} (largest change {_fmt_pct(worst)})")
    if bad:
        h, g0, g1, r = max(bad, key=lambda s: s[3])
        ours += f"; largest increase at {h:,.0f} ft from γ = {g0:g} to {g1:g} s"
    return Finding(
        "amplitude_decreases_with_gamma", "Fig. 10",
        "the LCO amplitude decreases as γ increases (slowly, then sharply for γ ≥ 5e-4 s)", ours,
        _verdict([s[3] <= tol for s in steps], len(steps)),
        {"steps": [{"altitude_ft": h, "gamma_from": g0, "gamma_to": g1, "relative_change": r}
                   for h, g0, g1, r in steps]}, acceptance=True)


def stiffness_matters_little_at_large_gamma(table: pd.DataFrame) -> Finding:
    """Fig. 10: γ = 1e-3 with and without stiffness nonlinearity differ by less than the change
    from γ = 5e-4 to γ = 1e-3."""
    A = curve_table(table)
    rows = []
    for h in A.index:
        both, only, half = A.loc[h, 1e-3], A.loc[h, "1e-3 only"], A.loc[h, 5e-4]
        if np.isfinite(both) and np.isfinite(only) and np.isfinite(half):
            rows.append({"altitude_ft": float(h), "with_minus_without": float(both - only),
                         "gamma_5e-4_to_1e-3": float(both - half)})
    ok = [abs(r["with_minus_without"]) < abs(r["gamma_5e-4_to_1e-3"]) for r in rows]
    ours = "; ".join(f"{r['altitude_ft']:,.0f} ft: {r['with_minus_without']:+.3f} vs "
                     f"{r['gamma_5e-4_to_1e-3']:+.3f} ft" for r in rows) or "no altitude with all "\
        "three LCOs"
    return Finding(
        "stiffness_nl_small_at_gamma_1e-3", "Fig. 10",
        "for γ = 1e-3 s the stiffness nonlinearity matters little: 'γ = 1e-3' and 'γ = 1e-3 only' "
        "are close (closer than γ = 5e-4 to γ = 1e-3)",
        "amplitude with minus without stiffness NL vs change from γ = 5e-4 to 1e-3: " + ours,
        _verdict(ok, len(rows)), {"rows": rows}, acceptance=True)


def slow_then_sharp_decrease(table: pd.DataFrame) -> Finding:
    """Fig. 10: 1e-5 -> 1e-4 decreases ≈10 % at high altitudes, ≈0 at 4,000 ft; γ ≥ 5e-4 sharp."""
    A = curve_table(table)
    slow = (A[1e-4] / A[1e-5] - 1.0).dropna()
    sharp = (A[1e-3] / A[1e-4] - 1.0).dropna()
    numbers = {"change_1e-5_to_1e-4": {float(k): float(v) for k, v in slow.items()},
               "change_1e-4_to_1e-3": {float(k): float(v) for k, v in sharp.items()}}
    paper = ("from γ = 1e-5 to 1e-4 s the amplitude decreases by about 10 % at higher altitudes "
             "and almost not at 4,000 ft; for γ ≥ 5e-4 s it drops sharply at all altitudes")
    if len(slow) < 2 or len(sharp) == 0:
        return Finding("slow_then_sharp", "Fig. 10", paper,
                       f"too few altitudes with LCOs for γ = 1e-5, 1e-4 and 1e-3 s "
                       f"({len(slow)} with both 1e-5 and 1e-4)", NA, numbers)
    lo, hi = slow.index.min(), slow.index.max()
    ok = (-0.2 <= slow[hi] <= -0.03) and abs(slow[lo]) < abs(slow[hi]) and (sharp < -0.2).all()
    ours = (f"1e-5 -> 1e-4: {_fmt_pct(slow[lo])} at {lo:,.0f} ft, {_fmt_pct(slow[hi])} at "
            f"{hi:,.0f} ft; 1e-4 -> 1e-3: {_fmt_pct(sharp.max())} to {_fmt_pct(sharp.min())}")
    return Finding("slow_then_sharp", "Fig. 10", paper, ours, AGREE if ok else DIFFER, numbers)


def amplitude_range(table: pd.DataFrame) -> Finding:
    """Conclusions: LCO amplitudes from below 1 % of span to significant fractions of it."""
    t = table[table["status"] == "lco"]
    if t.empty or "amplitude_pct_span" not in t:
        return Finding("amplitude_range", "Fig. 10", "LCO amplitudes range from below 1 % of "
                       "span to significant fractions of the span", "no converged LCO", NA)
    lo, hi = float(t["amplitude_pct_span"].min()), float(t["amplitude_pct_span"].max())
    return Finding(
        "amplitude_range", "Fig. 10",
        "LCO amplitudes range from below 1 % of span to significant fractions of the span",
        f"converged LCO amplitudes from {lo:.2f} % to {hi:.2f} % of span",
        AGREE if lo < 1.0 and hi > 5.0 else DIFFER, {"min_pct_span": lo, "max_pct_span": hi})


def damping_alone_gives_lco(table: pd.DataFrame, flutter_altitude: float) -> Finding:
    """Conclusions/Fig. 10: nonlinear damping alone turns flutter into a supercritical LCO."""
    t = _flags(table)
    sel = t[(t["gamma"] > 0) & (t["stiffness_nl"] == 0) & (t["damping_nl"] == 1)]
    sel = sel[sel["altitude_ft"] < flutter_altitude].sort_values("altitude_ft")
    if sel.empty:
        return Finding("damping_alone_lco", "Fig. 10", "nonlinear damping alone turns flutter "
                       "into a supercritical LCO", "no damping-only case", NA)
    n_lco = int((sel["status"] == "lco").sum())
    amp = sel[sel["status"] == "lco"]["amplitude_pct_span"].to_numpy()
    grows_away = bool(len(amp) < 2 or np.all(np.diff(amp) <= 0))
    return Finding(
        "damping_alone_lco", "Fig. 10",
        "nonlinear damping alone (no stiffness nonlinearity) turns flutter into a supercritical "
        "LCO", f"{n_lco} of {len(sel)} damping-only cases below the flutter altitude reach an "
        f"LCO ({amp.min():.2f} to {amp.max():.2f} % of span), amplitude "
        f"{'shrinking' if grows_away else 'not monotone'} towards the flutter altitude"
        if len(amp) else f"none of {len(sel)} damping-only cases reaches an LCO",
        AGREE if n_lco == len(sel) and grows_away else DIFFER,
        {"cases": len(sel), "lco": n_lco})


def _lowest_common(C: pd.DataFrame, keys) -> float | None:
    """The lowest altitude where every curve of ``keys`` has a value."""
    rows = C[list(keys)].dropna()
    return float(rows.index.min()) if len(rows) else None


def frequency_trends(table: pd.DataFrame) -> Finding:
    """Fig. 12: frequency decreases with decreasing altitude and increasing γ, except γ = 1e-3
    near 4,000 ft where it rises relative to γ = 5e-4."""
    F = curve_table(table, "frequency_hz")
    alt_ok = [bool(np.all(np.diff(F[g].dropna().to_numpy()) > 0))
              for g in PAPER_GAMMAS if F[g].notna().sum() >= 2]
    low = _lowest_common(F, (5e-4, 1e-3))
    gam = [(float(h), bool(np.all(np.diff(F.loc[h, list(PAPER_GAMMAS)].dropna().to_numpy())
                                  <= 0)))
           for h in F.index if F.loc[h, list(PAPER_GAMMAS)].notna().sum() >= 2]
    ours = (f"frequency increases with altitude on {sum(alt_ok)} of {len(alt_ok)} curves; "
            f"decreases with γ at {sum(ok for _, ok in gam)} of {len(gam)} altitudes")
    rise = None
    if low is not None:
        rise = float(F.loc[low, 1e-3] - F.loc[low, 5e-4])
        ours += f"; at {low:,.0f} ft (lowest with both) f(1e-3) − f(5e-4) = {rise:+.4f} Hz"
    else:
        ours += "; no altitude with LCOs at both γ = 5e-4 and 1e-3 s (exception not assessable)"
    # the trend with γ is judged away from the lowest altitude, where the paper has its exception
    main = all(alt_ok) and all(ok for h, ok in gam if h != low)
    ok = main and (rise is None or rise > 0)
    return Finding(
        "frequency_trends", "Fig. 12",
        "the LCO frequency decreases with decreasing altitude and with increasing γ, except "
        "γ = 1e-3 s around 4,000 ft where it rises relative to γ = 5e-4 s", ours,
        _verdict([ok], len(alt_ok) + len(gam)),
        {"by_altitude_increasing": alt_ok, "by_gamma_decreasing": gam,
         "low_altitude": low, "low_altitude_rise_hz": rise,
         "frequency_hz": _curves_dict(F)})


def ratio_trends(table: pd.DataFrame, mode_kinds: list[str] | None = None,
                 q4_column: str = "ratio_q1_q4", q4_note: str | None = None) -> Finding:
    """Fig. 13: q1/q2 grows as altitude decreases and γ increases; at ~4,000 ft more mode 4 at
    γ = 1e-3 than at 5e-4 (q1/q4 smaller). ``q4_column``: the ratio of q1 to our mode matched
    to the paper's mode 4 (:mod:`.modes`), ``q4_note`` says which."""
    R2 = curve_table(table, "ratio_q1_q2")
    R4 = curve_table(table, q4_column)
    q4 = q4_column.replace("ratio_", "").replace("_", "/")
    alt_ok = [bool(np.all(np.diff(R2[g].dropna().to_numpy()) < 0))
              for g in PAPER_GAMMAS if R2[g].notna().sum() >= 2]
    gam_ok = [bool(np.all(np.diff(R2.loc[h, list(PAPER_GAMMAS)].dropna().to_numpy()) >= 0))
              for h in R2.index if R2.loc[h, list(PAPER_GAMMAS)].notna().sum() >= 2]
    low = _lowest_common(R4, (5e-4, 1e-3))
    ours = (f"q1/q2 grows as altitude decreases on {sum(alt_ok)} of {len(alt_ok)} curves and "
            f"as γ increases at {sum(gam_ok)} of {len(gam_ok)} altitudes")
    mode4 = None
    if low is not None:
        mode4 = bool(R4.loc[low, 1e-3] < R4.loc[low, 5e-4])
        ours += (f"; at {low:,.0f} ft {q4} is {R4.loc[low, 1e-3]:.3g} (γ = 1e-3) vs "
                 f"{R4.loc[low, 5e-4]:.3g} (5e-4)")
    if q4_note:
        ours += f" ({q4_note})"
    elif mode_kinds is not None and len(mode_kinds) >= 4:
        ours += f" (our mode 4 is {mode_kinds[3]}; the paper's is bending–torsion)"
    ok = all(alt_ok) and all(gam_ok) and mode4 is not False
    return Finding(
        "ratio_trends", "Fig. 13",
        "q1/q2 typically grows as the altitude decreases and γ increases; the low-altitude "
        "frequency rise at γ = 1e-3 s comes with more mode-4 participation (smaller q1/q4)", ours,
        _verdict([ok], len(alt_ok) + len(gam_ok)),
        {"low_altitude": low, "more_mode4_at_low_altitude": mode4,
         "q1_q2": _curves_dict(R2), "q1_q4": _curves_dict(R4)})


def linear_statuses(table: pd.DataFrame, flutter_altitude: float) -> Finding:
    """Our check (acceptance): with γ = 0 and no stiffness nonlinearity the system is linear; no
    case below the flutter altitude may reach an LCO (it diverges past the cap) and every case
    above it decays."""
    t = _flags(table)
    sel = t[(t["gamma"] == 0) & (t["stiffness_nl"] == 0)].sort_values("altitude_ft")
    below = sel[sel["altitude_ft"] < flutter_altitude]
    above = sel[sel["altitude_ft"] > flutter_altitude]
    ok_below = bool((below["status"] == "diverged").all())
    ok_above = bool((above["status"] == "decay").all())
    ours = (f"below {flutter_altitude:,.0f} ft: " + ", ".join(
        f"{h:,.0f} {s}" for h, s in zip(below["altitude_ft"], below["status"])) +
        "; above: " + ", ".join(f"{h:,.0f} {s}" for h, s in zip(above["altitude_ft"],
                                                               above["status"])))
    return Finding(
        "linear_statuses", "check",
        "(our check) the linear system (γ = 0, no stiffness nonlinearity) flutters below the "
        "flutter altitude without an LCO and decays above it", ours,
        _verdict([ok_below and ok_above], len(sel)), {"below": below["status"].tolist(),
                                                       "above": above["status"].tolist()},
        acceptance=True)


def steps_to_converge(table: pd.DataFrame, marches_time: bool = True) -> Finding:
    """Sec. IV: amplitudes converged after 20,000–40,000 time steps (dt = 0.001 s). Only a
    time-marching table (``marches_time``) can say: a periodic solver's ``steps`` are Newton
    iterations on the orbit, not the transient the paper counts."""
    if not marches_time:
        return Finding("steps", "Sec. IV", "the amplitude converged after 20,000–40,000 time "
                       "steps of 0.001 s", "needs the paper's time marching (`torchrom paper "
                       "--method newmark`): the periodic solver computes the orbit, not the "
                       "transient to it", NA)
    t = table[table["status"] == "lco"]
    if t.empty:
        return Finding("steps", "Sec. IV", "the amplitude converged after 20,000–40,000 time "
                       "steps", "no converged LCO", NA)
    lo, hi, med = int(t["steps"].min()), int(t["steps"].max()), float(t["steps"].median())
    return Finding(
        "steps", "Sec. IV", "the amplitude converged after 20,000–40,000 time steps of 0.001 s",
        f"{lo:,} to {hi:,} steps (median {med:,.0f}) over {len(t)} converged LCOs",
        AGREE if 10_000 <= med <= 60_000 else DIFFER, {"min": lo, "max": hi, "median": med})


def harmonic_lco(histories: pd.DataFrame, table: pd.DataFrame, output: str = "A_Tz",
                 periods: int = 6) -> Finding:
    """Fig. 11: the converged LCO is very harmonic (total harmonic distortion of the last
    ``periods`` periods of point A, from an FFT over a whole number of periods)."""
    rows = table[table["case_id"].isin(set(histories["case_id"]))]
    out = []
    for r in rows.itertuples():
        h = histories[histories["case_id"] == r.case_id].sort_values("t")
        f = float(r.frequency_hz)
        if r.status != "lco" or not np.isfinite(f) or f <= 0:
            continue
        t, y = h["t"].to_numpy(), h[output].to_numpy()
        keep = t >= t[-1] - periods / f
        t, y = t[keep], y[keep] - y[keep].mean()
        n = len(y)
        if n < 16:  # a history that stopped early (a run decided at once): nothing to judge
            continue
        spec = np.abs(np.fft.rfft(y * np.hanning(n)))
        freqs = np.fft.rfftfreq(n, t[1] - t[0])
        k1 = int(np.argmin(np.abs(freqs - f)))
        fund = spec[max(k1 - 2, 0):k1 + 3]
        total = np.sqrt(np.sum(spec**2))
        thd = float(np.sqrt(max(total**2 - np.sum(fund**2), 0.0)) / np.sqrt(np.sum(fund**2)))
        out.append({"case_id": r.case_id, "stiffness_nl": float(r.stiffness_nl),
                    "damping_nl": float(r.damping_nl), "thd": thd})
    if not out:
        return Finding("harmonic_lco", "Fig. 11", "the converged LCO of point A is very harmonic",
                       "no converged LCO with a history", NA)
    worst = max(o["thd"] for o in out)
    return Finding(
        "harmonic_lco", "Fig. 11", "the converged LCO of point A is very harmonic",
        f"total harmonic distortion of point A over the last {periods} periods at most "
        f"{100 * worst:.2f} % ({len(out)} cases)", AGREE if worst < 0.05 else DIFFER,
        {"cases": out})


def alpha_decreases_with_gamma(alpha_gamma: pd.DataFrame) -> Finding:
    """Fig. 9: the matched α decreases as γ increases."""
    t = alpha_gamma.sort_values("gamma")
    d = np.diff(t["alpha"].to_numpy())
    return Finding(
        "alpha_decreases", "Fig. 9",
        "keeping the flutter altitude, α decreases as γ increases",
        f"α from {t['alpha'].iloc[0]:.4f} 1/s at γ = {t['gamma'].iloc[0]:g} s to "
        f"{t['alpha'].iloc[-1]:.4f} 1/s at γ = {t['gamma'].iloc[-1]:g} s, "
        f"{'monotone' if np.all(d < 0) else 'not monotone'}",
        AGREE if np.all(d < 0) else DIFFER,
        {"alpha": t["alpha"].tolist(), "gamma": t["gamma"].tolist()})


def fig10_acceptance(table: pd.DataFrame) -> list[Finding]:
    """The three Fig. 10 findings the issue accepts on, e.g. for the damping cause check."""
    return [gamma_small_matches_zero(table), amplitude_not_increasing_with_gamma(table),
            stiffness_matters_little_at_large_gamma(table)]


def evaluate(table: pd.DataFrame, histories: pd.DataFrame | None, alpha_gamma: pd.DataFrame,
             flutter_altitude: float, mode_kinds: list[str] | None = None,
             q4_column: str = "ratio_q1_q4", q4_note: str | None = None,
             marches_time: bool = True) -> list[Finding]:
    """Every finding, in the order of the report (``q4_column``, ``q4_note``: see
    :func:`ratio_trends`; ``marches_time``: the table comes from time marching, see
    :func:`steps_to_converge`)."""
    out = [alpha_decreases_with_gamma(alpha_gamma),
           gamma_small_matches_zero(table),
           amplitude_not_increasing_with_gamma(table),
           slow_then_sharp_decrease(table),
           stiffness_matters_little_at_large_gamma(table),
           amplitude_range(table),
           damping_alone_gives_lco(table, flutter_altitude),
           steps_to_converge(table, marches_time)]
    if histories is not None and len(histories):
        out.append(harmonic_lco(histories, table))
    else:  # a sweep without histories (the other wing variant by harmonic balance)
        out.append(Finding("harmonic_lco", "Fig. 11", "the converged LCO of point A is very "
                           "harmonic", "no time history in this sweep", NA))
    out += [frequency_trends(table), ratio_trends(table, mode_kinds, q4_column, q4_note),
            linear_statuses(table, flutter_altitude)]
    return out
