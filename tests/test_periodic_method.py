"""Harmonic balance as a sweep method: the same table as time marching (method = "hb")."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import torch

from torchrom.errors import InputError
from torchrom.periodic import HarmonicBalanceMethod
from torchrom.periodic.solve import orbit_state
from torchrom.sim import LCOCriteria
from torchrom.study.cases import case_system, orbits_of
from torchrom.study.config import load_sweep_config, with_method
from torchrom.study.sweep import run_sweep

CONFIG = """
title = "two VdP-Duffing modes"
method = "hb"
[model]
builtin = "van_der_pol_duffing"
frequencies_hz = [1.0, 2.3]
c1 = [-0.6, 0.05]
d3 = [1.0, 1.0]
k3 = [4.0, 0.0]
coupling = [[0.0, 3.0], [3.0, 0.0]]
[initial]
q0 = 0.5
[integrator]
dt = 0.002
t_end = 120.0
iterations = 3
[lco]
outputs = ["q1", "q2"]
rtol = 1e-5
[hb]
sensitivity = true
[cases]
combine = "product"
alpha = [0.0, 0.2, 0.4, 0.8]
gamma = [1.0]
"""


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    path = tmp_path_factory.mktemp("hb") / "vdp.toml"
    path.write_text(CONFIG)
    cfg = load_sweep_config(path)
    orbits = []
    hb, _ = run_sweep(cfg, on_orbits=orbits.append)
    nm, _ = run_sweep(with_method(cfg, "newmark"))
    hb.attrs["orbits"] = pd.concat(orbits, ignore_index=True)
    return cfg, hb, nm


def test_same_table_as_time_marching(tables):
    """Statuses agree; LCO amplitudes and frequencies within 1e-3 (Newmark's own error at
    dt = 2 ms, see test_periodic_solve); HB's own columns are filled."""
    cfg, hb, nm = tables
    assert cfg.method == "hb" and isinstance(cfg.solver.method, HarmonicBalanceMethod)
    assert list(hb["status"]) == list(nm["status"]) == ["lco", "lco", "lco", "decay"]
    lco = hb["status"] == "lco"
    assert np.allclose(hb.loc[lco, "amplitude"], nm.loc[lco, "amplitude"], rtol=1e-3)
    assert np.allclose(hb.loc[lco, "frequency_hz"], nm.loc[lco, "frequency_hz"], rtol=1e-4)
    assert set(hb["method"]) == {"hb"}
    assert hb.loc[lco, "stable"].all() and (hb.loc[lco, "floquet_multiplier"] < 1).all()
    assert (hb.loc[lco, "harmonics"] >= 5).all()
    assert hb.loc[~lco, "amplitude"].eq(0).all()
    # the two methods never share case ids (the method is part of the configuration's hash)
    assert not set(hb["case_id"]) & set(nm["case_id"])


def test_orbits_start_a_time_integration_on_the_lco(tables):
    """The sweep's orbits (``on_orbits``, one per LCO, its own H) put a time integration on
    the LCO: its first cycles from their state at τ = 0 have HB's amplitude (Newmark's error
    at dt = 2 ms, 1e-3; a start off the orbit would still be converging); a decaying case has
    no orbit."""
    cfg, hb, _ = tables
    orbits = hb.attrs["orbits"]
    lco = np.flatnonzero(hb["status"] == "lco")
    assert set(orbits["case_id"]) == set(hb["case_id"][lco])
    for i in lco:
        rows = orbits[orbits["case_id"] == hb["case_id"][i]]
        assert rows["k"].tolist() == list(range(2 * int(hb["harmonics"][i]) + 1))
    ids = list(hb["case_id"][lco])
    system, _ = case_system(cfg.build_model(), [cfg.cases[i] for i in lco],
                            torch.device("cpu"), torch.float64)
    X, omega = orbits_of(orbits, ids, system.n)
    q0, v0, xi0 = orbit_state(system, torch.as_tensor(X), torch.as_tensor(omega))
    res = cfg.integrator.run(system, q0, v0, xi0, t_end=3 * 2 * np.pi / omega.min(),
                             outputs=cfg.outputs, lco=LCOCriteria(stop=False, cycles=2))
    assert np.allclose(res.amplitude[:, 0], hb["amplitude"][lco], rtol=1e-3)


def test_amplitude_derivative_matches_finite_differences(tmp_path):
    """dA/dγ from the implicit-function theorem against a central difference of solved orbits
    at γ(1 ± 1e-4), all at one H (truncation of the difference ~1e-8 relative; the orbits are
    solved to 1e-9): agreement within 1e-5 relative."""
    path = tmp_path / "fixed_h.toml"
    path.write_text(CONFIG.replace("sensitivity = true", "sensitivity = true\n"
                                   "start_harmonics = 5\nharmonics = 5\nmax_harmonics = 5"))
    cfg = load_sweep_config(path)
    h = 1e-4
    table, _ = run_sweep(cfg, cases=[{"alpha": 0.2, "gamma": g} for g in (1.0, 1.0 + h,
                                                                          1.0 - h)])
    a = table["amplitude"].to_numpy()
    fd = (a[1] - a[2]) / (2 * h)
    assert table["amplitude_dgamma"][0] == pytest.approx(fd, rel=1e-5)
    f = table["frequency_hz"].to_numpy()
    assert table["frequency_dgamma"][0] == pytest.approx((f[1] - f[2]) / (2 * h), rel=1e-4)


def test_bad_hb_options(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text(CONFIG.replace("sensitivity = true", "harmonics = 0"))
    with pytest.raises(InputError, match=r"\[hb\].*harmonics"):
        load_sweep_config(path)
    path.write_text(CONFIG.replace("sensitivity = true", "colour = 1"))
    with pytest.raises(InputError, match="unknown key 'colour'"):
        load_sweep_config(path)
    path.write_text(CONFIG.replace("sensitivity = true", 'seed = "maybe"'))
    with pytest.raises(InputError, match="hb.seed: expected one of"):
        load_sweep_config(path)
    path.write_text(CONFIG.replace('method = "hb"', 'method = "collocation"'))
    with pytest.raises(InputError, match="method"):
        load_sweep_config(path)
