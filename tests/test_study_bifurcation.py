"""Bifurcation character from batched initial-amplitude sweeps (torchrom.study.bifurcation,
torchrom bifurcation).

Independent references: first-order averaging (REFERENCE Sec. 4) — for q̈ + (c + d3 q²) q̇ + ω² q
= 0 the amplitude obeys dA/dt = −(A/2)(c + d3 A²/4): with c > 0 > d3 an unstable LCO of
amplitude 2 sqrt(c/−d3) separates decaying from growing motions (subcritical), with c < 0 < d3
every motion settles on A = 2 sqrt(−c/d3) (supercritical); for the bounded variant a SciPy
DOP853 solution of the same equations.
"""

from __future__ import annotations

import cmath
import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from torchrom.cli import main
from torchrom.study import load_sweep_config
from torchrom.study.bifurcation import bifurcation_sweep, label_attractors
from torchrom.study.sweep import case_evaluator

# 2 Hz, c1/ω = 0.08: averaging puts the threshold within 3e-5 of 2 sqrt(c/−d3) (checked with
# DOP853 bisection while writing this test)
SUBCRITICAL = """
title = "subcritical oscillator"
[model]
builtin = "van_der_pol_duffing"
frequencies_hz = 2.0
c1 = {c1}
d3 = {d3}
[initial]
q0 = 1.0
[integrator]
dt = 0.01
t_end = 20.0
iterations = 3
[lco]
max_amplitude = 4.0
[cases]
gamma = 1.0
alpha = {alpha}
"""


def test_attractor_labels():
    labels = label_attractors(["decay", "lco", "lco", "lco", "diverged", "unconverged"],
                              [0.01, 1.0, 1.01, 2.0, 9.0, 3.0], same_rtol=0.02)
    assert labels == ["rest", "lco0", "lco0", "lco1", "unbounded", "undecided"]


def test_subcritical_threshold_is_located(tmp_path, capsys):
    """Acceptance: c1 > 0 > d3 is classified subcritical; the threshold between decay and
    growth is the unstable LCO 2 sqrt((c1 + α)/−d3), located within 2 % (measured 0.04 %)."""
    cfg = tmp_path / "sub.toml"
    cfg.write_text(SUBCRITICAL.format(c1=1.0, d3=-4.0, alpha="[0.0, 1.0]"))
    js = tmp_path / "bif.json"
    assert main(["bifurcation", str(cfg), "--q0", "0.1", "3", "--num", "10", "--points", "6",
                 "--out", str(tmp_path / "out"), "--json", str(js)]) == 0
    result = json.loads(js.read_text())
    assert result["character"] == "subcritical"
    assert "coexisting attractors" in result["evidence"]
    for row in result["controls"]:
        exact = 2 * math.sqrt((1.0 + row["alpha"]) / 4.0)
        assert row["local"] == "bistable"
        assert row["threshold_low"] <= exact * 1.005 and row["threshold_high"] >= exact / 1.005
        assert abs(row["threshold_q0"] / exact - 1) < 0.02
        assert row["threshold_amplitude"] == pytest.approx(row["threshold_q0"])  # q1 observed
        assert row["decay"] > 0 and row["diverged"] > 0 and row["lco"] == 0
    assert "character: subcritical" in capsys.readouterr().out
    assert (tmp_path / "out" / "bifurcation.png").stat().st_size > 10_000


