"""Sweeps in float32 with float64 confirmation of the borderline cases (torchrom.study.sweep)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.io import tomllib
from torchrom.study import config_from_dict, sweep_table
from torchrom.study.config import load_sweep_config
from torchrom.study.sweep import run_sweep

# four Van der Pol–Duffing cases reaching their LCO; with tol = 1e-7 (below float32's rounding of
# the acceleration corrections, ~1e-7 relative) float32 cannot certify its solution
CONFIG = """
title = "float32 confirmation"
[model]
builtin = "van_der_pol_duffing"
c1 = -1.0
d3 = 1.0
[initial]
q0 = 1.5
[integrator]
dt = 0.01
t_end = 30.0
iterations = 3
tol = {tol}
[cases]
alpha = [0.1, 0.2, 0.3, 0.4]
gamma = 1.0
"""


def _table(tmp_path, tol, dtype):
    path = tmp_path / f"c{tol}.toml"
    path.write_text(CONFIG.format(tol=tol))
    return run_sweep(load_sweep_config(path), dtype=dtype)[0]


def test_float32_borderline_cases_are_confirmed_in_float64(tmp_path):
    """With a tolerance float32 cannot reach every case is flagged by its error estimate and
    rerun in float64: the rows are then exactly the float64 sweep's (same case ids, amplitudes
    equal to rounding) and say so in the ``precision`` column."""
    t32 = _table(tmp_path, 1e-7, torch.float32)
    t64 = _table(tmp_path, 1e-7, torch.float64)
    assert (t64["precision"] == "float64").all() and (t64["status"] == "lco").all()
    assert (t32["precision"] == "float64 (confirmed)").all()
    assert t32["status"].tolist() == t64["status"].tolist()
    np.testing.assert_allclose(t32["amplitude"], t64["amplitude"], rtol=1e-12)


def test_float32_cases_within_tolerance_keep_float32(tmp_path):
    """With float32's default tolerance (1e-4) the cases converge in float32 and are kept; their
    amplitudes agree with float64 to ~1e-5 (float32 rounding over the LCO detection window)."""
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.replace("tol = {tol}\n", ""))
    cfg = load_sweep_config(path)
    t32 = run_sweep(cfg, dtype=torch.float32)[0]
    t64 = run_sweep(cfg, dtype=torch.float64)[0]
    assert (t32["precision"] == "float32").all() and (t32["status"] == "lco").all()
    np.testing.assert_allclose(t32["amplitude"], t64["amplitude"], rtol=1e-3)


def test_every_lco_row_carries_its_certificate(tmp_path):
    """A sweep's LCO rows carry the shooting certificate (orbit_error within the default 1e-3,
    dt_error, a resolved stability); a config can turn finishing off, which leaves a loosely
    accepted LCO (rtol 1e-2 at one cycle) flagged ``lco_uncertified`` instead of finished."""
    path = tmp_path / "c.toml"
    path.write_text(CONFIG.format(tol=1e-6))
    table, timing = run_sweep(load_sweep_config(path))
    lco = table[table.status == "lco"]
    assert len(lco) == 4 and lco.certified.all()
    # the certificate's seconds are counted apart, within the solver's (what a cheaper
    # certificate would save)
    assert 0.0 < timing["certificate_s"] < timing["wall_time_s"]
    # dt_error: 8.1e-4-1.0e-3, the spread of the discrete orbits at dt, 2 dt, 4 dt (their
    # one-evaluation coarse orbits do not show Newmark's h² law here; periodic.certify)
    assert (lco.orbit_error <= 1e-3).all() and (lco.dt_error < 1e-2).all()
    assert lco.stable.map(lambda s: s is True).all()
    loose = CONFIG.format(tol=1e-6).replace("[cases]", "[lco]\nrtol = 0.3\ncycles = 1\n"
                                            "[certificate]\nfinish = false\ntol = 1e-6\n"
                                            "richardson = false\n[cases]")
    path.write_text(loose)
    flagged = run_sweep(load_sweep_config(path))[0]
    assert set(flagged.status) == {"lco_uncertified"}
    assert (flagged.orbit_error > 1e-6).all() and flagged.dt_error.isna().all()


def test_plot_columns_cover_every_numeric_result_column(tmp_path):
    """``[plot] y`` is checked before the run against :func:`torchrom.study.config.
    result_columns`: every numeric column a sweep's table really has (time marching, harmonic
    balance, shooting) is in it, so no valid y is refused."""
    import pandas as pd

    from torchrom.study.cases import case_parameters
    from torchrom.study.config import is_result_column, result_columns, with_method

    path = tmp_path / "c.toml"
    path.write_text(CONFIG.format(tol=1e-6).replace("[0.1, 0.2, 0.3, 0.4]", "[0.2]"))
    cfg = load_sweep_config(path)
    allowed = result_columns(case_parameters(False), cfg.outputs, False)
    for method in ("newmark", "hb", "shooting"):
        table = run_sweep(with_method(cfg, method))[0]
        numeric = {c for c in table.columns if pd.api.types.is_numeric_dtype(table[c])
                   or pd.api.types.is_bool_dtype(table[c])}
        refused = sorted(c for c in numeric if not is_result_column(c, allowed))
        assert not refused, (method, refused)


def test_harmonic_balance_chunks_hold_neighbours_and_the_table_keeps_case_order(tmp_path):
    """A solver that chains neighbours gets its chunks cut from the cases in chain order
    (:func:`~torchrom.study.cases.chain_order`: by α from the largest down), and the table
    comes back in the configuration's case order: with chunks of two cases the rows are those
    of the one-chunk sweep (amplitudes to 1e-8: the Newton tolerance, from other starts)."""
    from torchrom.study.cases import chain_order

    path = tmp_path / "hb.toml"
    path.write_text(CONFIG.format(tol=1e-6).replace("[model]", 'method = "hb"\n[model]')
                    .replace("[0.1, 0.2, 0.3, 0.4]", "[0.3, 0.1, 0.4, 0.2]"))
    cfg = load_sweep_config(path)
    assert chain_order(cfg.cases) == [2, 0, 3, 1]
    one = run_sweep(cfg)[0]
    pairs = run_sweep(cfg, chunk_size=2)[0]
    assert one["alpha"].tolist() == pairs["alpha"].tolist() == [0.3, 0.1, 0.4, 0.2]
    assert (pairs["status"] == "lco").all() and pairs["certified"].all()
    np.testing.assert_allclose(pairs["amplitude"], one["amplitude"], rtol=1e-8)


# -- sweep_table: a configuration, dict or file in, the results table out (notebooks) --
def test_sweep_table_of_a_dict_is_the_sweep_of_its_file(tmp_path):
    """The four float64 cases of CONFIG as a dict through sweep_table and as a file through
    load_sweep_config and run_sweep: the same configuration hash, hence the same case ids, and
    the same rows to the last bit (one computation); the timing rides along in the attrs."""
    text = CONFIG.format(tol=1e-6)
    path = tmp_path / "study.toml"
    path.write_text(text)
    from_file = run_sweep(load_sweep_config(path))[0]
    table = sweep_table(tomllib.loads(text), progress=False)
    columns = ["case_id", "alpha", "status", "amplitude", "frequency_hz", "steps"]
    assert table[columns].equals(from_file[columns])
    assert list(table.status) == ["lco"] * 4
    assert table.attrs["timing"]["computed"] == 4 and table.attrs["units"]["alpha"] == "1/s"
    assert sweep_table(path, progress=False)[columns].equals(table[columns])


def test_sweep_table_checks_before_any_case_runs(tmp_path):
    """What `torchrom sweep` refuses before running (torchrom.study.sweep.checked_model), e.g. an
    initial state of the wrong size for the model, sweep_table refuses too, naming the dict, and
    leaves no output folder behind."""
    raw = tomllib.loads(CONFIG.format(tol=1e-6))
    raw["initial"]["q0"] = [1.5, 0.0, 0.0]  # the model has one mode
    with pytest.raises(InputError, match=r"^<dict>: \[initial\] q0: expected 1 values, got 3$"):
        sweep_table(raw, out=tmp_path / "out")
    assert not (tmp_path / "out").exists()
    raw["initial"]["q0"] = 1.5
    with pytest.raises(InputError, match=r"variant 'x'.*expected a dict or a TOML file"):
        sweep_table(config_from_dict(raw), "x")
