"""The paper's figures (Figs. 9–13) from result tables (matplotlib, Agg backend), atomically.

Each function takes the tables a sweep wrote and draws one figure of paper Sec. IV:

- :func:`fig9`  α vs γ at constant flutter altitude (table with columns gamma, alpha);
- :func:`fig10` LCO amplitude of point A vs altitude, ft and % of span, one curve per damping
  setting (γ, stiffness and damping nonlinearity switches);
- :func:`fig11` time histories of point A for the cases of one altitude (full and a zoom on the
  converged LCO), from ``histories.parquet`` and the results table;
- :func:`fig12` LCO frequency vs altitude;
- :func:`fig13` amplitude ratios of the generalized coordinates q1/q2 and q1/q4 vs altitude.

- :func:`table2` our natural frequencies against the paper's Table 2, mode by mode, with kinds.

A *curve* is a group of cases with the same (γ, stiffness_nl, damping_nl); curves with a single
altitude (e.g. the extra Fig. 11 cases) are left out of the altitude plots. Each curve has its
own line style and marker, later curves thinner, so that coincident curves (γ = 1e-5 on γ = 0)
stay visible; a converged LCO is the curve's marker filled, other statuses are marked apart;
the legend, outside the axes, lists only the curves and statuses drawn; no text on the axes
covers a marker (the flutter altitudes are named in the legend; a note is placed where its box
covers none, :func:`torchrom.study.plots.note_clear_of_markers`). Log axes say so in their
labels and read plain numbers, at least four of them (:func:`plain_log_ticks`). An axes without
any converged LCO says "no case with an LCO". Where the paper states a value (Table 2, the
flutter point, Table 3) it is drawn from the package's reference data
(:func:`torchrom.reference.paper_reference`), never typed here; the flutter altitude (ours
when given, and the paper's) is marked on the altitude axes.
Layout; drawing delegated to matplotlib.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

from ..errors import InputError
from ..io import atomic_path, check_can_write
from ..reference import PaperReference, paper_reference
from .plots import NO_LCO, note_clear_of_markers

#: marker per status other than a converged LCO (drawn with the curve's own marker, filled)
MARKERS = {"decay": ("v", False), "diverged": ("^", False), "failed": ("x", True)}
CURVE_KEYS = ("gamma", "stiffness_nl", "damping_nl")
#: (line style, marker, line width, marker size) of the curves in drawing order: every curve
#: its own style and marker, widths and sizes shrinking so that a curve drawn on top of an
#: identical one leaves the one below visible around it (Fig. 10: γ = 1e-5 on γ = 0)
CURVE_STYLES = (("-", "o", 3.6, 10.0), ("--", "s", 2.8, 8.0), ("-.", "D", 2.2, 6.5),
                (":", "^", 1.8, 5.5), ((0, (6, 2)), "v", 1.4, 4.5),
                ((0, (3, 1, 1, 1, 1, 1)), "P", 1.1, 3.8), ((0, (1, 1)), "X", 0.9, 3.2))


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


def _status_legend(plt, statuses) -> list:
    """Legend entries for the statuses actually drawn (a converged LCO: the curve's marker,
    filled; an unconverged case: the curve's marker, hollow)."""
    names = {"diverged": "diverged (drawn at the top)", "failed": "failed (drawn at the top)",
             "decay": "decay"}
    out = [plt.Line2D([], [], marker="o", ls="none", color="0.3", mfc=mfc, label=label)
           for s, mfc, label in (("lco", "0.3", "converged LCO (curve marker, filled)"),
                                 ("unconverged", "none", "unconverged (hollow, value when "
                                                         "stopped)")) if s in statuses]
    return out + [plt.Line2D([], [], marker=m, ls="none", color="0.3",
                             mfc="0.3" if f else "none", label=names.get(s, s))
                  for s, (m, f) in MARKERS.items() if s in statuses]


def _legend_outside(ax, handles, **kw) -> None:
    """The figure's legend to the right of all its axes (a secondary axis included), clear of
    the data (constrained layout makes room for it)."""
    ax.figure.legend(handles=handles, loc="outside right upper", fontsize=7.5, **kw)


def _curve_axes(ax, table: pd.DataFrame, y: str, x: str = "altitude_ft") -> set[str]:
    """One line per curve through its converged LCOs, each curve with its own line style and
    marker (:data:`CURVE_STYLES`, so coincident curves stay visible); cases that did not
    converge are hollow markers at their value when stopped, decays ▽, cases that diverged or
    failed are drawn at the top of the axis (their values are off any useful scale). Returns
    the statuses drawn."""
    last = f"last_{y}" if f"last_{y}" in table else y  # an unconverged case's value when stopped
    ys = pd.concat([table[table["status"].isin(["lco", "decay"])][y],
                    table[table["status"] == "unconverged"][last]]).astype(float)
    shown = ys[np.isfinite(ys)]
    top = float(shown.max()) * 1.08 if len(shown) else 1.0
    drawn: set[str] = set()
    for i, (label, grp) in enumerate(curves(table, x)):
        ls, marker, lw, ms = CURVE_STYLES[i % len(CURVE_STYLES)]
        ok = grp[(grp["status"] == "lco") & np.isfinite(grp[y].astype(float))]
        (line,) = ax.plot(ok[x], ok[y], ls=ls, lw=lw, marker=marker, ms=ms, label=label,
                          zorder=2 + i)
        color = line.get_color()
        if len(ok):
            drawn.add("lco")
        sel = grp[grp["status"] == "unconverged"]
        sel = sel[np.isfinite(sel[last].astype(float))]
        if len(sel):
            drawn.add("unconverged")
            ax.plot(sel[x], sel[last], marker, ms=ms, color=color, mfc="none", ls="none",
                    zorder=2 + i)
        for status, (smarker, filled) in MARKERS.items():
            sel = grp[grp["status"] == status]
            if status == "decay":
                sel = sel[np.isfinite(sel[y].astype(float))]
            if len(sel):
                drawn.add(status)
                vals = sel[y] if status == "decay" else np.full(len(sel), top)
                ax.plot(sel[x], vals, smarker, ms=6, color=color,
                        mfc=color if filled else "none", ls="none", zorder=2 + i)
    ax.grid(alpha=0.3)
    return drawn


def _flutter_lines(ax, flutter_altitude_ft: float | None, ref: PaperReference) -> None:
    """Vertical lines at our flutter altitude (when known; red, dashed) and at the paper's
    (blue, dotted), named in the legend with their altitudes. Not named on the axes: the lines
    are ~75 ft apart beside the flutter points and the last LCOs, where a name would cover
    their markers (issue 37)."""
    ours = flutter_altitude_ft is not None and np.isfinite(flutter_altitude_ft)
    lines = [(ref.flutter_altitude_ft, "tab:blue", ":", 1.6, "paper's flutter altitude")]
    if ours:
        lines.append((float(flutter_altitude_ft), "tab:red", "--", 1.3, "our flutter altitude"))
    for h, color, ls, lw, name in sorted(lines, key=lambda line: line[0]):
        ax.axvline(h, color=color, lw=lw, ls=ls, label=f"{name} {h:,.0f} ft", zorder=1)


def _title(table: pd.DataFrame, what: str) -> str:
    mach = table["mach"].iloc[0] if "mach" in table and len(table) else None
    return f"{what}, Mach {mach:.2f}" if mach is not None and np.isfinite(mach) else what


def fig9(table: pd.DataFrame, path, *, force: bool = False, reference_altitude=None,
         reference: PaperReference | None = None) -> Path:
    """α (1/s) vs γ (s) that keep the flutter altitude constant (paper Fig. 9), with every
    α(γ) value the paper states (:attr:`PaperReference.fig9_points`: its baseline Rayleigh
    damping, Eq. 46, which the curve must pass through) and ours labelled at the γ of the
    paper's Fig. 10 curves."""
    ref = reference or paper_reference()
    _require(table, ("gamma", "alpha"), "fig9")
    t = table.drop_duplicates(["gamma", "alpha"]).sort_values("gamma")
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.0, 4.2), constrained_layout=True)
    # the table's reference altitude in the unit its column names (ft for the Goland study)
    h, unit = reference_altitude, "ft"
    column = next((c for c in ("reference_altitude_ft", "reference_altitude_m") if c in t), None)
    if h is None and column is not None:
        h, unit = float(t[column].iloc[0]), column.rsplit("_", 1)[1]
    label = "α(γ) keeping the flutter altitude" + (f" at {h:,.0f} {unit}" if h is not None
                                                    else "")
    ax.plot(t["gamma"], t["alpha"], "o-", ms=4, lw=1.4, label=label)
    for g, a in ref.fig9_points:
        ax.plot(g, a, "k*", ms=11, ls="none",
                label=f"paper: α = {a:g} 1/s at γ = {g:g} s ({ref.fig9_source})")
    for g in ref.gammas_s:  # our α at the γ of the paper's Figs. 10-13 curves
        hit = t[np.isclose(t["gamma"], g, rtol=1e-9, atol=1e-12)]
        if len(hit):
            ax.annotate(f"{float(hit['alpha'].iloc[0]):.4f}", (g, float(hit["alpha"].iloc[0])),
                        textcoords="offset points", xytext=(4, 5), fontsize=7)
    ax.set_xlabel("γ (s)")
    ax.set_ylabel("α (1/s)")
    ax.text(0.99, 0.97, ref.fig9_note, transform=ax.transAxes, ha="right", va="top",
            fontsize=7, color="0.3", wrap=True)
    ax.ticklabel_format(axis="x", style="sci", scilimits=(-3, -3))
    ax.grid(alpha=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), fontsize=8)
    ax.set_title(_title(table, "Fig. 9: damping parameter α vs γ"), fontsize=10)
    return _save(fig, path, force)


