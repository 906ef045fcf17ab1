"""Built-in analytic ROMs: their forces are the written-out equations."""

import math

import numpy as np
import pytest
import torch

from torchrom.errors import InputError
from torchrom.rom.analytic import BUILTIN, touze_two_mode, van_der_pol_duffing


def test_van_der_pol_duffing_force_is_the_equation():
    f = [1.0, 2.5]
    c1, d2, d3, k3 = [-0.2, 0.1], [0.3, 0.0], [0.5, 0.7], [2.0, 4.0]
    cpl = np.array([[0.0, 1.5], [1.5, 0.0]])
    rom = van_der_pol_duffing(f, c1=c1, d2=d2, d3=d3, k3=k3, coupling=cpl)
    g = torch.Generator().manual_seed(0)
    q = torch.randn(5, 2, generator=g, dtype=torch.float64)
    v = torch.randn(5, 2, generator=g, dtype=torch.float64)
    alpha, gamma = 0.05, 1.7
    w2 = torch.tensor([(2 * math.pi * x) ** 2 for x in f], dtype=torch.float64)
    c1, d2, d3, k3 = (torch.tensor(x, dtype=torch.float64) for x in (c1, d2, d3, k3))
    expect = (alpha * v + gamma * (c1 + d2 * q + d3 * q**2) * v
              + w2 * q + q @ torch.tensor(cpl).T + k3 * q**3)
    got = rom.force(q, v, alpha, gamma)
    assert torch.allclose(got, expect, rtol=1e-13, atol=1e-12)
    assert rom.outputs["sum"].tolist() == [1.0, 1.0]
    assert set(BUILTIN) == {"van_der_pol_duffing", "touze_two_mode", "quintic_damping_oscillator"}


def test_touze_builtin_is_exact():
    rom = touze_two_mode()
    q = torch.tensor([[0.3, -0.2]], dtype=torch.float64)
    a, b = 1.13**2, 4.0
    q1, q2 = 0.3, -0.2
    f1 = a * q1 + 1.5 * a * q1**2 + b * q1 * q2 + 0.5 * a * q2**2 + 0.5 * (a + b) * (
        q1**3 + q1 * q2**2)
    assert abs(rom.stiffness_force(q)[0, 0].item() - f1) < 1e-14


def test_bad_parameters_name_the_field():
    with pytest.raises(InputError, match="c1"):
        van_der_pol_duffing([1.0, 2.0], c1=[1.0, 2.0, 3.0])
    with pytest.raises(InputError, match="frequencies_hz"):
        van_der_pol_duffing([-1.0])
    with pytest.raises(InputError, match="coupling"):
        van_der_pol_duffing([1.0, 2.0], coupling=[[0, 1], [2, 0]])
