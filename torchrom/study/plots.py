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


def parameter_plot(table: pd.DataFrame, path, *, x: str, y: str = "amplitude",
                   hue: str | None = None, title: str | None = None,
                   force: bool = False) -> Path:
    """y against the swept parameter x, one line per value of ``hue``; markers show the status
    (filled circle: converged LCO). Returns the path written (PNG/PDF by its suffix)."""
    plt = _pyplot()
    for col in (x, y) + ((hue,) if hue else ()):
        if col not in table.columns:
            raise InputError(f"plot: no column {col!r} in the results table; it has "
                             f"{list(table.columns)}")
    path = check_can_write(path, force, "figure")
    fig, ax = plt.subplots(figsize=(6.4, 4.4), constrained_layout=True)
    groups = table.groupby(hue, sort=True) if hue else [(None, table)]
    for key, grp in groups:
        grp = grp.sort_values(x)
        label = f"{hue} = {key:g}" if hue else None
        (line,) = ax.plot(grp[x], grp[y], "-", lw=1.2, label=label)
        for status, (marker, filled) in _MARKERS.items():
            sel = grp[grp["status"] == status]
            # an unconverged case at its value when stopped (hollow): its amplitude is NaN
            col = f"last_{y}" if status == "unconverged" and f"last_{y}" in sel else y
            if len(sel):
                ax.plot(sel[x], sel[col], marker, ms=5, color=line.get_color(),
                        mfc=line.get_color() if filled else "none", ls="none")
    handles = [plt.Line2D([], [], marker=m, ls="none", color="0.3", mfc="0.3" if f else "none",
                          label=s) for s, (m, f) in _MARKERS.items()
               if (table["status"] == s).any()]
    ax.legend(handles=ax.get_legend_handles_labels()[0] + handles, fontsize=8)
    ax.set_xlabel(x)
    ax.set_ylabel(y)
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title, fontsize=10)
    return _save(fig, path)


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
        label = ", ".join(f"{b} = {k:g}" for b, k in zip(by, key)) if by else None
        label = f"{label} (n = {len(v)})" if label else f"n = {len(v)}"
        ax_h.hist(v, bins=edges, histtype="step", lw=1.4, label=label)
        ax_c.step(v, np.arange(1, len(v) + 1) / len(v), where="post", lw=1.4, label=label)
    ax_h.set_xlabel(f"{value} (decay = 0)")
    ax_h.set_ylabel("cases")
    ax_c.set_xlabel(f"{value} (decay = 0)")
    ax_c.set_ylabel("cumulative probability")
    ax_c.set_ylim(0, 1.02)
    for ax in (ax_h, ax_c):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
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
    ax.set_xlabel("gamma (s)")
    ax.set_ylabel(f"{column} (decay = 0)")
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
    ax_b.set_xlabel(x or "case")
    ax_b.set_ylabel("amplitude (LCO; threshold: initial amplitude)")
    ax_r.set_xscale("log")
    ax_r.set_xlabel("initial amplitude")
    ax_r.set_ylabel("final amplitude (decay = 0, unbounded at the top)")
    if x:
        ax_r.legend(fontsize=7)
    for ax in (ax_b, ax_r):
        ax.grid(alpha=0.3)
    if title:
        fig.suptitle(title, fontsize=10)
    return _save(fig, path)
