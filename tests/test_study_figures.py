"""The paper's figures (torchrom.study.figures) as drawn: coincident curves stay visible, the
two flutter altitudes are told apart, log axes read plain numbers, every axis carries its unit,
our values are named as ours (the findings and report are in test_paper_findings.py)."""

from __future__ import annotations

import numpy as np

from torchrom.reference import paper_reference
from torchrom.study import figures

from .test_paper_findings import alpha_gamma, paper_like_table


def _curve_lines(ax):
    return [ln for ln in ax.get_lines() if not ln.get_label().startswith("_")
            and "flutter" not in ln.get_label() and "Table 3" not in ln.get_label()]


def test_coincident_curves_stay_visible(drawn):
    """Every curve has its own marker and line style, and where two curves coincide (within a
    line width; here γ = 1e-5 equals γ = 0 exactly) the one drawn later is thinner with smaller
    markers, so the one below shows around it."""
    t = paper_like_table()
    zero = t[(t["gamma"] == 0.0) & (t["stiffness_nl"] == 1)].set_index("altitude_ft")
    same = t["gamma"] == 1e-5
    t.loc[same, "amplitude"] = zero.loc[t.loc[same, "altitude_ft"], "amplitude"].to_numpy()
    fig = drawn(figures, figures.fig10, t, "x.png", flutter_altitude_ft=11349.0)
    lines = _curve_lines(fig.axes[0])
    assert len(lines) == 6
    assert len({ln.get_marker() for ln in lines}) == len(lines)
    assert len({str(ls) for ls, *_ in figures.CURVE_STYLES}) == len(figures.CURVE_STYLES)
    ylim = fig.axes[0].get_ylim()
    coincident = 0
    for i, a in enumerate(lines):
        for b in lines[i + 1:]:
            if len(a.get_xdata()) == len(b.get_xdata()) and np.allclose(
                    a.get_ydata(), b.get_ydata(), atol=0.01 * (ylim[1] - ylim[0])):
                coincident += 1
                assert b.get_linewidth() < a.get_linewidth()
                assert b.get_markersize() < a.get_markersize()
                assert b.get_zorder() > a.get_zorder()
    assert coincident >= 1


def test_flutter_altitudes_are_told_apart(drawn):
    fig = drawn(figures, figures.fig10, paper_like_table(), "x.png",
                flutter_altitude_ft=11349.0)
    ax = fig.axes[0]
    vlines = [ln for ln in ax.get_lines() if "flutter altitude" in ln.get_label()]
    assert sorted(ln.get_label() for ln in vlines) == [
        "our flutter altitude 11,349 ft", "paper's flutter altitude 11,275 ft"]
    ours, paper = sorted(vlines, key=lambda ln: ln.get_label())
    assert ours.get_color() != paper.get_color()
    assert ours.get_linestyle() != paper.get_linestyle()
    texts = [t.get_text().strip() for t in ax.texts]
    assert "ours 11,349 ft" in texts and "paper 11,275 ft" in texts
    legend = [t.get_text() for lg in fig.legends for t in lg.get_texts()]
    assert "our flutter altitude 11,349 ft" in legend


def test_log_axes_read_plain_numbers(drawn):
    fig = drawn(figures, figures.fig13, paper_like_table(), "x.png")
    for ax in fig.axes[:2]:
        labels = [t.get_text() for t in ax.yaxis.get_ticklabels(which="both")
                  if t.get_text() and t.get_visible()]
        assert labels
        for text in labels:
            assert float(text) > 0, text  # '20', '50', '100': no 2×10¹, 10^{1} or $...$


def test_axis_labels_carry_units_and_ours_is_named(drawn):
    t = paper_like_table()
    for fn, kw in ((figures.fig10, {}), (figures.fig12, {"table3": {4000.0: 1.87}}),
                   (figures.fig13, {})):
        fig = drawn(figures, fn, t, "x.png", **kw)
        for ax in fig.axes:
            for label in (ax.get_xlabel(), ax.get_ylabel()):
                if label:
                    assert label.endswith(")") and "(" in label, label
    fig = drawn(figures, figures.fig12, t, "x.png", table3={4000.0: 1.87},
                flutter_altitude_ft=11349.0, flutter_frequency_hz=1.97)
    legend = [x.get_text() for lg in fig.legends for x in lg.get_texts()]
    assert "ours, Table 3: growing response (linear)" in legend
    assert "paper Table 3: growing response (linear)" in legend
    assert "our flutter point (1.970 Hz)" in legend


def test_fig9_draws_every_alpha_the_paper_states(drawn):
    ref = paper_reference()
    assert ref.fig9_points == ((ref.beta0_s, ref.alpha0_per_s),)  # Eq. 46, the only one stated
    fig = drawn(figures, figures.fig9, alpha_gamma(), "x.png")
    ax = fig.axes[0]
    stars = [ln for ln in ax.get_lines() if ln.get_label().startswith("paper: ")]
    assert [(float(s.get_xdata()[0]), float(s.get_ydata()[0])) for s in stars] == list(
        ref.fig9_points)
    assert any(ref.fig9_note in t.get_text() for t in ax.texts)
    # ours labelled at the paper's γ levels that the table holds (0 and 1e-3 here)
    assert {t.get_text() for t in ax.texts} >= {"0.2700", "0.1800"}


def test_table2_names_a_mixed_mode_with_its_shares(drawn):
    import pandas as pd

    modes = pd.DataFrame({"mode": [1, 2], "frequency_hz": [1.66, 10.78],
                          "kind": ["bending", "bending"],
                          "content": [{"bending": 0.999, "torsion": 0.001},
                                      {"bending": 0.438, "torsion": 0.262, "in-plane": 0.294}]})
    fig = drawn(figures, figures.table2, modes, "x.png")
    texts = [t.get_text() for t in fig.axes[0].texts]
    assert "bending" in texts and "bending (b .44, ip .29, t .26)" in texts
