"""``torchrom paper``: the whole study end to end (the quick form by default, the full one slow).

The quick run builds the Goland FE model, identifies the 9L12D ROM, computes the aerodynamics on
its basis, checks the simulator against the eigenvalues, runs the coarse LCO sweep and writes the
figures and the report; a second run must reuse every cached file. The Fig. 10 acceptance
findings are asserted on the table; where our model disagrees with the paper the test is an
explicit, strict expected failure that names the disagreement (the report gives the numbers and
the causes) — it turns into an error as soon as the model agrees, so the mark cannot go stale.
"""

from __future__ import annotations

import dataclasses
import json
import shutil

import pandas as pd
import pytest

from torchrom.cli import main
from torchrom.errors import InputError
from torchrom.paper.study import FIGURE_FILES, run_paper

#: Fig. 10 acceptance findings on which the current Goland model differs from the paper, with
#: the reason (see report.md, "Why we differ"); measured on the quick and the full study
KNOWN_DIFFERENCES = {
    "stiffness_nl_small_at_gamma_1e-3": "at γ = 1e-3 s our stiffness nonlinearity raises the "
                                        "amplitude by 0.5-1.3 ft, more than the 5e-4 -> 1e-3 s "
                                        "change (0.3-0.8 ft); on the updated wing it fails for "
                                        "every admissible damping decomposition (report.md's "
                                        "band)",
    "amplitude_decreases_with_gamma": "one consecutive-γ step raises the amplitude by more than "
                                      "0.5 %: +0.7 % from γ = 0 to 1e-5 s at 7,000 ft (quick) or "
                                      "5,000 ft (full) — the large γ = 0 LCOs near the 5:1/6:1 "
                                      "internal resonance with the in-plane mode (experiments/"
                                      "results/hb_harmonic_convergence.md), whose amplitude "
                                      "moves by ~1 % with a 1e-5 change of the FE model (the "
                                      "CQUAD4's residual bending flexibility turned the quick "
                                      "study's verdict); it also depends on the damping "
                                      "decomposition (report.md's band)",
}
#: on the calibrated wing (the default before issue 15) "gamma_1e-5_equals_0" differed too
FULL_STUDY_DIFFERENCES = dict(KNOWN_DIFFERENCES)
ACCEPTANCE = ("gamma_1e-5_equals_0", "amplitude_decreases_with_gamma",
              "stiffness_nl_small_at_gamma_1e-3", "linear_statuses")


#: findings whose verdict sits on its threshold, so that the platform decides it (the BLAS
#: kernel's summation order moves the γ = 0 LCOs by ~1 %): their physics is asserted instead
AT_THRESHOLD = ("amplitude_decreases_with_gamma",)


def _acceptance_params():
    for key in ACCEPTANCE:
        if key in AT_THRESHOLD:
            continue
        marks = ([pytest.mark.xfail(strict=True, reason=KNOWN_DIFFERENCES[key])]
                 if key in KNOWN_DIFFERENCES else [])
        yield pytest.param(key, marks=marks, id=key)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("paper") / "quick"
    assert main(["paper", "--quick", "--out", str(out), "--json", str(out.parent / "s.json")]) \
        == 0
    return out


def _summary(out):
    return json.loads((out / "paper.json").read_text())


def test_quick_writes_every_figure_and_the_report(quick):
    for name in FIGURE_FILES.values():
        assert (quick / "figures" / name).stat().st_size > 10_000
    text = (quick / "report.md").read_text()
    for heading in ("## Table 2", "## Flutter point", "## Table 3", "## Fig. 9", "## Fig. 10",
                    "## Fig. 12", "## Fig. 13a", "## The paper's findings"):
        assert heading in text
    for name in ("goland.bdf", "rom.npz", "basis.npz", "aero.npz", "flutter.json"):
        assert (quick / "model" / name).is_file()
    table = pd.read_parquet(quick / "sweeps" / "lco" / "results.parquet")
    for col in ("case_id", "altitude_ft", "mach", "velocity", "dynamic_pressure", "density",
                "alpha", "gamma", "stiffness_nl", "damping_nl", "status", "amplitude",
                "amplitude_pct_span", "frequency_hz", "ratio_q1_q2", "ratio_q1_q4", "steps",
                "t_end", "config_hash", "version"):
        assert col in table.columns


def test_quick_simulator_reproduces_the_eigenvalue_flutter_altitude(quick):
    lin = _summary(quick)["linear"]
    assert abs(lin["difference_ft"]) < 50.0  # acceptance (observed < 1 ft)
    for row in lin["table3"]:
        assert row["frequency_sim_hz"] == pytest.approx(row["frequency_eig_hz"], rel=1e-3)


