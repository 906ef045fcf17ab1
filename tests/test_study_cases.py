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
    ('alpha = "matched"\nairspeed = 3.0', "unknown case parameter 'airspeed'"),
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


# -- wind-tunnel cases: speed at a density -------------------------------------------------------
def test_tunnel_case_is_the_matched_point_at_its_speed_and_density(model):
    """The same flight condition through the two grids: speed V = M a(h) at density ρ(h) (given
    directly, or through altitude_ft) assembles the matched-point case's very matrices (to
    rounding, rtol 1e-12)."""
    h = 7000.0
    fc = flight_condition(MACH, h)
    V, rho = float(fc.velocity), float(fc.density)
    cases = [{"altitude_ft": h, "alpha": 0.1, "gamma": 1e-4},
             {"speed": V, "density": rho, "alpha": 0.1, "gamma": 1e-4},
             {"speed": V, "altitude_ft": h, "alpha": 0.1, "gamma": 1e-4}]
    system, extra = case_system(model, cases)
    for name in ("M_add", "C_add", "K_add", "lag_D", "lag_R"):
        t = getattr(system, name).numpy()
        np.testing.assert_allclose(t[1], t[0], rtol=1e-12, atol=0)
        np.testing.assert_allclose(t[2], t[0], rtol=1e-12, atol=0)
    for e in extra:
        assert e["velocity"] == pytest.approx(V, rel=1e-12)
        assert e["density"] == pytest.approx(rho, rel=1e-12)
        assert e["dynamic_pressure"] == pytest.approx(0.5 * rho * V**2, rel=1e-12)


def test_flutter_speed_at_the_density_of_the_flutter_altitude(model):
    """Independent check of the speed axis: the flutter speed at the density ρ(h_f) of the
    matched-point flutter altitude h_f equals that point's speed V_f = M a(h_f). The two
    answers come from different root searches (Brent over the altitude to 1e-3 ft, over the
    speed to 1e-10 relative); 1e-3 ft of altitude moves V_f by about 4e-6 ft/s and the growth
    rate's zero by as little, so rel 1e-6 is a bound with margin (measured below 1e-8)."""
    ref = model.baseline_flutter()
    rho = float(flight_condition(MACH, ref.altitude).density)
    fs = model.flutter_speed(rho)
    assert fs.velocity == pytest.approx(ref.velocity, rel=1e-6)
    assert fs.frequency_hz == pytest.approx(ref.frequency_hz, rel=1e-5)
    assert fs.as_dict()["mach"] == MACH
    # denser air flutters at a lower speed (ρV² sets the aerodynamic stiffness)
    assert model.flutter_speed(1.2 * rho).velocity < fs.velocity


TUNNEL = CONFIG.split("[cases]")[0].replace("t_end = 20.0", "t_end = 6.0") + """
[cases]
density = {density}
speed = {speeds}
alpha = 0.05
gamma = 1e-4
[plot]
x = "speed"
"""


def test_tunnel_sweep_below_and_above_the_flutter_speed(model, files, tmp_path):
    """A speed sweep at one density: 10 % below the flutter speed the start decays, 10 % above
    it does not; the table carries speed with its unit and the figure puts it on the x axis."""
    from torchrom.study.plots import parameter_plot
    from torchrom.study.units import axis_label, column_units

    rho = 0.0015
    vf = model.flutter_speed(rho).velocity
    path = files / "tunnel.toml"
    path.write_text(TUNNEL.format(density=rho, speeds=[0.9 * vf, 1.1 * vf]))
    cfg = load_sweep_config(path)
    table, _ = run_sweep(cfg)
    below, above = table.sort_values("speed")["status"]
    assert below == "decay" and above != "decay"
    assert column_units(table)["speed"] == "ft/s"
    assert column_units(table)["density"] == "slug/ft^3"
    assert table["velocity"].tolist() == pytest.approx(sorted([0.9 * vf, 1.1 * vf]))
    assert axis_label(table, "speed") == "speed (ft/s)"
    png = parameter_plot(table, tmp_path / "amp.png", x="speed", y="amplitude_change")
    assert png.stat().st_size > 5_000
    # the CLI reports the flutter speed at the sweep's density
    run = _sweep_cli(path, tmp_path / "cli")
    assert run.returncode == 0, run.stderr
    assert f"flutter speed at 0.0015 slug/ft^3 (baseline damping): {vf:.2f} ft/s" in run.stdout


