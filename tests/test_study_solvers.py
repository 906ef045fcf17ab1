"""The sweep solvers' contract (torchrom.study.solvers) and the shooting solver."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from torchrom.commands._common import METHODS
from torchrom.errors import InputError
from torchrom.study.config import load_sweep_config, with_method
from torchrom.study.solvers import SOLVERS, Shooting
from torchrom.study.sweep import run_sweep

from .test_periodic_method import CONFIG as HB_CONFIG

# two coupled Van der Pol–Duffing modes: three LCOs and a decaying case (the HB test's cases)
CONFIG = HB_CONFIG.replace('method = "hb"', 'method = "shooting"')


@pytest.fixture(scope="module")
def configs(tmp_path_factory):
    path = tmp_path_factory.mktemp("solvers") / "vdp.toml"
    path.write_text(CONFIG)
    return load_sweep_config(path)


def test_every_solver_keeps_the_contract(configs):
    """Each named solver is built from a configuration and answers every question of the
    contract; the CLI's --method choices are the solvers' names."""
    assert METHODS == tuple(SOLVERS)
    for name in SOLVERS:
        cfg = with_method(configs, name)
        solver = cfg.solver
        assert solver.name == name
        assert isinstance(solver.marches_time, bool) and isinstance(solver.writes_orbits, bool)
        assert solver.certificate(cfg).enabled
        solver.check_effort(cfg, len(cfg.cases), "cases")
        solver.check_memory(cfg, 2, len(cfg.cases), 8)
        assert solver.describe(cfg)
        assert solver.with_gamma_sensitivity(cfg).method == name
    assert SOLVERS["newmark"].marches_time and not SOLVERS["shooting"].marches_time


def test_shooting_needs_no_t_end_and_always_finishes(configs, tmp_path):
    """A periodic-orbit solver reads no t_end; shooting's certificate is always on and
    finishing, whatever ``[certificate]`` says."""
    path = tmp_path / "no_t_end.toml"
    path.write_text(CONFIG.replace("t_end = 120.0\n", "")
                    + "[certificate]\nenabled = false\nfinish = false\n")
    cfg = load_sweep_config(path)
    assert math.isinf(cfg.t_end)
    cert = cfg.solver.certificate(cfg)
    assert cert.enabled and cert.finish and cert.always_finish
    with pytest.raises(InputError, match="t_end"):
        with_method(cfg, "newmark")


def test_shooting_rows_are_the_discrete_orbits(configs):
    """Every LCO of the shooting solver is certified and finished (the harmonic-balance
    predictor is not the discrete orbit), its stability known; amplitudes agree with a long
    Newmark transient at the same step within 2e-4 (the transients stop at rtol 1e-5 per
    cycle, their amplitudes measured on the sampled outputs, ~1e-4 at 500 steps per period)
    and with harmonic balance within 1e-3 (H ≤ 9 against the discrete orbit's step error,
    dt_error)."""
    sh, _ = run_sweep(configs)
    nm, _ = run_sweep(with_method(configs, "newmark"))
    hb, _ = run_sweep(with_method(configs, "hb"))
    assert list(sh["status"]) == list(nm["status"]) == ["lco", "lco", "lco", "decay"]
    lco = sh["status"] == "lco"
    assert set(sh["method"]) == {Shooting.name}
    assert sh.loc[lco, "certified"].all() and sh.loc[lco, "finished"].all()
    assert (sh.loc[lco, "shooting_iterations"] >= 1).all()
    assert sh.loc[lco, "stable"].notna().all() and sh.loc[lco, "stable"].astype(bool).all()
    assert np.allclose(sh.loc[lco, "amplitude"], nm.loc[lco, "amplitude"], rtol=2e-4)
    assert np.allclose(sh.loc[lco, "amplitude"], hb.loc[lco, "amplitude"], rtol=1e-3)
    assert np.allclose(sh.loc[lco, "frequency_hz"], nm.loc[lco, "frequency_hz"], rtol=1e-4)


def test_predictor_is_harmonic_balance_without_its_floquet(configs):
    """The predictor keeps the [hb] ladder in H and drops the Floquet multipliers and the
    γ-derivatives (the shooting finish's monodromy gives the stability of record)."""
    cfg = with_method(configs, "shooting")
    hb = dataclasses.replace(cfg.hb.options, harmonics=7, max_harmonics=15)
    pred = Shooting.predictor(dataclasses.replace(cfg.hb, options=hb, sensitivity=True))
    assert pred.options == hb
    assert not pred.stability and not pred.sensitivity
