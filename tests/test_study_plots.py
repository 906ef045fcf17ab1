"""Figures of sweep and branch tables (torchrom.study.plots): one line per series sorted by x,
the legend clear of the title, labels with units, the fold on the branch curve."""

from __future__ import annotations

import numpy as np
import pandas as pd

from torchrom.study import plots


def lco_table() -> pd.DataFrame:
    """A paper_lco.toml-like table: γ as hue, the stiffness switch off at one γ (a second series
    of that γ), a single extra case with the damping switch off; rows in no particular order."""
    rows = []
    for g, s, d, alts in ((0.0, 1.0, 1.0, (4e3, 7e3, 10e3)), (1e-3, 1.0, 1.0, (4e3, 7e3, 10e3)),
                          (1e-3, 0.0, 1.0, (4e3, 7e3, 10e3)), (1e-3, 1.0, 0.0, (10e3,))):
        for h in alts:
            rows.append({"altitude_ft": h, "gamma": g, "alpha": 0.28 - 190 * g, "mach": 0.7,
                         "stiffness_nl": s, "damping_nl": d, "status": "lco",
                         "amplitude": (11e3 - h) / 1e3 * (1 + s) / (1 + 1e3 * g) + 0.1 * d,
                         "frequency_hz": 1.9 + 1e-5 * h - 10 * g * s})
    t = pd.DataFrame(rows).sample(frac=1.0, random_state=3).reset_index(drop=True)
    t.attrs["units"] = {"amplitude": "ft"}
    return t


def test_one_line_per_series_sorted_by_x(drawn):
    """The hb sweep of configs/paper_lco.toml drew one zig-zag line through the series that share
    a γ: now each (γ, stiffness, damping) series is its own line, x increasing along it, and a
    series with a single case is a marker only."""
    t = lco_table()
    assert plots.series_keys(t, "altitude_ft", "gamma", None) == ["gamma", "stiffness_nl",
                                                                  "damping_nl"]
    fig = drawn(plots, plots.parameter_plot, t, "x.png", x="altitude_ft", y="frequency_hz",
                hue="gamma", title="Heavy Goland wing, Mach 0.70: post-flutter LCO (a long "
                                   "title, as the paper's configuration has)")
    ax = fig.axes[0]
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata())]
    joined = [ln for ln in lines if ln.get_linestyle() not in ("None", "none", "")]
    assert len(joined) == 3  # the three series with several altitudes
    for ln in joined:
        assert np.all(np.diff(ln.get_xdata()) > 0)
    assert len({(ln.get_color(), ln.get_marker()) for ln in lines}) == 4
    labels = [x.get_text() for lg in fig.legends for x in lg.get_texts()]
    assert "γ = 0.001 s, stiffness nonlinearity off, damping nonlinearity on" in labels
    # labels with units; the legend does not cover the title
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("altitude (ft)", "LCO frequency (Hz)")
    renderer = fig.canvas.get_renderer()
    title = fig._suptitle.get_window_extent(renderer)
    whole = fig.bbox
    for lg in fig.legends:
        box = lg.get_window_extent(renderer)
        assert not box.overlaps(title)
        assert whole.x0 <= box.x0 and box.x1 <= whole.x1  # not cut off at the figure's edge
        assert not lg.get_window_extent(renderer).overlaps(ax.get_window_extent(renderer))


def test_a_parameter_that_follows_x_does_not_split_the_line(drawn):
    """configs/goland_uq_hb.toml: 10⁴ sampled γ, α matched to each (a function of x). α once
    made every sample its own series (10⁴ legend entries, minutes to draw, axes collapsed):
    now the samples are one line. α set independently of γ (a grid) still splits it."""
    rng = np.random.default_rng(0)
    g = rng.lognormal(np.log(5e-4), 0.5, 2000)
    t = pd.DataFrame({"gamma": g, "alpha": 0.28 - 190 * g, "altitude_ft": 7000.0,
                      "status": "lco", "amplitude": 3.0 - 1e3 * g})
    assert plots.series_keys(t, "gamma", None, None) == []
    fig = drawn(plots, plots.parameter_plot, t, "x.png", x="gamma")
    assert len([ln for ln in fig.axes[0].get_lines() if len(ln.get_xdata())]) == 1
    grid = pd.concat([t.head(5).assign(alpha=a) for a in (0.1, 0.2)], ignore_index=True)
    assert plots.series_keys(grid, "gamma", None, None) == ["alpha"]


