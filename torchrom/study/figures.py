"""The paper's figures (Figs. 9–13) from result tables (matplotlib, Agg backend), atomically.

Each function takes the tables a sweep wrote and draws one figure of paper Sec. IV:

- :func:`fig9`  α vs γ at constant flutter altitude (table with columns gamma, alpha);
- :func:`fig10` LCO amplitude of point A vs altitude, ft and % of span, one curve per damping
  setting (γ, stiffness and damping nonlinearity switches);
- :func:`fig11` time histories of point A for the cases of one altitude (full and a zoom on the
  converged LCO), from ``histories.parquet`` and the results table;
- :func:`fig12` LCO frequency vs altitude;
- :func:`fig13` amplitude ratios of the generalized coordinates q1/q2 and q1/q4 vs altitude.

A *curve* is a group of cases with the same (γ, stiffness_nl, damping_nl); curves with a single
altitude (e.g. the extra Fig. 11 cases) are left out of the altitude plots. Markers show each
case's status (filled: converged LCO). Hand-written layout; drawing delegated to matplotlib.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..io import atomic_path, check_can_write

#: marker per status: settled LCOs filled, everything else hollow or crossed
MARKERS = {"lco": ("o", True), "decay": ("v", False), "unconverged": ("s", False),
           "diverged": ("^", False), "failed": ("x", True)}
CURVE_KEYS = ("gamma", "stiffness_nl", "damping_nl")


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _require(table: pd.DataFrame, columns, figure: str) -> None:
    missing = [c for c in columns if c not in table.columns]
    if missing:
        raise InputError(f"plot {figure}: the table has no column {missing[0]!r} (columns: "
                         f"{list(table.columns)})")


def _save(fig, path, force: bool) -> Path:
    path = check_can_write(path, force, "figure")
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=130, format=Path(path).suffix.lstrip(".") or "png")
    _plt().close(fig)
    return Path(path)


def curve_label(gamma: float, stiffness_nl: float, damping_nl: float) -> str:
    """The paper's legend for a damping setting (Figs. 10, 12, 13)."""
    g = f"γ = {gamma:.0e} s".replace("e-0", "e-")
    if gamma == 0 or damping_nl == 0 and stiffness_nl != 0:
        return "NL stiff only (γ = 0)" if gamma == 0 else f"{g}, NL stiffness only"
    if stiffness_nl == 0:
        return f"{g} only (no stiffness NL)"
    return g


def curves(table: pd.DataFrame, x: str = "altitude_ft", min_points: int = 2):
    """[(label, rows sorted by x)] per damping setting with at least ``min_points`` x values
    (the linear system, without any nonlinearity, is left out), in the order: increasing γ,
    settings with both nonlinearities first."""
    _require(table, (x, *CURVE_KEYS), "curves")
    t = table.copy()
    for k in ("stiffness_nl", "damping_nl"):
        t[k] = t[k].astype(float)
    out = []
    for key, grp in t.groupby(list(CURVE_KEYS), sort=False):
        g, s, d = (float(v) for v in key)
        if grp[x].nunique() < min_points or (s == 0 and (d == 0 or g == 0)):
            continue  # a single point, or the linear system (it has no LCO to show)
        out.append(((g, -s, -d), curve_label(g, s, d), grp.sort_values(x)))
    return [(label, grp) for _, label, grp in sorted(out, key=lambda c: c[0])]


def _status_legend(plt, table: pd.DataFrame) -> list:
    names = {"diverged": "diverged (drawn at the top)", "failed": "failed (drawn at the top)",
             "unconverged": "unconverged (value when stopped)", "lco": "converged LCO"}
    return [plt.Line2D([], [], marker=m, ls="none", color="0.3", mfc="0.3" if f else "none",
                       label=names.get(s, s)) for s, (m, f) in MARKERS.items()
            if (table["status"] == s).any()]