def test_quick_damping_cause_check(quick):
    """The Fig. 10 cases with the exact Kelvin–Voigt tensors: the γ = 1e-5 s curve coincides
    with γ = 0 (measured +0.3 %, the 2 % of the acceptance), so the decomposition's D̄2, D̄3
    cause that difference of the main study; the report says so."""
    check = _summary(quick)["damping_check"]
    verdicts = {f["key"]: f["verdict"] for f in check["findings"]}
    assert set(verdicts) == {"gamma_1e-5_equals_0", "amplitude_decreases_with_gamma",
                             "stiffness_nl_small_at_gamma_1e-3"}
    assert verdicts["gamma_1e-5_equals_0"] == "agree"
    assert all(r["status"] == "lco" for r in check["table"])
    text = (quick / "report.md").read_text()
    assert "## Cause check: the same cases with the exact Kelvin–Voigt damping" in text
    assert "`gamma_1e-5_equals_0` agrees with the paper" in text
    # dissipation on the γ = 0 LCO cycle: both tensor sets are semidefinite, so the nonlinear
    # terms can cancel at most all of the linear dissipation (ratio ≥ −1; 1e-6 for the
    # rounding-level λ_min and the finite-difference q̇); the exact tensors cancel nearly all of
    # it on this nearly inextensional motion (measured −0.993 in the full study), and more than
    # the decomposition does (−0.848 full)
    d = check["dissipation"]
    assert d["status"] == "lco"
    assert d["exact_ratio"] >= -1.0 - 1e-6 and d["decomposition_ratio"] >= -1.0 - 1e-6
    assert d["exact_ratio"] < -0.9
    assert d["exact_ratio"] < d["decomposition_ratio"]
    assert "nonlinear / linear dissipation" in text


def test_quick_stiffness_cause_section(quick):
    """Issue 28: the γ = 1e-3 s LCO at 4,000 ft with and without the stiffness nonlinearity by
    harmonic balance, the energy per cycle of each term, and the dual modes' effect; in the
    report under its heading. Measured (full study): 13.1 vs 6.4 % of span; the dual modes'
    quasi-static following turns the nonlinear damping from adding ~12x the linear one to
    cancelling ~0.8 of it."""
    from torchrom.paper.report import STIFFNESS_CAUSE_HEADING

    cause = _summary(quick)["stiffness_cause"]
    rows = {r["switch"]: r for r in cause["rows"]}
    both, none = rows["both nonlinearities"], rows["no stiffness nonlinearity"]
    assert both["status"] == none["status"] == "lco"
    assert both["amplitude"] > 1.5 * none["amplitude"]
    for r in (both, none):  # the stiffness terms do no work over a cycle (rounding)
        total = sum(v for k, v in r["terms"].items() if "conservative" not in k)
        assert abs(r["terms"]["K2 (conservative)"]) < 1e-6 * total
    assert none["following"]["dual coordinates zero"] > 1.0
    assert none["following"]["dual coordinates quasi-static"] < 0.0
    assert f"## {STIFFNESS_CAUSE_HEADING}" in (quick / "report.md").read_text()


@pytest.mark.parametrize("key", list(_acceptance_params()))
def test_quick_acceptance_findings(quick, key):
    found = {f["key"]: f for f in _summary(quick)["findings"]}
    assert found[key]["acceptance"]
    assert found[key]["verdict"] == "agree", found[key]["ours"]


def test_quick_amplitude_falls_with_gamma_beyond_the_first_step(quick):
    """Fig. 10's "the LCO amplitude decreases as γ increases", asserted as physics: its verdict
    at a 0.5 % rise sits on the first step's (γ = 0 to 1e-5 s: +0.7 % at one altitude here,
    under 0.5 % with OpenBLAS's Sandybridge kernel). Every step from γ ≥ 1e-5 s lowers the
    amplitude (by 1-30 % in the studies), and the first step moves it by at most 1.5 %, the
    ~1 % that a 1e-5 change of the model or the platform moves the γ = 0 LCOs by, plus margin
    (KNOWN_DIFFERENCES)."""
    found = {f["key"]: f for f in _summary(quick)["findings"]}["amplitude_decreases_with_gamma"]
    steps = found["numbers"]["steps"]
    assert steps
    later = [s["relative_change"] for s in steps if s["gamma_from"] >= 1e-5]
    first = [s["relative_change"] for s in steps if s["gamma_from"] == 0.0]
    assert later and max(later) < 0.0, later
    assert first and max(abs(r) for r in first) <= 0.015, first


