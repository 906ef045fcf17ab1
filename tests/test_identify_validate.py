"""Validation machinery (static Newton, free decay, metrics) on a model whose ROM is exact:
REFERENCE Sec. 5 as callables with the identity basis, so ROM and "FE" must agree to rounding."""

import numpy as np
import pytest

from torchrom.identify import validate as v
from torchrom.identify.build import IdentifyOptions, identify

from .identify_fixtures import touze_backend


@pytest.fixture(scope="module")
def exact_pair():
    be = touze_backend()
    be._outputs = {"A_Tx": 1, "A_Ty": 1, "A_Tz": 0}
    be._transverse_dofs = np.array([0])
    be._load_shapes = {"uniform": np.array([1.0, 0.5]), "step": np.array([1.0, -1.0])}
    res = identify(be, IdentifyOptions(n_linear=2, n_dual=0, damping="exact"))
    return be, res


def test_static_validation_of_an_exact_rom(exact_pair):
    be, res = exact_pair
    for shape, load in be.load_shapes().items():
        c = v.static_validation(be, res.rom, res.basis.Phi, shape, load, max_tip_fraction=0.25)
        assert c.tip_pct_span.max() >= 25.0 * (1 - 5e-3)  # levels stop within 0.5 %
        # same equations solved twice by Newton to 1e-10: agreement ~1e-9 relative
        assert max(c.errors.values()) < 1e-8, c.errors


def test_free_decay_of_an_exact_rom(exact_pair):
    be, res = exact_pair
    dec = v.free_decay_validation(be, res.rom, res.basis.Phi, be.load_shapes()["uniform"],
                                  tip_fraction=0.2, gamma=0.02, cycles=4, dt=0.1)
    # identical equations and integrator: differences are Newton tolerances
    assert np.abs(dec.rom - dec.fe).max() < 1e-7 * np.abs(dec.fe).max()
    assert dec.metrics["envelope_error"] < 1e-6 and dec.metrics["frequency_error"] < 1e-6
    assert dec.metrics["extrema"] == 8


def test_compare_decay_on_known_signals():
    t = np.linspace(0, 10, 20001)
    fe = 2.0 * np.exp(-0.05 * t) * np.cos(2 * np.pi * 1.0 * t)
    rom = 2.0 * 1.02 * np.exp(-0.05 * t) * np.cos(2 * np.pi * 1.005 * t)
    m = v.compare_decay(t, fe, rom, cycles=5)
    assert m["frequency_fe_hz"] == pytest.approx(1.0, rel=1e-4)
    assert m["frequency_error"] == pytest.approx(0.005, rel=2e-2)
    assert m["envelope_error"] == pytest.approx(0.02, abs=5e-3)


def test_compare_damping_identical_is_zero(exact_pair):
    _, res = exact_pair
    Q = np.random.default_rng(0).normal(size=(50, 2))
    out = v.compare_damping(res.rom, res.rom, Q, Q[::-1])
    assert out["D3_rel_diff"] == 0.0 and out["power_max_rel_diff"] == 0.0