def _altitude_figure(table: pd.DataFrame, path, y: str, ylabel: str, title: str, force: bool,
                     decorate: Callable | None = None, flutter_altitude_ft: float | None = None,
                     reference: PaperReference | None = None) -> Path:
    """A Fig. 10 / 12-style figure: ``y`` of every curve against the altitude, the flutter
    altitudes marked, ``decorate(ax)`` adding the paper's values."""
    _require(table, ("altitude_ft", y, "status", *CURVE_KEYS), title.split(":")[0])
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9.0, 4.8), constrained_layout=True)
    drawn = _curve_axes(ax, table, y)
    _flutter_lines(ax, flutter_altitude_ft, reference or paper_reference())
    ax.set_xlabel("altitude (ft)")
    ax.set_ylabel(ylabel)
    if decorate is not None:
        decorate(ax)
    _legend_outside(ax, ax.get_legend_handles_labels()[0] + _status_legend(plt, drawn))
    ax.set_title(_title(table, title), fontsize=10)
    if "lco" not in drawn:
        note_clear_of_markers(ax, NO_LCO)
    return _save(fig, path, force)


def fig10(table: pd.DataFrame, path, *, force: bool = False,
          flutter_altitude_ft: float | None = None,
          reference: PaperReference | None = None) -> Path:
    """LCO amplitude of point A (half peak-to-peak, ft and % of span) vs altitude (Fig. 10); the
    paper gives no amplitude numbers, only its flutter altitude is drawn."""

    def percent_axis(ax):
        pct = table["amplitude_pct_span"] if "amplitude_pct_span" in table else None
        ok = None if pct is None else (table["amplitude"] > 0) & np.isfinite(pct)
        if ok is None or not ok.any():
            return
        span = float(np.median(100.0 * table["amplitude"][ok] / pct[ok]))
        sec = ax.secondary_yaxis("right", functions=(lambda a: 100 * a / span,
                                                     lambda p: p * span / 100))
        sec.set_ylabel(f"LCO amplitude (% of span, {span:g} ft)")

    return _altitude_figure(table, path, "amplitude", "LCO amplitude of point A, Tz (ft)",
                            "Fig. 10: LCO amplitude vs altitude", force, percent_axis,
                            flutter_altitude_ft, reference)