def _curve_axes(ax, table: pd.DataFrame, y: str, x: str = "altitude_ft"):
    """One line per curve through its converged LCOs, status markers on every case; cases that
    diverged or failed are drawn at the top of the axis (their values are off any useful scale)."""
    last = f"last_{y}" if f"last_{y}" in table else y  # an unconverged case's value when stopped
    drawn = pd.concat([table[table["status"].isin(["lco", "decay"])][y],
                       table[table["status"] == "unconverged"][last]])
    drawn = drawn[np.isfinite(drawn)]
    top = float(drawn.max()) * 1.08 if len(drawn) else 1.0
    for label, grp in curves(table, x):
        ok = grp[grp["status"] == "lco"]
        (line,) = ax.plot(ok[x], ok[y], "-", lw=1.4, label=label)
        for status, (marker, filled) in MARKERS.items():
            sel = grp[grp["status"] == status]
            if len(sel):
                vals = (sel[y] if status in ("lco", "decay") else sel[last]
                        if status == "unconverged" else np.full(len(sel), top))
                ax.plot(sel[x], vals, marker, ms=5, color=line.get_color(),
                        mfc=line.get_color() if filled else "none", ls="none")
    ax.grid(alpha=0.3)


def _title(table: pd.DataFrame, what: str) -> str:
    mach = table["mach"].iloc[0] if "mach" in table and len(table) else None
    return f"{what}, Mach {mach:.2f}" if mach is not None and np.isfinite(mach) else what


def fig9(table: pd.DataFrame, path, *, force: bool = False, reference_altitude=None) -> Path:
    """α (1/s) vs γ (s) that keep the flutter altitude constant (paper Fig. 9)."""
    _require(table, ("gamma", "alpha"), "fig9")
    t = table.drop_duplicates(["gamma", "alpha"]).sort_values("gamma")
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.0, 4.2), constrained_layout=True)
    h = reference_altitude
    if h is None and "reference_altitude_ft" in t:
        h = float(t["reference_altitude_ft"].iloc[0])
    label = "α(γ) keeping the flutter altitude" + (f" at {h:,.0f} ft" if h is not None else "")
    ax.plot(t["gamma"], t["alpha"], "o-", ms=4, lw=1.4, label=label)
    if {"baseline_gamma", "baseline_alpha"} <= set(t.columns):
        ax.plot(t["baseline_gamma"].iloc[0], t["baseline_alpha"].iloc[0], "k*", ms=11,
                label=f"FE Rayleigh damping α0 = {t['baseline_alpha'].iloc[0]:g} 1/s, "
                      f"β0 = {t['baseline_gamma'].iloc[0]:g} s")
    ax.set_xlabel("γ (s)")
    ax.set_ylabel("α (1/s)")
    ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, -3))
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(_title(table, "Fig. 9: damping parameter α vs γ"), fontsize=10)
    return _save(fig, path, force)


def _altitude_figure(table: pd.DataFrame, path, y: str, ylabel: str, title: str, force: bool,
                     decorate: Callable | None = None) -> Path:
    """A Fig. 10 / 12-style figure: ``y`` of every curve against the altitude."""
    _require(table, ("altitude_ft", y, "status", *CURVE_KEYS), title.split(":")[0])
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7.0, 4.8), constrained_layout=True)
    _curve_axes(ax, table, y)
    ax.set_xlabel("altitude (ft)")
    ax.set_ylabel(ylabel)
    if decorate is not None:
        decorate(ax)
    ax.legend(handles=ax.get_legend_handles_labels()[0] + _status_legend(plt, table),
              fontsize=7.5, framealpha=0.8)
    ax.set_title(_title(table, title), fontsize=10)
    return _save(fig, path, force)


def fig10(table: pd.DataFrame, path, *, force: bool = False) -> Path:
    """LCO amplitude of point A (half peak-to-peak, ft and % of span) vs altitude (Fig. 10)."""

    def percent_axis(ax):
        pct = table["amplitude_pct_span"] if "amplitude_pct_span" in table else None
        ok = None if pct is None else (table["amplitude"] > 0) & np.isfinite(pct)
        if ok is None or not ok.any():
            return
        span = float(np.median(100.0 * table["amplitude"][ok] / pct[ok]))
        sec = ax.secondary_yaxis("right", functions=(lambda a: 100 * a / span,
                                                     lambda p: p * span / 100))
        sec.set_ylabel(f"% of span ({span:g} ft)")

    return _altitude_figure(table, path, "amplitude", "LCO amplitude of point A, Tz (ft)",
                            "Fig. 10: LCO amplitude vs altitude", force, percent_axis)