def test_quick_both_wing_variants_side_by_side(quick):
    """Issue 15: the study's wing is the updated variant; the calibrated one runs beside it
    (pipeline, the same LCO sweep, the same findings) and report.md shows both: Table 2,
    flutter, Table 3, findings."""
    summary = _summary(quick)
    assert summary["variant"] == "updated"
    other = summary["variants"]["calibrated"]
    assert [r["kind"] for r in other["flutter"]["table2"]][3] == "in-plane"
    # the updated wing's mode 5 has the largest in-plane share (its label wins by 0.013 only:
    # the report states the margin, tests/test_fe_goland.py shows it flip with the store)
    t2 = summary["flutter"]["table2"]
    assert max(t2, key=lambda r: r["content"]["in-plane"])["mode"] == 5
    assert "mode 5 in-plane by" in (quick / "report.md").read_text()
    assert {f["key"] for f in other["findings"]} == {f["key"] for f in summary["findings"]}
    text = (quick / "report.md").read_text()
    assert "## The two wing variants side by side" in text
    section = text.split("## The two wing variants side by side")[1]
    for part in ("Table 2", "Flutter at Mach 0.70", "Table 3", "findings",
                 "updated (this study)", "calibrated"):
        assert part in section
    assert (quick / "model_calibrated" / "rom.npz").is_file()


def test_quick_decomposition_band(quick):
    """Issue 15: the Fig. 10 check cases over admissible damping decompositions from the
    optimum decomposition (θ = 0) to the exact tensors (θ = 1), each member checked (semidefinite
    to rounding, K2 reproduced to rounding, K3 within the decomposition's own 1.5 %); the band
    contains each member's amplitude, and every finding has a verdict over the members."""
    from torchrom.paper.band import DEPENDS, FAILS, HOLDS, NOT_ASSESSABLE

    band = _summary(quick)["decomposition_band"]
    # the family's members, then the criterion's SDP optimum (off the segment: θ null)
    assert [m["theta"] for m in band["members"]] == [0.0, 0.5, 1.0, None]
    assert band["members"][-1]["name"] == "sdp"
    assert band["admissible"]
    for m in band["members"]:
        assert m["min_eigenvalue_scaled"] >= -1e-9 and m["reproduction_error_K2"] < 1e-12
    # the exact tensors reproduce the identified K3 to identification accuracy; the optimum
    # decomposition only to ~1 % (its enforcement), and restoring it makes it indefinite
    exact, sdp = band["members"][2], band["members"][3]
    assert exact["strict"] and not band["members"][0]["strict"]
    # the exact tensors are a feasible point of the SDP: its optimum is no lower (SCS's
    # tolerance 1e-5, 2,000 iterations: 1e-4)
    assert sdp["solver"]["optimum_t"] >= exact["min_eigenvalue_scaled"] - 1e-4
    assert band["decomposition_restored_min_eigenvalue"] < 0
    assert set(band["findings"]) == {"gamma_1e-5_equals_0", "amplitude_decreases_with_gamma",
                                     "stiffness_nl_small_at_gamma_1e-3"}
    assert set(band["findings"].values()) <= {HOLDS, FAILS, DEPENDS, NOT_ASSESSABLE}
    # the ends are the main study's and the exact check's tables
    main = pd.read_parquet(quick / "sweeps" / "lco" / "results.parquet")
    row = main[(main["altitude_ft"] == 4000.0) & (main["gamma"] == 1e-3)
               & (main["stiffness_nl"] == 1)].iloc[0]
    b = pd.DataFrame(band["band"])
    cell = b[(b["altitude_ft"] == 4000.0) & (b["curve"] == "0.001")].iloc[0]
    assert cell["min"] <= row["amplitude_pct_span"] <= cell["max"]
    assert "## Fig. 10 over admissible damping decompositions" in (quick / "report.md").read_text()


def test_quick_every_differing_finding_is_explained(quick):
    summary = _summary(quick)
    text = (quick / "report.md").read_text()
    differ = [f["key"] for f in summary["findings"] if f["verdict"] == "differ"]
    for key in differ:
        assert f"`{key}`" in text
    if differ:
        assert "### Why we differ" in text


