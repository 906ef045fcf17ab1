"""Aeroelastic sweeps from TOML: model files, matched α, flight conditions, bundles, variants,
histories, and the results table (torchrom.study.cases / config / sweep)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from torchrom.aero.atmosphere import flight_condition
from torchrom.cli import main
from torchrom.errors import InputError
from torchrom.study.cases import HistorySpec, case_system
from torchrom.study.config import load_sweep_config
from torchrom.study.grid import expand_cases
from torchrom.study.models import AeroelasticModel, alpha_gamma_table
from torchrom.study.sweep import run_sweep

from .aeroelastic_fixtures import MACH, section_model

CONFIG = """
title = "typical section LCO"
[model]
rom = "rom.npz"
aero = "aero.npz"
[aeroelastic]
baseline_alpha = 0.05
baseline_gamma = 1e-4
[initial]
q0 = 0.01
[integrator]
dt = 0.001
t_end = 20.0
iterations = 3
tol = 1e-4
[lco]
outputs = ["A_Tz", "q1", "q2", "q3"]
max_amplitude = 5.0
[cases]
altitude_ft = [6000.0, 8000.0]
alpha = "matched"
curve = [{ gamma = 0.0 }, { gamma = 2e-4 }, { gamma = 2e-4, stiffness_nl = false }]
[[cases.list]]
altitude_ft = 12000.0
gamma = 0.0
[history]
where = { altitude_ft = 8000.0, gamma = 2e-4 }
every = 5
[plot]
x = "altitude_ft"
hue = "gamma"
[variants.quick.cases]
altitude_ft = [8000.0]
[variants.quick.integrator]
t_end = 10.0
"""


@pytest.fixture(scope="module")
def model():
    return section_model()


@pytest.fixture(scope="module")
def files(tmp_path_factory, model):
    folder = tmp_path_factory.mktemp("section")
    model.rom.save(folder / "rom.npz")
    model.aero.save(folder / "aero.npz")
    (folder / "lco.toml").write_text(CONFIG)
    return folder


def test_config_cases_bundles_list_and_variant(files):
    cfg = load_sweep_config(files / "lco.toml")
    assert len(cfg.cases) == 2 * 3 + 1
    assert cfg.cases[2] == {"altitude_ft": 6000.0, "alpha": "matched", "gamma": 2e-4,
                            "stiffness_nl": False}
    assert cfg.cases[-1] == {"altitude_ft": 12000.0, "alpha": "matched", "gamma": 0.0}
    assert cfg.history.indices(cfg.cases) == [4, 5]
    quick = load_sweep_config(files / "lco.toml", variant="quick")
    assert len(quick.cases) == 3 + 1 and quick.t_end == 10.0 and quick.hash != cfg.hash
    with pytest.raises(InputError, match="no variant 'slow'"):
        load_sweep_config(files / "lco.toml", variant="slow")


@pytest.mark.parametrize("change, message", [
    ('alpha = "matched"', None),
    ('alpha = "tuned"', "expected a number or 'matched'"),
    ('alpha = "matched"\nspeed = 3.0', "unknown case parameter 'speed'"),
])
def test_config_case_values_are_checked(files, change, message):
    text = CONFIG.replace('alpha = "matched"', change, 1)
    path = files / "bad.toml"
    path.write_text(text)
    if message is None:
        load_sweep_config(path)
    else:
        with pytest.raises(InputError, match=message):
            load_sweep_config(path)


def test_matched_alpha_needs_aerodynamics(files):
    text = CONFIG.replace('aero = "aero.npz"\n', "").replace(
        "[aeroelastic]\nbaseline_alpha = 0.05\nbaseline_gamma = 1e-4\n", "")
    path = files / "structural.toml"
    path.write_text(text)
    with pytest.raises(InputError, match="unknown case parameter 'altitude_ft'"):
        load_sweep_config(path)
    path.write_text(CONFIG.replace("baseline_alpha", "alpha0"))
    with pytest.raises(InputError, match=r"\[aeroelastic\]: unknown key 'alpha0'"):
        load_sweep_config(path)


def test_bundle_keys_are_case_parameters():
    with pytest.raises(InputError, match=r"curve\[1\]: unknown case parameter 'gama'"):
        expand_cases({"curve": [{"gamma": 0.0}, {"gama": 1.0}]}, allowed=("gamma",))


def test_history_spec():
    spec = HistorySpec.from_table({"where": {"gamma": [0.0, 1e-3]}, "every": 2},
                                  ("gamma", "altitude_ft"))
    assert spec.indices([{"gamma": 1e-3}, {"gamma": 5e-4}, {"gamma": 0}]) == [0, 2]
    with pytest.raises(InputError, match="unknown case parameter"):
        HistorySpec.from_table({"where": {"mass": 1.0}}, ("gamma",))


def test_case_system_columns_are_the_flight_condition_and_the_alpha_used(model):
    cases = [{"altitude_ft": 8000.0, "alpha": "matched", "gamma": 1e-3},
             {"altitude_ft": 3000.0, "alpha": 0.2, "stiffness_nl": False}]
    system, extra = case_system(model, cases)
    fc = flight_condition(MACH, 8000.0)
    assert extra[0]["velocity"] == pytest.approx(float(fc.velocity))
    assert extra[0]["density"] == pytest.approx(float(fc.density))
    assert extra[0]["alpha"] == pytest.approx(model.matched_alpha(1e-3))
    assert extra[0]["alpha_matched"] and not extra[1]["alpha_matched"]
    assert extra[1]["gamma"] == 0.0 and extra[1]["stiffness_nl"] == 0.0
    assert extra[1]["damping_nl"] == 1.0
    assert system.alpha.tolist() == pytest.approx([model.matched_alpha(1e-3), 0.2])
    with pytest.raises(InputError, match="differs from the Mach number"):
        case_system(model, [{"altitude_ft": 8000.0, "mach": 0.7}])


def test_matched_alpha_keeps_the_reference_flutter_altitude(model):
    """Fig. 9 construction: each (α(γ), γ) pair flutters at the baseline's altitude."""
    h = model.reference_altitude()
    table = alpha_gamma_table(model, [0.0, 5e-4, 1e-3])
    assert np.all(np.diff(table["alpha"]) < 0)  # more γ needs less α
    assert np.abs(table["growth_rate_at_reference"]).max() < 1e-8
    for g, a in zip(table["gamma"], table["alpha"]):
        other = AeroelasticModel(model.rom, model.aero, baseline_alpha=a, baseline_gamma=g)
        assert other.baseline_flutter().altitude == pytest.approx(h, abs=1.0)
    assert model.matched_alpha(model.baseline_gamma) == model.baseline_alpha


