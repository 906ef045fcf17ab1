"""The shipped study configurations (configs/*.toml) load, expand and name their model."""

import pytest

from torchrom.study import load_sweep_config

from .conftest import REPO

CONFIGS = sorted((REPO / "configs").glob("*.toml"))


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_shipped_configuration_is_valid(path):
    cfg = load_sweep_config(path)
    assert cfg.cases and cfg.title


def test_uq_configuration_is_reproducible():
    a = load_sweep_config(REPO / "configs" / "uq_vdp.toml").cases
    b = load_sweep_config(REPO / "configs" / "uq_vdp.toml").cases
    assert a == b and len(a) == 300 and len({c["gamma"] for c in a}) == 100
