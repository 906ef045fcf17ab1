"""Figures of sweep tables (matplotlib, Agg backend), written atomically."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from ..errors import InputError
from ..io import atomic_path, check_can_write
from .grid import case_label

#: marker per status: settled LCOs filled, everything else hollow or crossed
_MARKERS = {"lco": ("o", True), "decay": ("v", False), "unconverged": ("s", False),
            "diverged": ("^", False), "failed": ("x", True)}


#: line styles and markers of the series that share a colour (a hue value), in order
SERIES_STYLES = (("-", "o"), ("--", "s"), ("-.", "D"), (":", "^"), ((0, (5, 1, 1, 1)), "v"),
                 ((0, (1, 1)), "P"))


def series_keys(table: pd.DataFrame, x: str, hue: str | None, facet: str | None) -> list[str]:
    """The columns that tell one series of a parameter plot from another: ``hue`` and every
    case parameter (:data:`torchrom.study.cases.AEROELASTIC_PARAMETERS`) other than ``x`` and
    ``facet`` that takes several values at one x (and panel) among the rows of one hue value
    (e.g. the stiffness switch at one γ), so a line never joins cases of different series. A
    parameter that follows x (α matched to each sampled γ) does not split the line: a 10⁴-sample
    study is one series, not 10⁴."""
    from .cases import AEROELASTIC_PARAMETERS

    keys = [hue] if hue else []
    at = [x] + ([facet] if facet else [])
    groups = table.groupby(hue, sort=False) if hue else [(None, table)]
    for c in AEROELASTIC_PARAMETERS:
        if c in table.columns and c not in (x, facet, hue) and any(
                (g[c].astype(str).groupby([g[k] for k in at], sort=False).nunique() > 1).any()
                for _, g in groups):
            keys.append(c)
    return keys


def parameter_plot(table: pd.DataFrame, path, *, x: str, y: str = "amplitude",
                   hue: str | None = None, facet: str | None = None, title: str | None = None,
                   force: bool = False) -> Path:
    """y against x, one series per value of ``hue`` and of any other case parameter that
    varies (:func:`series_keys`; a colour per hue value, a line style and marker per other
    series), sorted by x; one panel per value of ``facet``; markers show the status (filled:
    converged LCO; a series with a single x value is drawn as markers only). Axis labels carry
    units (:func:`.units.axis_label`); the legend sits below the axes, clear of the title, and
    lists only what is drawn. Returns the path written (PNG/PDF/SVG by its suffix)."""
    import numpy as np

    from .units import axis_label

    plt = _pyplot()
    for col in (x, y) + tuple(c for c in (hue, facet) if c):
        if col not in table.columns:
            raise InputError(f"plot: no column {col!r} in the results table; it has "
                             f"{list(table.columns)}")
    path = check_can_write(path, force, "figure")
    panels = sorted(table[facet].dropna().unique()) if facet else [None]
    ncol = min(len(panels), 3)
    nrow = -(-len(panels) // ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.6 * ncol + 1.8, 3.8 * nrow + 0.8),
                             squeeze=False, sharex=True, sharey=True, constrained_layout=True)
    has_status = "status" in table.columns
    drawn: set[str] = set()
    keys = series_keys(table, x, hue, facet)
    series = ([tuple(r) for r in table[keys].drop_duplicates().sort_values(keys).itertuples(
        index=False)] if keys else [()])
    hue_values = sorted(table[hue].dropna().unique()) if hue else [None]
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    styles: dict[tuple, tuple] = {}
    for key in series:
        color = colors[(hue_values.index(key[0]) if hue and key[0] in hue_values else 0)
                       % len(colors)]
        shared = sum(1 for k in styles if (k[:1] == key[:1] if hue else True))
        styles[key] = (color, *SERIES_STYLES[shared % len(SERIES_STYLES)])
    labelled: set[tuple] = set()
    for ax, value in zip(axes.flat, panels):
        sub = table if facet is None else table[table[facet] == value]
        for key in series:
            sel_rows = np.ones(len(sub), dtype=bool)
            for k, v in zip(keys, key):
                sel_rows &= (sub[k].astype(str) == str(v)).to_numpy()
            grp = sub[sel_rows].sort_values(x)
            if grp.empty:
                continue
            color, ls, marker = styles[key]
            label = None
            if keys and key not in labelled:
                labelled.add(key)
                label = ", ".join(_value_label(table, k, v) for k, v in zip(keys, key))
            ok = grp[grp["status"] == "lco"] if has_status else grp
            single = grp[x].nunique() < 2
            ax.plot(ok[x], ok[y], ls="none" if single else ls, lw=1.3, color=color,
                    marker=marker, ms=5, label=label)
            if not has_status:
                continue
            for status, (smarker, filled) in _MARKERS.items():
                if status == "lco":
                    if len(ok):
                        drawn.add(status)
                    continue
                # an unconverged case at its value when stopped (hollow): its amplitude is NaN
                col = f"last_{y}" if status == "unconverged" and f"last_{y}" in grp else y
                sel = grp[(grp["status"] == status) & np.isfinite(grp[col].astype(float))]
                if len(sel):
                    drawn.add(status)
                    ax.plot(sel[x], sel[col], smarker, ms=6, color=color,
                            mfc=color if filled else "none", ls="none")
        ax.grid(alpha=0.3)
        if facet:
            ax.set_title(_value_label(table, facet, value), fontsize=9)
    for ax in axes.flat[len(panels):]:
        ax.set_visible(False)
    for ax in axes[-1, :]:
        ax.set_xlabel(axis_label(table, x))
    for ax in axes[:, 0]:
        ax.set_ylabel(axis_label(table, y))
    handles = [h for h in axes.flat[0].get_legend_handles_labels()[0]]
    for ax in axes.flat[1:len(panels)]:
        handles += ax.get_legend_handles_labels()[0]
    handles += [plt.Line2D([], [], marker="o" if s == "lco" else m, ls="none", color="0.3",
                           mfc="0.3" if f else "none", label=STATUS_NAMES.get(s, s))
                for s, (m, f) in _MARKERS.items() if s in drawn]
    if handles:
        # as many columns as the longest label lets fit in the figure's width (8 pt text:
        # ~0.065 in per character, plus the marker)
        widest = 0.065 * max(len(h.get_label()) for h in handles) + 0.6
        ncol = max(1, min(3, len(handles), int(fig.get_figwidth() // widest)))
        fig.legend(handles=handles, loc="outside lower center", fontsize=8, ncol=ncol)
    if title:
        fig.suptitle(title, fontsize=10)
    if has_status:
        for ax, value in zip(axes.flat, panels):
            sub = table if facet is None else table[table[facet] == value]
            if not (sub["status"] == "lco").any():
                note_clear_of_markers(ax, NO_LCO)
    return _save(fig, path)


#: legend text of each status
STATUS_NAMES = {"lco": "converged LCO (filled)", "decay": "decay", "unconverged": "unconverged "
                "(value when stopped)", "diverged": "diverged", "failed": "failed"}


def _value_label(table: pd.DataFrame, column: str, value) -> str:
    """``name = value unit`` for a legend or panel title (names from :mod:`.units`; the
    nonlinearity switches as on/off)."""
    from .units import column_name, column_units

    name = column_name(column)
    if column in ("stiffness_nl", "damping_nl") and str(value) in ("0", "0.0", "False", "1",
                                                                    "1.0", "True"):
        return f"{name} {'on' if str(value) in ('1', '1.0', 'True') else 'off'}"
    unit = column_units(table).get(column)
    try:
        v = f"{float(value):g}" if not isinstance(value, bool) else str(value)
    except (TypeError, ValueError):
        v = str(value)
    return f"{name} = {v}" + (f" {unit}" if unit and unit != "-" else "")


#: where :func:`note_clear_of_markers` tries a note, in axes fractions (x, y, ha, va), in order
NOTE_PLACES = ((0.5, 0.97, "center", "top"), (0.5, 0.03, "center", "bottom"),
               (0.5, 0.5, "center", "center"), (0.03, 0.97, "left", "top"),
               (0.97, 0.97, "right", "top"), (0.03, 0.03, "left", "bottom"),
               (0.97, 0.03, "right", "bottom"))
NO_LCO = "no case with an LCO"


def marker_boxes(ax):
    """The pixel boxes (x0, y0, x1, y1) of the markers drawn inside ``ax`` (as laid out now)."""
    import numpy as np

    boxes = []
    for ln in ax.get_lines():
        if not ln.get_visible() or ln.get_marker() in (None, "None", "", " ", ","):
            continue
        xy = np.column_stack([np.asarray(ln.get_xdata(), float),
                              np.asarray(ln.get_ydata(), float)])
        xy = ln.get_transform().transform(xy[np.isfinite(xy).all(axis=1)])
        r = ln.get_markersize() * ax.figure.dpi / 72.0 / 2.0
        boxes += [(x - r, y - r, x + r, y + r) for x, y in xy if ax.bbox.contains(x, y)]
    return boxes


def note_clear_of_markers(ax, text: str):
    """``text`` written on ``ax`` at the first of :data:`NOTE_PLACES` where its box covers no
    marker, as the figure is laid out now (so call it once the axes are complete); the first
    place when none is clear. Returns the text artist."""
    fig = ax.figure
    fig.draw_without_rendering()  # the layout (and the axes' limits) the markers are drawn at
    renderer = fig.canvas.get_renderer()
    markers = marker_boxes(ax)
    note = ax.text(0, 0, text, transform=ax.transAxes, fontsize=9, color="0.3", zorder=10)
    for x, y, ha, va in (*NOTE_PLACES, NOTE_PLACES[0]):
        note.set_position((x, y))
        note.set_horizontalalignment(ha)
        note.set_verticalalignment(va)
        bb = note.get_window_extent(renderer)
        if not any(bb.x0 < x1 and x0 < bb.x1 and bb.y0 < y1 and y0 < bb.y1
                   for x0, y0, x1, y1 in markers):
            break
    return note


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path) -> Path:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=120, format=path.suffix.lstrip(".") or "png")
    _pyplot().close(fig)
    return path


def distribution_plot(table: pd.DataFrame, path, *, by=(), value: str = "amplitude",
                      title: str | None = None, force: bool = False) -> Path:
    """Histogram (left) and empirical CDF (right) of ``value`` over sampled cases, one curve
    per group of ``by`` (e.g. altitude). An LCO counts with its amplitude, a decay as 0 (the
    CDF's jump at 0 is the probability of no LCO); other statuses are left out (see
    :func:`torchrom.study.sampling.distribution_values`)."""
    import numpy as np

    from .sampling import distribution_values

    for col in (value, *by):
        if col not in table.columns:
            raise InputError(f"plot: no column {col!r} in the results table; it has "
                             f"{list(table.columns)}")
    path = check_can_write(path, force, "figure")
    plt = _pyplot()
    vals = distribution_values(table, value)
    fig, (ax_h, ax_c) = plt.subplots(1, 2, figsize=(10, 4.2), constrained_layout=True)
    finite = vals.dropna()
    edges = np.histogram_bin_edges(finite, bins=max(10, min(40, 2 * int(len(finite) ** 0.5))))
    groups = table.groupby(list(by), sort=True) if by else [(None, table)]
    for key, grp in groups:
        v = np.sort(vals[grp.index].dropna().to_numpy())
        if not len(v):
            continue
        key = key if isinstance(key, tuple) else (key,)
        label = ", ".join(_value_label(table, b, k) for b, k in zip(by, key)) if by else None
        label = f"{label} (n = {len(v)})" if label else f"n = {len(v)}"
        ax_h.hist(v, bins=edges, histtype="step", lw=1.4, label=label)
        ax_c.step(v, np.arange(1, len(v) + 1) / len(v), where="post", lw=1.4, label=label)
    from .units import axis_label

    ax_h.set_xlabel(f"{axis_label(table, value)}, decay = 0")
    ax_h.set_ylabel("cases")
    ax_c.set_xlabel(f"{axis_label(table, value)}, decay = 0")
    ax_c.set_ylabel("cumulative probability")
    ax_c.set_ylim(0, 1.02)
    for ax in (ax_h, ax_c):
        ax.grid(alpha=0.3)
    fig.legend(handles=ax_c.get_legend_handles_labels()[0], loc="outside right upper",
               fontsize=8)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def _case_label(case: dict, keys) -> str:
    return case_label(case, keys)


def calibration_plot(evaluations: pd.DataFrame, result: pd.DataFrame, path, *,
                     column: str = "amplitude", target: float, title: str | None = None,
                     force: bool = False) -> Path:
    """The response (``column`` of an LCO, 0 for a decay) against γ for every base case of a
    calibration (:func:`torchrom.study.calibrate.calibrate_gamma`), the target (horizontal line)
    and the calibrated γ (dashed vertical lines)."""
    path = check_can_write(path, force, "figure")
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.4), constrained_layout=True)
    keys = [k for k in result.columns if k not in ("base_case",)
            and k in evaluations.columns and k not in ("gamma", "alpha", column, "status")
            and result[k].nunique() > 1]
    for b, grp in evaluations.groupby("base_case", sort=True):
        grp = grp.sort_values("gamma")
        decided = grp[grp["status"].isin(["lco", "decay"])]
        label = _case_label(grp.iloc[0].to_dict(), keys) or None
        (line,) = ax.plot(decided["gamma"], decided["response"], "-", lw=1.0, label=label)
        for status, (marker, filled) in _MARKERS.items():
            sel = decided[decided["status"] == status]
            if len(sel):
                ax.plot(sel["gamma"], sel["response"], marker, ms=3.5, color=line.get_color(),
                        mfc=line.get_color() if filled else "none", ls="none")
        for g in result.loc[(result["base_case"] == b) & (result["status"] == "ok"), "gamma"]:
            ax.axvline(g, color=line.get_color(), ls="--", lw=0.9)
    ax.axhline(target, color="0.3", lw=0.9, ls=":", label=f"target {column} = {target:g}")
    ax.set_xscale("log")
    from .units import axis_label

    ax.set_xlabel(axis_label(evaluations, "gamma"))
    ax.set_ylabel(f"{axis_label(evaluations, column)}, decay = 0")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    return _save(fig, path)


def bifurcation_plot(runs: pd.DataFrame, summary: pd.DataFrame, path, *, x: str | None,
                     title: str | None = None, force: bool = False) -> Path:
    """Bifurcation diagram (left: amplitude of every attractor against the control parameter
    ``x``, rest states at 0, unbounded growth as ▲ at the top, basin thresholds as open
    circles: the unstable branch) and the evidence behind it (right: the amplitude each run
    ends on against its initial amplitude, one curve per control). Amplitudes are in the
    decision output's units (``initial_scale`` of
    :func:`torchrom.study.bifurcation.bifurcation_sweep`). With one control case (``x`` None)
    the left panel has that case only."""
    import numpy as np

    path = check_can_write(path, force, "figure")
    plt = _pyplot()
    fig, (ax_b, ax_r) = plt.subplots(1, 2, figsize=(11, 4.4), constrained_layout=True)
    xs = summary[x].to_numpy(dtype=float) if x else np.zeros(len(summary))
    lco = runs[runs["status"] == "lco"]
    thr = summary["threshold_amplitude"]
    top = 1.15 * max(float(lco["amplitude"].max()) if len(lco) else 0.0,
                     float(thr.max()) if thr.notna().any() else 0.0,
                     float(runs["initial_amplitude"].max()))
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for c, row in summary.reset_index(drop=True).iterrows():
        mine = runs[runs["control"] == c].sort_values("initial_amplitude")
        xv = xs[c]
        if (mine["status"] == "decay").any():
            ax_b.plot(xv, 0.0, "o", color="k", ms=6)
        for _lab, grp in mine[mine["status"] == "lco"].groupby("attractor"):
            ax_b.plot(xv, grp["amplitude"].mean(), "o", color="C0", ms=6)
        if (mine["status"] == "diverged").any():
            ax_b.plot(xv, top, "^", color="C3", ms=7)
        if np.isfinite(row["threshold_amplitude"]):
            ax_b.plot(xv, row["threshold_amplitude"], "o", mfc="none", color="C1", ms=7)
        color = colors[c % len(colors)]
        label = f"{x} = {xv:g}" if x else None
        final = np.where(mine["status"] == "decay", 0.0,
                         np.where(mine["status"] == "diverged", top, mine["amplitude"]))
        ok = mine["attractor"] != "undecided"
        ax_r.plot(mine["initial_amplitude"][ok], final[ok.to_numpy()], ".-", color=color, lw=1,
                  label=label)
    has = thr.notna().to_numpy()
    if has.sum() > 1:
        ax_b.plot(xs[has], thr[has], "--", color="C1", lw=1)
    present = {"rest (decay)": (runs["status"] == "decay").any(),
               "stable LCO": (runs["status"] == "lco").any(),
               "threshold (unstable LCO)": bool(has.any()),
               "unbounded": (runs["status"] == "diverged").any()}
    styles = {"rest (decay)": ("o", "k", "k"), "stable LCO": ("o", "C0", "C0"),
              "threshold (unstable LCO)": ("o", "C1", "none"), "unbounded": ("^", "C3", "C3")}
    ax_b.legend(handles=[plt.Line2D([], [], marker=m, ls="none", color=c, mfc=f, label=k)
                         for k, (m, c, f) in styles.items() if present[k]], fontsize=8)
    from .units import axis_label, column_units

    unit = column_units(runs).get("amplitude")
    u = f" ({unit})" if unit else ""
    ax_b.set_xlabel(axis_label(summary, x) if x else "case")
    ax_b.set_ylabel(f"amplitude{u} (LCO; threshold: initial amplitude)")
    ax_r.set_xscale("log")
    ax_r.set_xlabel(f"initial amplitude{u}")
    ax_r.set_ylabel(f"final amplitude{u} (decay = 0, unbounded at the top)")
    if x:
        ax_r.legend(fontsize=7)
    for ax in (ax_b, ax_r):
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)


def amplitude_label(table: pd.DataFrame, column: str) -> str:
    """Axis label of a branch or sweep amplitude column: the decision output it measures
    (``table.attrs["decision_output"]``) and its unit, e.g. "LCO amplitude of A_Tz (ft)"."""
    from .units import axis_label

    out = table.attrs.get("decision_output")
    label = axis_label(table, column)
    if out and column in ("amplitude", "amplitude_pct_span"):
        label = label.replace("LCO amplitude", f"LCO amplitude of {out}", 1)
    return label


def branch_polyline(grp: pd.DataFrame, parameter: str, y: str):
    """(x, y, kind of the segment ending at each point) of one branch in point order, with each
    refined fold (``fold_parameter``, ``fold_<y>``) inserted into the segment near its detecting
    point that it lengthens least (axes scaled to the branch's extent), so the curve turns at
    the fold itself. A segment's kind ("stable", "unstable", "unknown") is the stability of its
    end point, of its start point when it ends on the fold (stability changes there)."""
    import numpy as np

    fold_y = "fold_" + y
    x = grp[parameter].to_numpy(dtype=float)
    v = grp[y].to_numpy(dtype=float)
    st = ["unknown" if s is None or pd.isna(s) else "stable" if bool(s) else "unstable"
          for s in grp["stable"]]
    pts = [[a, b, k, False] for a, b, k in zip(x, v, st)]
    if fold_y in grp:
        sx = max(float(np.ptp(x)), 1e-300)
        sy = max(float(np.ptp(v)), 1e-300)

        def dist(p, q) -> float:
            return float(np.hypot((p[0] - q[0]) / sx, (p[1] - q[1]) / sy))
        for r in np.flatnonzero((grp["kind"] == "fold").to_numpy()):
            fx, fy = float(grp["fold_parameter"].iloc[r]), float(grp[fold_y].iloc[r])
            if not (np.isfinite(fx) and np.isfinite(fy)):
                continue
            row = next(i for i, p in enumerate(pts) if p[0] == x[r] and p[1] == v[r])

            near = range(max(1, row - 3), min(len(pts), row + 2))
            if len(near):
                f = (fx, fy)
                j = min(near, key=lambda k, f=f: dist(pts[k - 1], f) + dist(f, pts[k])
                        - dist(pts[k - 1], pts[k]))
                pts.insert(j, [fx, fy, pts[j - 1][2], True])
    kinds = [pts[i - 1][2] if p[3] else p[2] for i, p in enumerate(pts)]
    return (np.array([p[0] for p in pts]), np.array([p[1] for p in pts]), kinds)


def branch_diagram(table: pd.DataFrame, path, *, parameter: str, units: str = "",
                   y: str = "amplitude", y_label: str | None = None, title: str | None = None,
                   label_of=None, force: bool = False) -> Path:
    """Bifurcation diagram of branch tables (:mod:`torchrom.study.branch`): ``y`` against the
    parameter, one colour per branch, stable orbits solid, unstable dashed, dotted where the
    Floquet verdict is unknown (``floquet_error``), the Hopf points
    as open circles at zero amplitude, folds as diamonds at their refined limit point, which
    the curve passes through (:func:`branch_polyline`). Only what is drawn gets a legend entry;
    the legend sits outside the axes."""
    import numpy as np

    path = check_can_write(path, force, "figure")
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8.2, 4.6), constrained_layout=True)
    colors = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    drew = {"stable": False, "unstable": False, "unknown": False, "hopf": False, "fold": False}
    for b, grp in table.groupby("branch", sort=True):
        color = colors[int(b) % len(colors)]
        name = label_of(grp.iloc[0]) if label_of else f"branch {b}"
        ax.plot([], [], color=color, label=name)
        x, v, kinds = branch_polyline(grp.sort_values("point"), parameter, y)
        for i in range(1, len(x)):
            ax.plot(x[i - 1: i + 1], v[i - 1: i + 1], color=color, lw=1.6,
                    ls={"stable": "-", "unstable": "--", "unknown": ":"}[kinds[i]])
            drew[kinds[i]] = True
        hopf = grp["kind"] == "hopf"
        if hopf.any():
            ax.plot(grp[parameter][hopf], grp[y][hopf], "o", mfc="white", color=color, ms=7,
                    zorder=3)
            drew["hopf"] = True
        fold_y = "fold_" + y
        if fold_y in grp:
            for _, row in grp[grp["kind"] == "fold"].iterrows():
                if np.isfinite(row["fold_parameter"]) and np.isfinite(row[fold_y]):
                    ax.plot(row["fold_parameter"], row[fold_y], "D", color=color, ms=7,
                            zorder=3)
                    drew["fold"] = True
    handles = [plt.Line2D([], [], color="k", ls="-", label="stable LCO")] if drew["stable"] \
        else []
    if drew["unstable"]:
        handles.append(plt.Line2D([], [], color="k", ls="--", label="unstable LCO"))
    if drew["unknown"]:
        handles.append(plt.Line2D([], [], color="k", ls=":", label="stability unknown"))
    if drew["hopf"]:
        handles.append(plt.Line2D([], [], marker="o", mfc="white", color="k", ls="none",
                                  label="Hopf (flutter) point"))
    if drew["fold"]:
        handles.append(plt.Line2D([], [], marker="D", color="k", ls="none", label="fold"))
    first = ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, title="branch")
    ax.add_artist(first)
    ax.legend(handles=handles, loc="lower left", bbox_to_anchor=(1.01, 0.0), fontsize=8)
    from .units import column_name

    name = column_name(parameter)
    ax.set_xlabel(f"{name} ({units})" if units else name)
    ax.set_ylabel(y_label or amplitude_label(table, y))
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)
    return _save(fig, path)