def test_sweep_table_has_the_design_columns_and_histories(files):
    cfg = load_sweep_config(files / "lco.toml")
    hist = []
    table, timing = run_sweep(cfg, on_history=hist.append)
    design = ["case_id", "altitude_ft", "mach", "velocity", "dynamic_pressure", "density",
              "alpha", "gamma", "stiffness_nl", "damping_nl", "status", "amplitude",
              "amplitude_pct_span", "frequency_hz", "ratio_q1_q2", "steps", "t_end",
              "config_hash", "version"]
    assert [c for c in design if c not in table.columns] == []
    assert table["alpha"].dtype == float and table["stiffness_nl"].notna().all()
    by = table.set_index(["altitude_ft", "gamma", "stiffness_nl"])
    # below the flutter altitude (≈ 9,600 ft) the nonlinear cases settle into LCOs; the pitch
    # damping nonlinearity alone (stiffness off) limits the amplitude too
    assert (by.loc[(8000.0, 2e-4, 1.0), "status"]) == "lco"
    assert (by.loc[(8000.0, 2e-4, 0.0), "status"]) == "lco"
    assert by.loc[(12000.0, 0.0, 1.0), "status"] == "decay"  # above flutter
    h = pd.concat(hist)
    assert set(h["case_id"]) == set(table[(table["altitude_ft"] == 8000.0)
                                          & (table["gamma"] == 2e-4)]["case_id"])
    assert list(h.columns) == ["case_id", "t", "A_Tz", "q1", "q2", "q3"]
    assert timing["case_steps"] > 0


def test_sweep_cli_writes_histories(files, tmp_path):
    rc = main(["sweep", str(files / "lco.toml"), "--out", str(tmp_path / "out")])
    assert rc == 0
    assert (tmp_path / "out" / "histories.parquet").is_file()
    table = pd.read_parquet(tmp_path / "out" / "results.parquet")
    assert rc == 0 and len(table) == 7
    assert main(["plot", str(tmp_path / "out" / "results.parquet"), "--figure", "fig11",
                 "--out", str(tmp_path / "fig11.png")]) == 0
    assert (tmp_path / "fig11.png").stat().st_size > 10_000


@pytest.mark.parametrize("old, new", [
    # the section's baseline flutter point lies within the default range, not within 0..100 ft
    ("baseline_gamma = 1e-4\n", "baseline_gamma = 1e-4\naltitude_range_ft = [0.0, 100.0]\n"),
    ('altitude_ft = 12000.0\n', 'altitude_ft = 12000.0\nmach = 0.1\n'),
])
def test_aeroelastic_case_errors_are_refused_before_the_run(files, tmp_path, capsys, old, new):
    """A matched α without a baseline flutter point in the altitude range, or a case Mach
    number the aerodynamic data do not have, is refused when the configuration is read —
    not after the sweep started, which then advised resuming (issue 37)."""
    text = CONFIG.replace(old, new, 1)
    assert text != CONFIG
    path = files / "late.toml"
    path.write_text(text)
    out = tmp_path / "out"
    rc = main(["sweep", str(path), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and "resume" not in err and not out.exists()
    assert ("no flutter point between 0 and 100 ft" in err if "range" in new
            else "[cases] mach: 0.1 (case 6) differs" in err), err
    assert len(err.strip().splitlines()) == 1