def test_quick_second_run_reuses_the_cache(quick):
    lines = []
    summary = run_paper(quick, quick=True, log=lines.append)
    assert {"rom.npz", "aero.npz", "flutter.json"} <= set(summary["reused"])
    assert summary["lco"]["reused"]
    # no silent stage: every stage numbered out of the same total, in order, with an ETA
    stages = [ln for ln in lines if ln.startswith("stage ")]
    total = len(summary["seconds"]) - 1  # without "total"
    assert [ln.split(":")[0] for ln in stages] == [f"stage {k}/{total}"
                                                  for k in range(1, total + 1)]
    assert all(ln.endswith(")") and "(ETA " in ln for ln in stages)
    # every sweep of the study, with the certificate's seconds within the solver's
    assert {"lco", "lco_exact_damping", "lco_calibrated"} <= set(summary["sweeps"])
    assert all(0.0 <= v["certificate_s"] <= v["wall_time_s"]
               for v in summary["sweeps"].values())


@pytest.fixture(scope="module")
def quick_newmark(quick, tmp_path_factory):
    """``torchrom paper --quick --method newmark`` (the paper's time marching) from a copy of
    the quick study (its model cache warm: the FE model, ROM and aerodynamics are reused)."""
    out = tmp_path_factory.mktemp("paper_newmark") / "quick"
    shutil.copytree(quick, out)
    assert main(["paper", "--quick", "--method", "newmark", "--out", str(out)]) == 0
    return out


#: the largest LCO (4,000 ft, γ = 0, ~25 % of span)
LARGEST_LCO = {"altitude_ft": 4000.0, "gamma": 0.0, "stiffness_nl": 1.0, "damping_nl": 1.0}


def _hb_newmark(quick, quick_newmark):
    hb = pd.read_parquet(quick / "sweeps" / "lco" / "results.parquet")
    nm = pd.read_parquet(quick_newmark / "sweeps" / "lco_newmark" / "results.parquet")
    keys = ["altitude_ft", "gamma", "stiffness_nl", "damping_nl"]
    both = nm.merge(hb, on=keys, suffixes=("_nm", "_hb"))
    assert len(both) == len(nm) == len(hb)
    return both


def test_paper_default_method_is_harmonic_balance():
    """Issue 36 item 5: the study's default solver is the certified periodic one; the command
    line's default (kept apart so that it parses without torch) is the same."""
    from torchrom.commands.paper import PAPER_METHODS
    from torchrom.paper.study import PAPER_METHOD
    from torchrom.study.solvers import SOLVERS

    assert PAPER_METHODS[0] == PAPER_METHOD == "hb"
    assert not SOLVERS[PAPER_METHOD].marches_time and SOLVERS["newmark"].marches_time


def test_quick_hb_agrees_with_newmark(quick, quick_newmark):
    """The Goland quick-study cases: every status as time marching decides it, LCO amplitudes
    within 0.5 % and frequencies within 0.2 % of the paper-setting Newmark sweep (issue
    acceptance). Every LCO of both is certified and none has an unknown stability (the HB
    rows by the Fourier certificate or shooting, the Newmark rows by shooting on the discrete
    map: the updated wing's large, nearly undamped γ = 0 orbits, where HB at H ≤ 13 stops
    1–2 % away and the Newmark transient ~1 % short, are finished to the same orbit)."""
    both = _hb_newmark(quick, quick_newmark)
    assert (both["status_nm"] == both["status_hb"]).all()
    lco = both[both["status_nm"] == "lco"]
    assert len(lco) >= 17
    assert lco["certified_nm"].all() and lco["certified_hb"].all()
    amp = (lco["amplitude_hb"] / lco["amplitude_nm"] - 1).abs()
    freq = (lco["frequency_hz_hb"] / lco["frequency_hz_nm"] - 1).abs()
    assert amp.max() <= 5e-3, lco.loc[amp.idxmax(), ["altitude_ft", "gamma"]].to_dict()
    assert freq.max() <= 2e-3
    # the stability of record: resolved for every LCO, the same verdict from both methods,
    # and the paper's supercritical LCOs are stable
    for suffix in ("_nm", "_hb"):
        assert lco["stable" + suffix].notna().all()
        assert lco["stable" + suffix].astype(bool).all()
    text = (quick / "report.md").read_text()
    assert "## Harmonic balance confirmed by time marching" in text
    assert "## LCO branches from the flutter point" in text
    summary = _summary(quick)
    assert summary["method"] == "hb" and _summary(quick_newmark)["method"] == "newmark"
    confirm = pd.DataFrame(summary["hb"]["confirmation"])
    ok = confirm[confirm["newmark_status"] == "lco"]
    big = (ok[list(LARGEST_LCO)] == pd.Series(LARGEST_LCO)).all(axis=1)
    assert len(ok[~big]) >= 6 and (ok.loc[~big, "amplitude_diff_pct"].abs() <= 0.5).all()
    # the largest LCO: time marching from the HB orbit ends within 1 % (its transient attracts
    # by ~1 % per period, so a finite run stops short)
    assert (ok.loc[big, "amplitude_diff_pct"].abs() <= 1.0).all()
    assert (quick / "figures" / FIGURE_FILES["branches"]).stat().st_size > 10_000


