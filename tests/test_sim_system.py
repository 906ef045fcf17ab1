"""CaseSystem: broadcasting, exact float64 parameters, selection and concatenation."""

import pytest
import torch

from torchrom.errors import InputError
from torchrom.rom import NonlinearROM
from torchrom.sim import CaseSystem


def _rom(n=2):
    return NonlinearROM(torch.eye(n, dtype=torch.float64), 4.0 * torch.eye(n, dtype=torch.float64))


def test_build_broadcasts_and_keeps_float64_values_exact():
    rom = _rom()
    s = CaseSystem.build(rom, alpha=[0.05, 0.1, 0.3], gamma=1e-3, damping_nl=[True, False, True],
                         K_add=torch.ones(2, 2, dtype=torch.float64))
    assert s.batch_size == 3 and s.n == 2 and s.n_lag == 0
    assert s.alpha.tolist() == [0.05, 0.1, 0.3]  # not rounded through float32
    assert s.gamma.tolist() == [1e-3] * 3
    assert s.damping_nl.tolist() == [1.0, 0.0, 1.0]
    assert s.K_add.shape == (3, 2, 2) and s.M_add is None


def test_select_and_concat_round_trip():
    rom = _rom()
    lag = {"lag_D": torch.rand(4, 2, 3), "lag_E": torch.rand(4, 3, 2),
           "lag_R": -torch.eye(3).expand(4, 3, 3)}
    s = CaseSystem.build(rom, alpha=torch.arange(4.0), **lag)
    a, b = s.select([0, 1]), s.select(torch.tensor([2, 3]))
    back = CaseSystem.concat([a, b])
    for name, t in s.fields().items():
        other = getattr(back, name)
        assert (t is None and other is None) or torch.equal(t, other), name
    # a system without additions next to one with them: the missing ones become zeros
    plain = CaseSystem.build(rom, 1)
    mixed = CaseSystem.concat([plain, CaseSystem.build(rom, 1, C_add=torch.ones(2, 2))])
    assert torch.equal(mixed.C_add[0], torch.zeros(2, 2, dtype=torch.float64))


def test_validation_names_the_field():
    rom = _rom()
    with pytest.raises(InputError, match="lag_D, lag_E and lag_R"):
        CaseSystem.build(rom, 2, lag_D=torch.zeros(2, 2, 1))
    with pytest.raises(InputError, match="CaseSystem.lag_E"):
        CaseSystem.build(rom, 2, lag_D=torch.zeros(2, 2, 1), lag_E=torch.zeros(2, 2, 2),
                         lag_R=torch.zeros(2, 1, 1))
    with pytest.raises(InputError, match="share one ROM"):
        CaseSystem.concat([CaseSystem.build(rom, 1), CaseSystem.build(_rom(), 1)])