def fig12(table: pd.DataFrame, path, *, force: bool = False,
          flutter_altitude_ft: float | None = None, flutter_frequency_hz: float | None = None,
          table3: dict[float, float] | None = None,
          reference: PaperReference | None = None) -> Path:
    """LCO frequency (Hz) vs altitude (Fig. 12), with the paper's flutter point and its Table 3
    (frequency of the growing response of the linear system below flutter), and, when given,
    our flutter point and our Table 3 (``table3``: altitude ft → Hz)."""
    ref = reference or paper_reference()

    def paper_points(ax):
        alts = sorted(ref.table3_hz)
        ax.plot(alts, [ref.table3_hz[a] for a in alts], "kx", ms=7, mew=1.4, ls="none",
                label="paper Table 3: growing response (linear)")
        if table3:
            ours = sorted(table3)
            ax.plot(ours, [table3[a] for a in ours], "k+", ms=9, mew=1.4, ls="none",
                    label="ours, Table 3: growing response (linear)")
        ax.plot(ref.flutter_altitude_ft, ref.flutter_frequency_hz, "*", color="0.45", ms=12,
                label=f"paper's flutter point ({ref.flutter_frequency_hz:g} Hz)")
        if flutter_altitude_ft is not None and flutter_frequency_hz is not None:
            ax.plot(flutter_altitude_ft, flutter_frequency_hz, "k*", ms=12,
                    label=f"our flutter point ({flutter_frequency_hz:.3f} Hz)")

    return _altitude_figure(table, path, "frequency_hz", "LCO frequency (Hz)",
                            "Fig. 12: LCO frequency vs altitude", force, paper_points,
                            flutter_altitude_ft, ref)


