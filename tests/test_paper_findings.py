"""The findings checks (torchrom.paper.findings), the report and the figures on synthetic tables
built to follow — or to break — the paper's statements."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from torchrom.cli import main
from torchrom.errors import InputError
from torchrom.paper import findings as fnd
from torchrom.study import figures

ALTS = (4000.0, 7000.0, 10000.0)
SPAN = 20.0


def paper_like_table(changes=None) -> pd.DataFrame:
    """A Fig. 10–13 table with the paper's trends: amplitude falls with altitude and γ (slowly
    to 1e-4, then sharply), frequency rises with altitude and falls with γ except at the lowest
    altitude for γ = 1e-3; ``changes[(h, γ, stiffness_nl)] = amplitude`` overrides a value."""
    rows = []
    curves = [(g, 1.0, 1.0) for g in fnd.PAPER_GAMMAS] + [(1e-3, 0.0, 1.0), (0.0, 0.0, 1.0)]
    for h in ALTS:
        for g, s, d in curves:
            base = 3.0 - 4.6e-4 * (h - 4000.0)
            drop = {0.0: 1.0, 1e-5: 0.999, 1e-4: 1.0 - 0.1 * (h - 4000) / 6000, 5e-4: 0.6,
                    1e-3: 0.4}[g]
            amp = base * drop * (1.0 if s else 0.97)
            freq = 1.8 + 2e-5 * (h - 4000) - 60.0 * g
            if h == 4000.0 and g == 1e-3:
                freq += 0.05
            status = "lco"
            if s == 0 and g == 0:
                status, amp = "diverged", 12.0
            amp = (changes or {}).get((h, g, s), amp)
            rows.append({"case_id": f"{h}-{g}-{s}", "altitude_ft": h, "mach": 0.7, "gamma": g,
                         "alpha": 0.27 - 90 * g, "stiffness_nl": s, "damping_nl": d,
                         "status": status, "amplitude": amp, "amplitude_pct_span": 100 * amp / SPAN,
                         "frequency_hz": freq, "ratio_q1_q2": 10 + 1e3 * g - 5e-4 * (h - 4000),
                         "ratio_q1_q4": 50 - (5 if (h == 4000 and g == 1e-3) else 0) + g,
                         "steps": 25000})
    for h in (12000.0, 13000.0):
        rows.append({"case_id": f"{h}-lin", "altitude_ft": h, "mach": 0.7, "gamma": 0.0,
                     "alpha": 0.27, "stiffness_nl": 0.0, "damping_nl": 1.0, "status": "decay",
                     "amplitude": 1e-4, "amplitude_pct_span": 5e-4, "frequency_hz": 2.0,
                     "ratio_q1_q2": 9.0, "ratio_q1_q4": 50.0, "steps": 9000})
    return pd.DataFrame(rows)


def alpha_gamma() -> pd.DataFrame:
    g = np.linspace(0, 1.2e-3, 7)
    return pd.DataFrame({"gamma": g, "alpha": 0.27 - 90 * g, "reference_altitude_ft": 11252.0,
                         "mach": 0.7, "flutter_frequency_hz": 2.09 - 10 * g,
                         "baseline_alpha": 0.2565, "baseline_gamma": 1.338e-4})


def histories(table: pd.DataFrame) -> pd.DataFrame:
    t = np.arange(0.0, 20.0, 0.005)
    frames = []
    for r in table[(table["altitude_ft"] == 10000.0) & (table["gamma"] == 1e-3)].itertuples():
        y = r.amplitude * np.tanh(t / 5) * np.sin(2 * np.pi * r.frequency_hz * t)
        y += 0.01 * r.amplitude * np.sin(6 * np.pi * r.frequency_hz * t)  # 1 % third harmonic
        frames.append(pd.DataFrame({"case_id": r.case_id, "t": t, "A_Tz": y}))
    return pd.concat(frames, ignore_index=True)


def by_key(found):
    return {f.key: f for f in found}


def test_a_table_with_the_papers_trends_agrees_everywhere():
    t = paper_like_table()
    found = by_key(fnd.evaluate(t, histories(t), alpha_gamma(), 11252.0, ["bending"] * 4))
    assert {k: f.verdict for k, f in found.items() if f.verdict != fnd.AGREE} == {}
    assert found["harmonic_lco"].numbers["cases"][0]["thd"] == pytest.approx(0.01, abs=0.003)
    assert found["steps"].numbers["median"] == 25000


def test_each_acceptance_check_detects_its_disagreement():
    # γ = 1e-5 3 % above γ = 0 at 7,000 ft
    t = paper_like_table()
    at = (t.altitude_ft == 7000) & (t.stiffness_nl == 1)
    base = float(t[at & (t.gamma == 0)].amplitude.iloc[0])
    t.loc[at & (t.gamma == 1e-5), "amplitude"] = 1.03 * base
    f = fnd.gamma_small_matches_zero(t)
    assert f.verdict == fnd.DIFFER and f.numbers["relative_difference"][7000.0] == \
        pytest.approx(0.03)
    assert fnd.amplitude_not_increasing_with_gamma(t).verdict == fnd.DIFFER
    # stiffness nonlinearity off changes γ = 1e-3 more than going from 5e-4 to 1e-3
    t = paper_like_table()
    sel = (t.gamma == 1e-3) & (t.stiffness_nl == 0)
    t.loc[sel, "amplitude"] *= 0.2
    assert fnd.stiffness_matters_little_at_large_gamma(t).verdict == fnd.DIFFER
    # a linear case below the flutter altitude that 'reaches an LCO'
    t = paper_like_table()
    t.loc[(t.gamma == 0) & (t.stiffness_nl == 0) & (t.altitude_ft == 4000), "status"] = "lco"
    assert fnd.linear_statuses(t, 11252.0).verdict == fnd.DIFFER


def test_cases_without_a_converged_lco_are_not_compared():
    t = paper_like_table()
    t.loc[t.gamma.isin([0.0, 1e-5]) & (t.stiffness_nl == 1), "status"] = "unconverged"
    f = fnd.gamma_small_matches_zero(t)
    assert f.verdict == fnd.NA and len(f.numbers["altitudes_without_both_lcos"]) == 3
    C = fnd.curve_table(t)
    assert C[0.0].isna().all() and C.loc[list(ALTS), 1e-4].notna().all()


def test_report_and_figures_from_the_table(tmp_path):
    from torchrom.paper.report import render

    t = paper_like_table()
    h = histories(t)
    ag = alpha_gamma()
    found = fnd.evaluate(t, h, ag, 11252.0)
    for name, fn in figures.TABLE_FIGURES.items():
        path = fn(ag if name == "fig9" else t, tmp_path / f"{name}.png")
        assert path.stat().st_size > 10_000
    assert figures.fig11(t, h, tmp_path / "fig11.png").stat().st_size > 10_000
    with pytest.raises(InputError, match="already exists"):
        figures.fig10(t, tmp_path / "fig10.png")
    with pytest.raises(InputError, match="no column 'gamma'"):
        figures.fig10(t.drop(columns="gamma"), tmp_path / "other.png")
    summary = _summary()
    text = render(summary, found, t, ag)
    for heading in ("## Table 2", "## Flutter point", "## Table 3", "## Fig. 9", "## Fig. 10",
                    "## Fig. 12", "## Fig. 13a", "## The paper's findings"):
        assert heading in text
    assert "diverged" in text  # the linear curve's status is shown, not a number
    # an altitude where none of the curves has a case is left out, not a row of dashes
    fig10 = text.split("## Fig. 10")[1].split("## Fig. 12")[0]
    assert "12,000" not in fig10 and "| –" not in fig10
    # modes are named with their content shares, a small margin stated
    assert "bending (0.44 bending, 0.29 in-plane, 0.26 torsion)" in text
    assert "mode 2 in-plane by 0.405 vs 0.392 torsion (margin 0.013)" in text
    assert "mode 2 has the largest in-plane share" in text
    # the SDP solver's status: not converged, said so
    summary["decomposition_band"] = {"members": [{"name": "sdp", "solver": {
        "solver": "SCS", "status": "solved (inaccurate - reached max_iters)",
        "iterations": 2000, "optimum_t": 3.6e-3, "min_eigenvalue_scaled_projected": -8e-3}}]}
    from torchrom.paper.report import sdp_status_lines

    status = " ".join(sdp_status_lines(summary["decomposition_band"]))
    assert "reached max_iters" in status and "did **not** converge" in status


def test_plot_command(tmp_path):
    t = paper_like_table()
    t.to_parquet(tmp_path / "results.parquet")
    histories(t).to_parquet(tmp_path / "histories.parquet")
    for name in ("fig10", "fig11", "fig12", "fig13"):
        assert main(["plot", str(tmp_path / "results.parquet"), "--figure", name, "--out",
                     str(tmp_path / f"{name}.png")]) == 0
    assert main(["plot", str(tmp_path / "missing.parquet"), "--figure", "fig10", "--out",
                 str(tmp_path / "x.png")]) == 2


def _summary() -> dict:
    contents = ({"bending": 0.438, "torsion": 0.262, "in-plane": 0.294, "axial": 0.006},
                {"bending": 0.194, "torsion": 0.392, "in-plane": 0.405, "axial": 0.009})
    modes = [{"mode": i + 1, "frequency_hz": f, "paper_hz": p, "diff_pct": 100 * (f / p - 1),
              "kind": kind, "content": c}
             for i, ((f, p), kind, c) in enumerate(zip(((1.69, 1.69), (4.03, 3.051)),
                                                       ("bending", "in-plane"), contents))]
    point = {"altitude": 11252.0, "frequency_hz": 2.09, "velocity": 750.7,
             "dynamic_pressure": 475.5}
    return {"quick": True, "version": "x", "seconds": {"total": 1.0}, "cpu_seconds": {},
            "reused": [], "lco": {"cases": 1, "case_steps": 10, "us_per_case_step": 3.0,
                                  "reused": False},
            "flutter": {"state_space": point, "pk": point, "mach": 0.7,
                        "baseline_alpha": 0.2565, "baseline_gamma": 1.338e-4,
                        "paper": {"altitude": 11275.0, "frequency_hz": 1.975}, "table2": modes},
            "linear": {"flutter_altitude_sim_ft": 11252.1, "flutter_altitude_eig_ft": 11252.0,
                       "difference_ft": 0.1, "growth": [{"altitude_ft": 11000.0,
                                                         "sigma_sim": 0.1, "sigma_eig": 0.1}],
                       "table3": [{"altitude_ft": 4000.0, "frequency_sim_hz": 2.0,
                                   "frequency_eig_hz": 2.0, "paper_hz": 1.851}]},
            "linear_window": 0.3, "linear_t_end": 12.0}
