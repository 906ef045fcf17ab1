"""``torchrom sweep``: the demo configuration end to end, and its error messages."""

import json
import shutil

import pandas as pd
import pytest

from torchrom.cli import main

from .conftest import REPO

SMALL = """
title = "small"
[model]
builtin = "van_der_pol_duffing"
frequencies_hz = [1.0, 2.0]
c1 = [-0.8, 0.1]
d3 = [1.0, 1.0]
k3 = [4.0, 0.0]
coupling = [[0.0, 3.0], [3.0, 0.0]]
[initial]
q0 = 1.0
[integrator]
dt = 0.01
t_end = 40.0
predictor = "quadratic"
[lco]
outputs = ["sum", "q1", "q2"]
rtol = 1e-3
[cases]
alpha = [0.0, 0.4, 1.2]
gamma = [1.0, 2.0]
[plot]
x = "alpha"
hue = "gamma"
"""


@pytest.fixture()
def small_config(tmp_path):
    path = tmp_path / "small.toml"
    path.write_text(SMALL)
    return path


def test_sweep_writes_table_figure_and_json(small_config, tmp_path, capsys):
    out = tmp_path / "out"
    js = tmp_path / "r.json"
    assert main(["sweep", str(small_config), "--out", str(out), "--json", str(js)]) == 0
    table = pd.read_parquet(out / "results.parquet")
    csv = pd.read_csv(out / "results.csv")
    assert len(table) == len(csv) == 6
    for col in ("case_id", "alpha", "gamma", "status", "amplitude", "frequency_hz",
                "ratio_q1_q2", "steps", "t_end", "config_hash", "version"):
        assert col in table.columns, col
    assert table["case_id"].is_unique
    # α = 1.2 damps both γ levels' self-excitation (net c = α + γ c1 > 0 for γ = 1), α = 0 not
    by = table.set_index(["alpha", "gamma"])
    assert by.loc[(0.0, 1.0), "status"] == "lco" and by.loc[(0.0, 1.0), "amplitude"] > 0.5
    assert by.loc[(1.2, 1.0), "status"] == "decay"
    assert (out / "amplitude_vs_alpha.png").stat().st_size > 10_000
    records = json.loads(js.read_text())
    assert len(records) == 6 and set(records[0]) == set(table.columns)
    printed = capsys.readouterr().out
    assert "status:" in printed
    assert "6 computed in 1 chunk, 0 reused" in printed  # one chunk: singular

    # the same configuration again resumes: nothing recomputed, the same table
    assert main(["sweep", str(small_config), "--out", str(out)]) == 0
    assert "0 computed in 0 chunks, 6 reused" in capsys.readouterr().out
    pd.testing.assert_frame_equal(pd.read_parquet(out / "results.parquet"), table)
    # a changed configuration is refused without --force, then replaces the results with it
    small_config.write_text(SMALL.replace("rtol = 1e-3", "rtol = 2e-3"))
    assert main(["sweep", str(small_config), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "different configuration (config changed" in err and "--force" in err
    assert main(["sweep", str(small_config), "--out", str(out), "--force"]) == 0
    assert "6 computed" in capsys.readouterr().out
    # a results table this command did not write is never replaced silently
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "results.csv").write_text("x\n1\n")
    assert main(["sweep", str(small_config), "--out", str(foreign)]) == 2
    assert "already exists" in capsys.readouterr().err


@pytest.mark.parametrize("edit,message", [
    (lambda s: s.replace("dt = 0.01", "dt = -1"), "[integrator] dt: expected a positive"),
    (lambda s: s.replace("[cases]\n", "[cases]\nalpah = 1\n"), "unknown case parameter 'alpah'"),
    (lambda s: s.replace("rtol = 1e-3", "rtl = 1e-3"), "[lco]: unknown key 'rtl'"),
    (lambda s: s.replace("c1 = [-0.8, 0.1]", "c1 = [-0.8, 0.1, 0.2]"), "c1: expected 2"),
    (lambda s: s.replace('predictor = "quadratic"', 'predictor = "cubic"'),
     "integrator.predictor"),
    (lambda s: s.replace("[plot]", "[plot\n"), "invalid TOML"),
    (lambda s: s.replace('outputs = ["sum", "q1", "q2"]', 'outputs = ["tip"]'),
     "output 'tip': not an output"),
])
def test_bad_configuration_gives_one_line_error(small_config, tmp_path, capsys, edit, message):
    small_config.write_text(edit(SMALL))
    assert main(["sweep", str(small_config), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and message in err, err
    assert not (tmp_path / "o" / "results.parquet").exists()


def test_demo_configuration_runs(tmp_path):
    """The README's main job (the shipped demo), on a copy with a shorter t_end."""
    demo = (REPO / "configs" / "demo_vdp.toml").read_text()
    assert "t_end = 200.0" in demo
    cfg = tmp_path / "demo.toml"
    cfg.write_text(demo.replace("t_end = 200.0", "t_end = 30.0")
                   .replace("num = 13", "num = 4"))
    shutil.copy(cfg, tmp_path / "demo_copy.toml")
    assert main(["sweep", str(cfg), "--out", str(tmp_path / "demo"), "--dtype", "float32"]) == 0
    table = pd.read_csv(tmp_path / "demo" / "results.csv")
    assert len(table) == 12 and set(table["status"]) <= {"lco", "decay", "unconverged"}


def test_sweep_logged_to_a_file_shows_progress_lines_and_no_bar(small_config, tmp_path):
    """stdout and stderr redirected to a file (not a terminal): plain progress lines with
    elapsed time and ETA, no tqdm bar (no carriage returns, no 'it/s')."""
    import os
    import subprocess
    import sys

    log = tmp_path / "sweep.log"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    with open(log, "w") as fh:
        rc = subprocess.run([sys.executable, "-m", "torchrom", "sweep", str(small_config),
                             "--out", str(tmp_path / "out"), "--chunk-size", "2"],
                            stdout=fh, stderr=subprocess.STDOUT, env=env, cwd=tmp_path,
                            timeout=300).returncode
    text = log.read_text()
    assert rc == 0, text
    lines = [ln for ln in text.splitlines() if ln.startswith("cases done:")]
    assert len(lines) >= 3 and lines[-1].startswith("cases done: 6/6 cases (100 %)")
    assert all("elapsed" in ln and "ETA" in ln for ln in lines)
    assert "\r" not in text and "it/s" not in text and "case/s" not in text
    out = tmp_path / "out"
    for name in ("results.parquet", "results.csv"):
        assert (out / name).stat().st_mode & 0o777 == 0o666 & ~_umask()
    quiet = subprocess.run([sys.executable, "-m", "torchrom", "sweep", str(small_config),
                            "--out", str(tmp_path / "quiet"), "--quiet", "--chunk-size", "2"],
                           capture_output=True,
                           text=True, env=env, cwd=tmp_path, timeout=300)
    assert quiet.returncode == 0 and "cases done" not in quiet.stdout + quiet.stderr
    assert "wrote" in quiet.stdout  # results are still reported


def _umask() -> int:
    from torchrom.io import current_umask

    return current_umask()
