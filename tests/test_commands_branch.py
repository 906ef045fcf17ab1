"""``torchrom branch``: branch table, Hopf points, diagram, refusal to overwrite."""

from __future__ import annotations

import json
import math

import pandas as pd
import pytest

from torchrom.cli import main

from .conftest import REPO


def test_branch_of_the_subcritical_oscillator(tmp_path, capsys):
    out = tmp_path / "br"
    cfg = REPO / "configs" / "bifurcation_subcritical.toml"
    args = ["branch", str(cfg), "--parameter", "alpha", "--range", "-1.5", "1.0", "--out",
            str(out), "--json", str(tmp_path / "br.json")]
    assert main(args) == 0
    table = pd.read_parquet(out / "branch.parquet")
    assert (out / "branch.png").stat().st_size > 10_000
    assert pd.read_csv(out / "hopf.csv")["parameter"][0] == pytest.approx(-1.0, rel=1e-9)
    assert table["kind"].iloc[0] == "hopf" and table["amplitude"].iloc[0] == 0
    assert table["alpha"].between(-1.5, 1.0).all()
    assert set(table["method"]) == {"hb"}
    # unstable from the Hopf point up to the fold, stable beyond it (the hysteresis)
    fold = table[table["kind"] == "fold"]
    assert len(fold) == 1 and math.isfinite(fold["fold_parameter"].iloc[0])
    lco = table[table["kind"] != "hopf"]
    # every orbit point certified by shooting on the Newmark map, its stability resolved (the
    # monodromy's: the stability of record)
    assert lco["certified"].astype(bool).all() and lco["stable"].notna().all()
    # (dt_error is large near the Hopf point: the discrete map's Hopf point moves with the
    # step and A ∝ √(α − α*) there, so it is only required to be reported)
    assert (lco["orbit_error"] <= 1e-3).all() and lco["dt_error"].notna().all()
    assert not lco[lco["amplitude"] < fold["fold_amplitude"].iloc[0] * 0.95]["stable"].any()
    assert lco[lco["amplitude"] > fold["fold_amplitude"].iloc[0] * 1.05]["stable"].all()
    summary = json.loads((tmp_path / "br.json").read_text())
    assert summary["parameter"] == "alpha" and len(summary["folds"]) == 1
    printed = capsys.readouterr().out
    assert "subcritical" in printed and "fold at alpha" in printed
    # no output is replaced without --force
    before = (out / "branch.csv").read_bytes()
    assert main(args) == 2
    assert "exists" in capsys.readouterr().err
    assert (out / "branch.csv").read_bytes() == before


def test_branch_bad_parameter(tmp_path, capsys):
    cfg = REPO / "configs" / "bifurcation_subcritical.toml"
    assert main(["branch", str(cfg), "--parameter", "colour", "--range", "0", "1", "--out",
                 str(tmp_path / "x")]) == 2
    assert "branch parameter" in capsys.readouterr().err
    assert main(["branch", str(cfg), "--parameter", "alpha", "--out", str(tmp_path / "x")]) == 2
    assert "bounds" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_branch_progress_covers_the_range_from_the_hopf_point(capsys):
    """The continuation's progress: the share of the range between the bound nearest the
    Hopf point (α* = -1 in [-1.5, 1]: the lower one) and the furthest point corrected, monotone
    and at the end at least that of the table's furthest point (a corrector may try a point
    beyond it that is not kept: a step halved after a failure), at most the whole range."""
    from torchrom.study.branch import branch_options, run_branches
    from torchrom.study.config import load_sweep_config

    cfg = load_sweep_config(REPO / "configs" / "bifurcation_subcritical.toml")
    parameter, options = branch_options(cfg, "alpha", (-1.5, 1.0))
    seen = []
    study = run_branches(cfg, parameter, options, progress=seen.append)
    assert seen and seen == sorted(seen) and 0.0 < seen[-1] <= 1.0
    furthest = float((study.table["alpha"] + 1.5).abs().max()) / 2.5
    assert furthest - 1e-12 <= seen[-1] <= 1.0