def test_quick_findings_by_method(quick, quick_newmark):
    """Issue 36 item 5: the findings of both methods have the same verdicts except the Sec. IV
    step count, which only the paper's time marching can assess (HB's ``steps`` are Newton
    iterations); the time-marching study assesses it from its transients."""
    hb = {f["key"]: f for f in _summary(quick)["findings"]}
    nm = {f["key"]: f for f in _summary(quick_newmark)["findings"]}
    assert set(hb) == set(nm)
    assert hb["steps"]["verdict"] == "not assessable" and "--method newmark" in hb["steps"]["ours"]
    assert nm["steps"]["verdict"] in ("agree", "differ") and nm["steps"]["numbers"]["median"]
    changed = {k for k in hb if k != "steps" and hb[k]["verdict"] != nm[k]["verdict"]}
    assert not changed, {k: (hb[k]["ours"], nm[k]["ours"]) for k in changed}


def test_quick_branches_are_supercritical(quick):
    """The branches from the flutter point in altitude (γ = 0 and 1e-3 s): both leave the Hopf
    point stable, without folds, down to 4,000 ft (the paper's supercritical LCOs); the damped
    branch is stable all along. Every orbit point is certified by shooting and its stability
    (the shooting monodromy's) resolved, except the points listed as uncertified (their finish
    failed), at most one per branch."""
    for row in _summary(quick)["hb"]["branches"]:
        assert row["stable_from_hopf"] and not row["folds_ft"]
        assert row["lowest_altitude_ft"] == pytest.approx(4000.0)
        assert 0 < row["amplitude_pct_span_there"] < 50
        assert len(row["uncertified_altitudes_ft"]) <= 1
        if row["gamma"] > 0:
            assert not row["unstable_altitudes_ft"]
    table = pd.read_csv(quick / "tables" / "lco_branches.csv")
    lco = table[table["status"] == "lco"]
    assert lco["certified"].astype(bool).all() and lco["stable"].notna().all()
    assert (lco["orbit_error"] <= 1e-3).all()


def test_secondary_sweeps_seed_only_unconverged_cases_and_are_cached_apart():
    """The study's secondary HB sweeps seed only unconverged cases; their cache key differs
    from the main sweep's although the configuration's own hash is the same (before the key
    included the solver's settings, a run reused the other setting's tables)."""
    from torchrom.paper.study import _secondary, _sweep_key, config_path
    from torchrom.study.config import load_sweep_config, with_method

    cfg = with_method(load_sweep_config(config_path("paper_lco.toml")), "hb")
    assert cfg.hb.seed == "unresolved"
    sec = _secondary(cfg)
    assert sec.hb.seed == "unconverged" and sec.hash == cfg.hash
    assert _sweep_key(sec, "m", "cpu", "float64") != _sweep_key(cfg, "m", "cpu", "float64")
    newmark = load_sweep_config(config_path("paper_lco.toml"))
    # a Newmark study's secondary sweeps differ only in certifying without dt_error
    assert _secondary(newmark) == dataclasses.replace(newmark, certificate=dataclasses.replace(
        newmark.certificate, richardson=False))
    assert not sec.certificate.richardson and cfg.certificate.richardson


def test_paper_refuses_a_folder_it_did_not_write(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="did not write"):
        run_paper(tmp_path, quick=True)


@pytest.mark.slow
def test_full_study(tmp_path):
    """The full study (8 altitudes, 59 cases, runs up to 200 s): the same checks."""
    out = tmp_path / "full"
    assert main(["paper", "--out", str(out)]) == 0
    summary = _summary(out)
    assert abs(summary["linear"]["difference_ft"]) < 50.0
    found = {f["key"]: f["verdict"] for f in summary["findings"]}
    for key in ACCEPTANCE:
        expected = "differ" if key in FULL_STUDY_DIFFERENCES else "agree"
        assert found[key] == expected, (key, found[key])