def test_goland_tunnel_configuration_runs_quick(tmp_path, monkeypatch):
    """configs/goland_tunnel.toml, variant quick (4L2D ROM, 4 modes, 4 s runs; about 10 s),
    end to end: built model, speeds either side of its sea-level flutter speed (about
    630 ft/s), table and figure."""
    from torchrom.cache_dir import set_cache_root
    from torchrom.study.plots import parameter_plot

    from .conftest import REPO

    set_cache_root(tmp_path / "cache")
    try:
        cfg = load_sweep_config(REPO / "configs" / "goland_tunnel.toml", variant="quick")
        model = cfg.build_model()
        rho = float(flight_condition(model.mach, 0.0).density)
        vf = model.flutter_speed(rho).velocity
        speeds = sorted(c["speed"] for c in cfg.cases)
        assert speeds[0] < vf < speeds[1]
        table, _ = run_sweep(cfg, model=model)
    finally:
        set_cache_root(None)
    assert table["density"].tolist() == pytest.approx([rho, rho], rel=1e-12)
    status = dict(zip(table["speed"], table["status"]))
    assert status[speeds[0]] == "decay" and status[speeds[1]] != "decay"
    assert parameter_plot(table, tmp_path / "a.png", x="speed").stat().st_size > 5_000


@pytest.mark.parametrize("cases, words", [
    ("density = 0.0015\nspeed = [-10.0, 500.0]", ("[cases] speed", "positive", "ft/s")),
    ("density = 0.0\nspeed = 500.0", ("[cases] density", "positive", "slug/ft^3")),
    ("altitude_ft = [0.0, 5000.0]\nspeed = [400.0, 500.0]",
     ("[cases] altitude_ft", "swept together with speed")),
    ("density = [0.001, 0.002]\nspeed = [400.0, 500.0]",
     ("[cases] density", "swept together with speed")),
    ("density = 0.0015\naltitude_ft = 0.0\nspeed = 500.0", ("[cases] density", "exactly one")),
    ("speed = 500.0", ("[cases] speed", "exactly one of density")),
    ("density = 0.0015", ("[cases] density", "without speed")),
])
def test_bad_tunnel_cases_in_the_cli(files, tmp_path, cases, words):
    """Bad wind-tunnel cases: the real CLI in a subprocess, one line naming the key, exit 2,
    nothing written."""
    path = files / f"badtunnel{abs(hash(cases))}.toml"
    path.write_text(CONFIG.split("[cases]")[0] + "[cases]\n" + cases + "\nalpha = 0.05\n")
    run = _sweep_cli(path, tmp_path / "out")
    assert run.returncode == 2, run.stderr
    assert "Traceback" not in run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, run.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not (tmp_path / "out").exists()


def _sweep_cli(config, out):
    """``torchrom sweep CONFIG --out OUT`` as a process (this checkout's torchrom)."""
    import os
    import subprocess
    import sys
    from pathlib import Path

    import torchrom

    env = {**os.environ, "PYTHONPATH": str(Path(torchrom.__file__).parents[1])}
    return subprocess.run([sys.executable, "-m", "torchrom", "sweep", str(config), "--out",
                           str(out)], capture_output=True, text=True, env=env, timeout=600)


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


