"""Start kinds of a sweep (torchrom.study.starts): small, neighbour (warm starts), waves."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.rom.analytic import quintic_damping_oscillator
from torchrom.sim import LCOCriteria, Newmark
from torchrom.study.cases import case_system
from torchrom.study.starts import (
    Finished,
    check_start,
    default_along,
    march,
    neighbour_scale,
    sweep_lines,
)

from .aeroelastic_fixtures import section_model

INTEG = Newmark(dt=1e-3, iterations=2, refresh_every=1, tol=1e-3)
LCO = LCOCriteria(max_amplitude=10.0)


def _run(t_end=60.0, integ=INTEG, lco=LCO):
    def run(system, q0, v0, xi0, _index):
        return integ.run(system, q0, v0, xi0, t_end=t_end, outputs=["A_Tz"], lco=lco)
    return run


def test_lines_group_every_other_parameter_and_order_along_one():
    cases = [{"altitude_ft": a, "gamma": g} for g in (1e-4, 0.0) for a in (8000.0, 6000.0, 7000.0)]
    assert default_along(cases) == "altitude_ft"
    assert sweep_lines(cases, "altitude_ft") == [[1, 2, 0], [4, 5, 3]]
    assert sweep_lines(cases, None) == [[i] for i in range(6)]


def test_neighbour_scale_extrapolates_the_last_two_amplitudes_linearly():
    prev = [Finished(7000.0, "lco", 2.0, None, None, None),
            Finished(6000.0, "lco", 3.0, None, None, None)]
    assert neighbour_scale(prev, 8000.0) == pytest.approx(0.5)  # 2 − 1 = 1 -> λ = 1/2
    assert neighbour_scale(prev, 7500.0) == pytest.approx(0.75)
    assert neighbour_scale(prev, 20000.0) == 0.5  # clipped
    assert neighbour_scale(prev[:1], 8000.0) == 1.0  # one neighbour: its own amplitude
    assert neighbour_scale([prev[0], Finished(6000.0, "decay", 0.0, None, None, None)],
                           8000.0) == 1.0


def test_supercritical_lcos_do_not_depend_on_the_start():
    # the typical section flutters near 10,000 ft: an altitude line below it, two gammas
    model = section_model()
    cases = [{"altitude_ft": a, "gamma": g, "alpha": 0.05} for g in (1e-4, 3e-4)
             for a in (5000.0, 6000.0, 7000.0, 8000.0)]
    system = case_system(model, cases, dtype=torch.float64)[0]
    initial = {"q0": 0.01, "mode": 1}
    small = march(system, model.rom, cases, {**initial, "start": "small"}, _run())
    warm = march(system, model.rom, cases, {**initial, "start": "neighbour"}, _run())
    assert (small.status == "lco").all() and (warm.status == "lco").all()
    # the same orbit within the LCO tolerance (rtol 1e-3 per cycle, approached from both sides)
    np.testing.assert_allclose(warm.amplitude[:, 0], small.amplitude[:, 0], rtol=5e-3)
    np.testing.assert_allclose(warm.frequency_hz, small.frequency_hz, rtol=1e-3)
    # the first case of each line starts small; the others continue from their neighbour and
    # need less simulated time
    later = [1, 2, 3, 5, 6, 7]
    assert warm.time[later].sum() < 0.7 * small.time[later].sum()
    np.testing.assert_array_equal(warm.time[[0, 4]], small.time[[0, 4]])
    # started on its harmonic-balance orbit, each case only confirms it: the same LCO (the
    # integrator's, within the LCO tolerance as above) in less simulated time than from the
    # small start
    orbit = march(system, model.rom, cases, {**initial, "start": "hb"}, _run())
    assert (orbit.status == "lco").all()
    np.testing.assert_allclose(orbit.amplitude[:, 0], small.amplitude[:, 0], rtol=5e-3)
    np.testing.assert_allclose(orbit.frequency_hz, small.frequency_hz, rtol=1e-3)
    assert orbit.time.sum() < 0.5 * small.time.sum()


def test_subcritical_start_decides_the_attractor():
    # subcritical Hopf (configs/bifurcation_subcritical.toml): for −1 < α < 0.498 the rest state
    # and a large LCO coexist. A small start decays there; the neighbour start continues the
    # LCO branch from α = −1.3 (where the rest state is unstable): hysteresis, documented
    rom = quintic_damping_oscillator(2.0, c1=1.0, d3=-5.0, d5=2.0)
    cases = [{"alpha": a, "gamma": 1.0} for a in (-1.3, -0.8, -0.4)]
    system = case_system(rom, cases, dtype=torch.float64)[0]
    integ = Newmark(dt=0.005, iterations=4, tol=1e-5, predictor="quadratic")
    lco = LCOCriteria()

    def run(sub, q0, v0, xi0, _index):
        return integ.run(sub, q0, v0, xi0, t_end=30.0, outputs=["q1"], lco=lco)

    initial = {"q0": 0.05, "static_manifold": False}
    small = march(system, rom, cases, {**initial, "start": "small"}, run)
    warm = march(system, rom, cases, {**initial, "start": "neighbour"}, run)
    assert list(small.status) == ["lco", "decay", "decay"]
    assert list(warm.status) == ["lco", "lco", "lco"]


def test_start_options_are_checked():
    params = ("altitude_ft", "gamma")
    check_start({"start": "neighbour", "along": "gamma"}, params)
    with pytest.raises(InputError, match=r"\[initial\] start: expected one of"):
        check_start({"start": "hot"}, params)
    with pytest.raises(InputError, match=r"\[initial\] along: expected a case parameter"):
        check_start({"along": "mach_number"}, params)
    with pytest.raises(InputError, match=r"\[initial\] static_manifold: expected true or false"):
        check_start({"static_manifold": "yes"}, params)


SWEEP = """
title = "starts"
[model]
builtin = "van_der_pol_duffing"
c1 = -1.0
d3 = 1.0
[initial]
q0 = 1.5
{initial}
[integrator]
dt = 0.01
t_end = 30.0
iterations = 3
{integrator}
[cases]
alpha = [0.1, 0.2, 0.3, 0.4]
gamma = 1.0
"""


def test_sweep_config_takes_the_start_and_step_options(tmp_path):
    from torchrom.study.config import load_sweep_config
    from torchrom.study.sweep import run_sweep

    path = tmp_path / "s.toml"
    path.write_text(SWEEP.format(initial='start = "neighbour"',
                                 integrator="adaptive = true\nstep_tol = 1e-4\nextrapolate = 2"))
    cfg = load_sweep_config(path)
    assert cfg.integrator.adaptive and cfg.integrator.extrapolate == 2
    table = run_sweep(cfg)[0]
    assert (table["status"] == "lco").all()
    # averaging: A = 2√(−(c1 + α)/d3) — the structural α adds to c1 = −1
    np.testing.assert_allclose(table["amplitude"], 2 * np.sqrt(1.0 - table["alpha"]), rtol=0.02)
    path.write_text(SWEEP.format(initial='start = "warm"', integrator=""))
    with pytest.raises(InputError, match=r"s\.toml: \[initial\] start: expected one of"):
        load_sweep_config(path)
    path.write_text(SWEEP.format(initial="", integrator="step_tol = -1.0"))
    with pytest.raises(InputError, match=r"s\.toml: \[integrator\].*step_tol"):
        load_sweep_config(path)