def fig12(table: pd.DataFrame, path, *, force: bool = False) -> Path:
    """LCO frequency (Hz) vs altitude (Fig. 12)."""
    return _altitude_figure(table, path, "frequency_hz", "LCO frequency (Hz)",
                            "Fig. 12: LCO frequency vs altitude", force)


def fig13(table: pd.DataFrame, path, *, force: bool = False) -> Path:
    """Amplitude ratios of the generalized coordinates q1/q2 and q1/q4 vs altitude (Fig. 13)."""
    _require(table, ("altitude_ft", "ratio_q1_q2", "ratio_q1_q4", "status", *CURVE_KEYS),
             "fig13")
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.4), constrained_layout=True)
    for ax, col, what in ((axes[0], "ratio_q1_q2", "mode 1 / mode 2"),
                          (axes[1], "ratio_q1_q4", "mode 1 / mode 4")):
        _curve_axes(ax, table, col)
        ax.set_yscale("log")
        ax.set_xlabel("altitude (ft)")
        ax.set_ylabel(f"LCO amplitude ratio {what} (-)")
    axes[0].legend(fontsize=7.5)
    axes[0].set_title("a) q1/q2 (bending / torsion)", fontsize=10)
    axes[1].set_title("b) q1/q4", fontsize=10)
    fig.suptitle(_title(table, "Fig. 13: ratios of LCO generalized-coordinate amplitudes"),
                 fontsize=10)
    return _save(fig, path, force)


def history_cases(table: pd.DataFrame, histories: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``table`` whose histories are in ``histories``."""
    _require(table, ("case_id",), "fig11")
    _require(histories, ("case_id", "t"), "fig11")
    return table[table["case_id"].isin(set(histories["case_id"]))]


def fig11(table: pd.DataFrame, histories: pd.DataFrame, path, *, output: str = "A_Tz",
          zoom_s: float = 2.0, force: bool = False) -> Path:
    """Time histories of point A (Fig. 11): a) full, b) the last ``zoom_s`` seconds of each
    (the converged LCO), one line per case with histories."""
    rows = history_cases(table, histories)
    if rows.empty:
        raise InputError("plot fig11: no case of the results table has a time history")
    _require(histories, (output,), "fig11")
    plt = _plt()
    fig, (ax_a, ax_b) = plt.subplots(2, 1, figsize=(7.5, 7.0), constrained_layout=True)
    order = sorted(rows.itertuples(), key=lambda r: (-float(r.stiffness_nl) - float(r.damping_nl),
                                                     -float(r.stiffness_nl)))
    names = {(1.0, 1.0): "NL damp. & stiff.", (1.0, 0.0): "NL stiffness only",
             (0.0, 1.0): "NL damping only"}
    for r in order:
        h = histories[histories["case_id"] == r.case_id].sort_values("t")
        key = (float(r.stiffness_nl), float(r.damping_nl))
        label = f"{names.get(key, curve_label(r.gamma, *key))} ({r.status}, {r.steps} steps)"
        (line,) = ax_a.plot(h["t"], h[output], lw=0.6, label=label)
        last = h[h["t"] >= h["t"].iloc[-1] - zoom_s]
        ax_b.plot(last["t"] - last["t"].iloc[0], last[output], lw=1.2, color=line.get_color(),
                  label=label)
    first = order[0]
    where = f"{first.altitude_ft:,.0f} ft, γ = {first.gamma:g} s"
    for ax in (ax_a, ax_b):
        ax.set_ylabel(f"point A, {output.split('_')[-1]} (ft)")
        ax.grid(alpha=0.3)
    ax_a.set_xlabel("time (s)")
    ax_b.set_xlabel(f"time within the last {zoom_s:g} s of each run (s)")
    ax_a.legend(fontsize=7.5)
    ax_a.set_title(f"Fig. 11a: time history of point A at {where}", fontsize=10)
    ax_b.set_title("Fig. 11b: converged LCO (zoom)", fontsize=10)
    return _save(fig, path, force)


#: figures drawn from the results table alone
TABLE_FIGURES: dict[str, Callable] = {"fig9": fig9, "fig10": fig10, "fig12": fig12,
                                      "fig13": fig13}
FIGURES = (*TABLE_FIGURES, "fig11")