def ratio_column(table: pd.DataFrame, ours: int) -> str:
    """The column of q1 / q``ours`` (made from the ``amplitude_q<j>`` columns when needed)."""
    col = f"ratio_q1_q{ours}"
    if col not in table.columns:
        from ..sim.metrics import amplitude_ratio

        _require(table, ("amplitude_q1", f"amplitude_q{ours}"), "fig13")
        table[col] = amplitude_ratio(table["amplitude_q1"].to_numpy(),
                                     table[f"amplitude_q{ours}"].to_numpy())
    return col


def fig13(table: pd.DataFrame, path, *, force: bool = False, q4_mode: int = 4,
          q4_note: str | None = None, flutter_altitude_ft: float | None = None,
          reference: PaperReference | None = None) -> Path:
    """Amplitude ratios of the generalized coordinates q1/q2 and q1/q4 vs altitude (Fig. 13).

    ``q4_mode``: our mode compared with the paper's mode 4 (matched by kind,
    :func:`torchrom.paper.modes.paper_mode_map`; its ratio is made from the ``amplitude_q<j>``
    columns), ``q4_note`` says why, e.g. "our mode 5 (torsion) for the paper's mode 4"."""
    table = table.copy()
    col4 = ratio_column(table, q4_mode)
    _require(table, ("altitude_ft", "ratio_q1_q2", col4, "status", *CURVE_KEYS), "fig13")
    ref = reference or paper_reference()
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(12.5, 4.6), constrained_layout=True)
    drawn: set[str] = set()
    empty = []
    for ax, col, what in ((axes[0], "ratio_q1_q2", "q1 / q2"),
                          (axes[1], col4, f"q1 / q{q4_mode}")):
        on_axes = _curve_axes(ax, table, col)
        drawn |= on_axes
        if "lco" not in on_axes:
            empty.append(ax)
        _flutter_lines(ax, flutter_altitude_ft, ref)
        ax.set_yscale("log")
        plain_log_ticks(ax.yaxis)
        ax.set_xlabel("altitude (ft)")
        ax.set_ylabel(f"LCO amplitude ratio {what} (-, log scale)")
    _legend_outside(axes[1], axes[1].get_legend_handles_labels()[0] + _status_legend(plt, drawn))
    axes[0].set_title("a) q1/q2 (bending / torsion)", fontsize=10)
    import textwrap

    note = "\n" + "\n".join(textwrap.wrap(q4_note, 60)) if q4_note else ""
    axes[1].set_title(f"b) q1/q{q4_mode}{note}", fontsize=10)
    fig.suptitle(_title(table, "Fig. 13: ratios of LCO generalized-coordinate amplitudes"),
                 fontsize=10)
    for ax in empty:
        note_clear_of_markers(ax, NO_LCO)
    return _save(fig, path, force)