def test_supercritical_lco_is_reached_from_every_amplitude(tmp_path):
    """c1 < 0 < d3: one LCO 2 sqrt((−c1 − α)/d3) from every initial amplitude where the rest
    state is unstable, decay everywhere else: supercritical."""
    path = tmp_path / "super.toml"
    path.write_text(SUBCRITICAL.format(c1=-1.0, d3=1.0, alpha="[0.0, 0.5, 1.5]")
                    .replace("max_amplitude = 4.0", "max_amplitude = 20.0"))
    cfg = load_sweep_config(path)
    res = bifurcation_sweep(case_evaluator(cfg), cfg.cases, np.geomspace(0.05, 5.0, 8))
    assert res.character == "supercritical"
    s = res.summary.set_index("alpha")
    assert s["local"].tolist() == ["lco", "lco", "stable"]
    for alpha in (0.0, 0.5):
        expected = 2 * math.sqrt(1.0 - alpha)
        # first-order averaging with |c|/ω = 0.08: 0.3 % measured
        assert s.loc[alpha, "lco_amplitude_min"] == pytest.approx(expected, rel=0.01)
        assert s.loc[alpha, "lco_amplitude_max"] / s.loc[alpha, "lco_amplitude_min"] < 1.002
    assert "one LCO from every initial amplitude" in res.evidence
    assert set(res.runs["round"]) == {0}  # no basin boundary: nothing to refine


BOUNDED = """
title = "subcritical Hopf bounded by quintic damping"
[model]
builtin = "quintic_damping_oscillator"
[initial]
q0 = 1.0
[integrator]
dt = 0.005
t_end = 15.0
iterations = 4
tol = 1e-5
predictor = "quadratic"
[lco]
outputs = ["q1"]
[cases]
gamma = 1.0
alpha = [-1.3, 0.0, 1.0]
"""


def scipy_lco_amplitude(alpha: float, c1=1.0, d3=-5.0, d5=2.0, f=2.0, f2=20.0, zeta=0.5,
                        eps=0.05) -> float:
    """The same two equations with DOP853 (rtol 1e-10): half peak-to-peak of q1 at the end."""
    w, w2 = 2 * math.pi * f, 2 * math.pi * f2

    def rhs(t, y):
        q1, q2, v1, v2 = y
        a1 = -(alpha + c1 + d3 * q1**2 + d5 / eps**2 * q2**2) * v1 - w**2 * q1
        a2 = -(alpha + 2 * zeta * w2) * v2 - w2**2 * (q2 + eps * q1**2)
        return [v1, v2, a1, a2]

    sol = solve_ivp(rhs, (0, 12.0), [1.5, 0, 0, 0], method="DOP853", rtol=1e-10, atol=1e-12,
                    dense_output=True)
    q1 = sol.sol(np.linspace(10.0, 12.0, 20001))[0]
    return 0.5 * (q1.max() - q1.min())


def test_bounded_subcritical_shows_hysteresis(tmp_path):
    """The quintic-damping variant (large motions settle on a stable LCO): all runs reach the
    large LCO where the rest state is unstable (α = −1.3), rest and LCO coexist at α = 0
    (hysteresis: the jump up and the return happen at different α), everything decays at α = 1.
    The threshold at α = 0 is the averaged unstable LCO (root of 1 − 5x/4 + κ x²/4, κ from
    the slave's response), within 2 % (0.4 % measured); the stable LCO matches SciPy within 0.2 %
    (first-order averaging is not valid there: the damping is strongly nonlinear)."""
    path = tmp_path / "bounded.toml"
    path.write_text(BOUNDED)
    cfg = load_sweep_config(path)
    res = bifurcation_sweep(case_evaluator(cfg), cfg.cases, np.geomspace(0.05, 2.0, 10),
                            points=6)
    s = res.summary.set_index("alpha")
    assert res.character == "subcritical"
    assert s["local"].tolist() == ["lco", "bistable", "stable"]
    r = 2 * 2.0 / 20.0
    H = 1 / (1 - r * r + 2j * 0.5 * r)
    kappa = 2 + abs(H) ** 2 - 2 * abs(H) * math.cos(cmath.phase(H))
    x = (1.25 - math.sqrt(1.25**2 - kappa)) / (kappa / 2)  # smaller root of 1 − 1.25x + κx²/4
    assert s.loc[0.0, "threshold_q0"] == pytest.approx(math.sqrt(x), rel=0.02)
    for alpha in (-1.3, 0.0):
        assert s.loc[alpha, "lco_amplitude_max"] == pytest.approx(
            scipy_lco_amplitude(alpha), rel=2e-3)