def test_the_same_flight_condition_in_m_and_in_ft(model, files, tmp_path):
    """One altitude unit per run (issue 46 item 6), none converted: the section model with
    its altitudes in m (altitude_unit "m") is the same physics as in ft. Its baseline flutter
    altitude is the ft one x 0.3048 (2e-3 m: each Brent search stops at 1e-3 of its unit);
    a case at altitude_m = 8,000 x 0.3048 has the velocity and density of altitude_ft = 8,000
    (1e-12: the atmosphere takes each with its unit; the conversion is exact) and the same
    matched α (1e-6 relative: it is solved at the two reference altitudes, 1e-3 m apart at
    most). Through a configuration, altitude_m alone names the run's unit: the table's column
    is altitude_m, its units metadata says m, and its velocity and density are the ft run's."""
    m = AeroelasticModel(model.rom, model.aero, baseline_alpha=model.baseline_alpha,
                         baseline_gamma=model.baseline_gamma, altitude_unit="m")
    assert m.altitude_column == "altitude_m" and m.altitude_range[1] == pytest.approx(12192.0)
    assert m.baseline_flutter().altitude == pytest.approx(
        model.baseline_flutter().altitude * 0.3048, abs=2e-3)
    assert m.baseline_flutter().altitude_unit == "m"
    _, ex_m = case_system(m, [{"altitude_m": 8000.0 * 0.3048, "alpha": "matched",
                               "gamma": 1e-3}])
    _, ex_ft = case_system(model, [{"altitude_ft": 8000.0, "alpha": "matched", "gamma": 1e-3}])
    for key in ("velocity", "density", "dynamic_pressure"):
        assert ex_m[0][key] == pytest.approx(ex_ft[0][key], rel=1e-12)
    assert ex_m[0]["alpha"] == pytest.approx(ex_ft[0]["alpha"], rel=1e-6)
    with pytest.raises(InputError, match="altitude_ft: the model's altitudes are in m"):
        case_system(m, [{"altitude_ft": 8000.0}])

    short = CONFIG.split("[cases]")[0].replace("t_end = 20.0", "t_end = 0.05")
    tables = {}
    for column, h in (("altitude_ft", 8000.0), ("altitude_m", 8000.0 * 0.3048)):
        path = files / f"one_{column}.toml"
        path.write_text(short + f"[cases]\n{column} = {h!r}\nalpha = 0.05\n")
        tables[column] = run_sweep(load_sweep_config(path))[0]
    t_m, t_ft = tables["altitude_m"], tables["altitude_ft"]
    assert "altitude_ft" not in t_m.columns and t_m.attrs["units"]["altitude_m"] == "m"
    assert t_ft.attrs["units"]["altitude_ft"] == "ft"
    for key in ("velocity", "density"):
        assert t_m[key].iloc[0] == pytest.approx(t_ft[key].iloc[0], rel=1e-12)


@pytest.mark.parametrize("cases, aeroelastic, words", [
    ("altitude_m = 2000.0\naltitude_ft = 3000.0", "",
     ("[cases] altitude_ft: given together with altitude_m", "one altitude unit per run")),
    ("altitude_ft = 3000.0", 'reference_altitude_m = 2000.0\n',
     ("[cases] altitude_ft: altitudes in ft, but [aeroelastic] reference_altitude_m names m",
      "one altitude unit per run")),
    ("altitude_m = 90000.0", "", ("[cases] altitude_m", "USSA-76")),
])
def test_altitudes_of_two_units_are_refused_in_the_cli(files, tmp_path, cases, aeroelastic,
                                                       words):
    """One altitude unit per run: two units in one configuration, or an altitude outside the
    atmosphere in its unit, is one line from the real CLI (exit 2, nothing written)."""
    path = files / f"twounits{abs(hash(cases + aeroelastic))}.toml"
    head = CONFIG.split("[cases]")[0].replace("[initial]", aeroelastic + "[initial]")
    path.write_text(head + "[cases]\n" + cases + "\nalpha = 0.05\n")
    run = _sweep_cli(path, tmp_path / "out")
    assert run.returncode == 2, run.stderr
    lines = [ln for ln in run.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in run.stderr, run.stderr
    for w in words:
        assert w in lines[0], (w, lines[0])
    assert not (tmp_path / "out").exists()