def branch_table() -> pd.DataFrame:
    """A subcritical branch (alpha): unstable from the Hopf point up to a fold at α = 0.48,
    stable beyond; the fold is detected at the first point past the turn (as
    :mod:`torchrom.study.branch` records it), its refined point lies between points 2 and 3."""
    a = [-1.0, -0.5, 0.42, 0.46, 0.18, -0.3]
    amp = [0.0, 0.7, 1.38, 1.64, 1.9, 2.1]
    t = pd.DataFrame({"branch": 0, "point": range(6), "alpha": a, "amplitude": amp,
                      "kind": ["hopf", "regular", "regular", "regular", "fold", "end"],
                      "stable": pd.array([None, False, False, True, True, True],
                                         dtype="boolean"),
                      "fold_parameter": [np.nan] * 4 + [0.48, np.nan],
                      "fold_amplitude": [np.nan] * 4 + [1.556, np.nan]})
    t.attrs["units"] = {"alpha": "1/s", "amplitude": "ft"}
    t.attrs["decision_output"] = "A_Tz"
    return t


def test_fold_is_on_the_branch_curve(drawn):
    t = branch_table()
    x, y, kinds = plots.branch_polyline(t, "alpha", "amplitude")
    i = int(np.flatnonzero(x == 0.48)[0])
    assert i == 3 and y[i] == 1.556  # between the points it lies between, not after point 4
    assert kinds[i] == "unstable" and kinds[i + 1] == "stable"  # stability changes at the fold
    fig = drawn(plots, plots.branch_diagram, t, "x.png", parameter="alpha", units="1/s")
    ax = fig.axes[0]
    fold = [ln for ln in ax.get_lines() if ln.get_marker() == "D"]
    assert len(fold) == 1
    fx, fy = fold[0].get_xdata()[0], fold[0].get_ydata()[0]
    on_curve = [ln for ln in ax.get_lines() if ln.get_marker() in ("None", "none", "")
                and len(ln.get_xdata()) == 2 and (fx, fy) in zip(ln.get_xdata(), ln.get_ydata())]
    assert len(on_curve) == 2  # the curve's segments end and start on the fold marker
    # the y axis names the decision output and its unit, not "(output units)"
    assert ax.get_ylabel() == "LCO amplitude of A_Tz (ft)"
    assert ax.get_xlabel() == "α (1/s)"


def test_note_goes_where_it_covers_no_marker(drawn):
    """A sweep where every case decayed (the sweep's own figure): the panel says "no case with an
    LCO", and the note is moved off its first place (top centre) when markers are there."""
    t = lco_table()
    t["status"], t["amplitude"] = "decay", 0.0
    fig = drawn(plots, plots.parameter_plot, t, "x.png", x="altitude_ft", y="amplitude",
                hue="gamma")
    ax = fig.axes[0]
    (note,) = ax.texts
    assert note.get_text() == plots.NO_LCO and note.get_position() == (0.5, 0.97)
    ax.set_ylim(-0.5, 0.03)  # the decays at 0 now lie at 94 % height, under the note: it moves
    moved = plots.note_clear_of_markers(ax, "moved")
    renderer = fig.canvas.get_renderer()
    bb = moved.get_window_extent(renderer)
    assert moved.get_position() != (0.5, 0.97)
    assert not any(bb.x0 < x1 and x0 < bb.x1 and bb.y0 < y1 and y0 < bb.y1
                   for x0, y0, x1, y1 in plots.marker_boxes(ax))
    assert plots.marker_boxes(ax)  # there are markers to avoid