def plain_log_ticks(axis, min_labels: int = 4) -> None:
    """Tick labels of a log axis as plain numbers (10, 20, 50, 100; not 2×10¹ or 10¹), at least
    ``min_labels`` of them in the axis's present range: the decades and 2 and 5 × each decade
    where that gives enough (a range of several decades), otherwise round numbers 1, 2, 2.5 or
    5 × a power of ten apart (Fig. 13's ratios span 9-21: decades alone label only 10 and 20).
    Minor ticks, unlabelled, at every integer multiple of each decade, so the spacing shows the
    scale is logarithmic. Call it once the data are drawn (the choice reads the axis range)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, MaxNLocator, NullFormatter

    def plain(v, _pos=None) -> str:
        return f"{v:.10g}" if v > 0 else ""

    lo, hi = sorted(axis.get_view_interval())
    decades = LogLocator(base=10.0, subs=(1.0, 2.0, 5.0))
    inside = [v for v in decades.tick_values(lo, hi) if lo <= v <= hi]
    if len(inside) >= min_labels:
        axis.set_major_locator(decades)
    else:
        axis.set_major_locator(MaxNLocator(nbins=2 * min_labels, steps=[1, 2, 2.5, 5, 10]))
    axis.set_major_formatter(FuncFormatter(plain))
    axis.set_minor_locator(LogLocator(base=10.0, subs=tuple(range(1, 10))))
    axis.set_minor_formatter(NullFormatter())


def table2(modes: pd.DataFrame, path, *, force: bool = False,
           reference: PaperReference | None = None) -> Path:
    """Our natural frequencies against the paper's Table 2, mode by mode (``modes``: columns
    mode, frequency_hz and optionally kind and content, the content shares), each bar labelled
    with the mode's kind (and the shares of a mixed mode)."""
    _require(modes, ("mode", "frequency_hz"), "table2")
    ref = reference or paper_reference()
    plt = _plt()
    fig, ax = plt.subplots(figsize=(9.0, 4.4), constrained_layout=True)
    n = min(len(modes), len(ref.table2_hz))
    m = modes.sort_values("mode").iloc[:n]
    x = np.arange(1, n + 1)
    ax.bar(x - 0.2, m["frequency_hz"], 0.4, label="torchrom (FE reconstruction)")
    ax.bar(x + 0.2, ref.table2_hz[:n], 0.4, color="0.6", label="paper Table 2")
    from ..fe.kinds import kind_label

    kinds = list(m["kind"]) if "kind" in m else [None] * n
    contents = list(m["content"]) if "content" in m else [None] * n
    for xi, f, k, c in zip(x, m["frequency_hz"], kinds, contents):
        if k:  # a mixed mode with its content shares
            ax.annotate(kind_label(k, c if isinstance(c, dict) else None, short=True),
                        (xi - 0.2, f), textcoords="offset points", xytext=(0, 3),
                        ha="center", fontsize=6.5, rotation=90)
    for xi, f, k in zip(x, ref.table2_hz[:n], ref.table2_kinds):
        ax.annotate(k, (xi + 0.2, f), textcoords="offset points", xytext=(0, 3), ha="center",
                    fontsize=6.5, rotation=90, color="0.35")
    ax.set_xticks(x)
    ax.set_xlabel("mode")
    ax.set_ylabel("natural frequency (Hz)")
    ax.set_ylim(0, 1.3 * max(float(m["frequency_hz"].max()), max(ref.table2_hz[:n])))
    ax.grid(alpha=0.3, axis="y")
    _legend_outside(ax, ax.get_legend_handles_labels()[0])
    ax.set_title("Table 2: natural frequencies of the heavy Goland wing", fontsize=10)
    return _save(fig, path, force)


def history_cases(table: pd.DataFrame, histories: pd.DataFrame) -> pd.DataFrame:
    """The rows of ``table`` whose histories are in ``histories``."""
    _require(table, ("case_id",), "fig11")
    _require(histories, ("case_id", "t"), "fig11")
    return table[table["case_id"].isin(set(histories["case_id"]))]


def upward_crossing(t: np.ndarray, y: np.ndarray, before: float) -> float | None:
    """The last time ≤ ``before`` at which ``y`` crosses its mean upwards (linear
    interpolation), None when there is none."""
    c = y - y.mean()
    i = np.flatnonzero((c[:-1] < 0) & (c[1:] >= 0) & (t[1:] <= before))
    if not len(i):
        return None
    j = i[-1]
    return float(t[j] - c[j] * (t[j + 1] - t[j]) / (c[j + 1] - c[j]))


def fig11(table: pd.DataFrame, histories: pd.DataFrame, path, *, output: str = "A_Tz",
          zoom_s: float = 2.0, force: bool = False) -> Path:
    """Time histories of point A (Fig. 11): a) full, b) the converged LCO, one line per case with
    histories. In b) each case's time starts at an upward crossing of its mean in the last
    ``zoom_s`` + one cycle of its run, so the phase is defined (0 at the crossing) and the cases'
    shapes, amplitudes and periods compare directly."""
    rows = history_cases(table, histories)
    if rows.empty:
        raise InputError("plot fig11: no case of the results table has a time history")
    _require(histories, (output,), "fig11")
    plt = _plt()
    fig, (ax_a, ax_b) = plt.subplots(2, 1, figsize=(9.5, 7.0), constrained_layout=True)
    order = sorted(rows.itertuples(), key=lambda r: (-float(r.stiffness_nl) - float(r.damping_nl),
                                                     -float(r.stiffness_nl)))
    names = {(1.0, 1.0): "NL damp. & stiff.", (1.0, 0.0): "NL stiffness only",
             (0.0, 1.0): "NL damping only"}
    for r in order:
        h = histories[histories["case_id"] == r.case_id].sort_values("t")
        key = (float(r.stiffness_nl), float(r.damping_nl))
        label = f"{names.get(key, curve_label(r.gamma, *key))} ({r.status}, {r.steps} steps)"
        t, y = h["t"].to_numpy(), h[output].to_numpy()
        (line,) = ax_a.plot(t, y, lw=0.6, label=label)
        period = 1.0 / float(r.frequency_hz) if np.isfinite(r.frequency_hz) and \
            r.frequency_hz > 0 else 0.0
        window = t >= t[-1] - zoom_s - 1.5 * period
        t0 = upward_crossing(t[window], y[window], t[-1] - zoom_s)
        if t0 is None:  # no oscillation to align on (e.g. a decay): the last zoom_s seconds
            t0 = t[-1] - zoom_s
        last = (t >= t0) & (t <= t0 + zoom_s)
        ax_b.plot(t[last] - t0, y[last], lw=1.2, color=line.get_color(), label=label)
    first = order[0]
    where = f"{first.altitude_ft:,.0f} ft, γ = {first.gamma:g} s"
    for ax in (ax_a, ax_b):
        ax.set_ylabel(f"point A, {output.split('_')[-1]} (ft)")
        ax.grid(alpha=0.3)
    _legend_outside(ax_b, ax_b.get_legend_handles_labels()[0])  # the same cases in a) and b)
    ax_a.set_xlabel("time (s)")
    ax_b.set_xlabel("time from an upward mean crossing near the end of each run (s)")
    ax_a.set_title(f"Fig. 11a: time history of point A at {where}", fontsize=10)
    ax_b.set_title(f"Fig. 11b: converged LCO, the last {zoom_s:g} s of each run, phase 0 at an "
                   "upward crossing", fontsize=10)
    return _save(fig, path, force)


#: figures drawn from the results table alone
TABLE_FIGURES: dict[str, Callable] = {"fig9": fig9, "fig10": fig10, "fig12": fig12,
                                      "fig13": fig13}
#: every figure: those above, Fig. 11 (results and histories) and Table 2 (a table of modes)
FIGURES = (*TABLE_FIGURES, "fig11", "table2")
