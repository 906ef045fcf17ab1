"""The shipped study configurations (configs/*.toml) load, expand and name their model."""

import pytest

from torchrom.study import load_sweep_config

from .conftest import REPO

CONFIGS = sorted((REPO / "configs").glob("*.toml"))
#: configurations of a deck's ROM that its guide page builds first (not shipped): they load
#: up to the missing file, which the refusal names (the full run: tests/test_bah.py, slow)
BUILT_BY_A_GUIDE = {"bah_lco": "docs/guide/bah.md", "bah_free_lco": "docs/guide/bah.md",
                    "pazy_skin_lco": "docs/guide/pazy-flutter.md",
                    "pazy_aoa_lco": "docs/guide/pazy-aoa.md",
                    "wingbox_lco": "docs/guide/own-wing.md",
                    "goland_lco_motion": "docs/guide/viewers.md"}


@pytest.mark.parametrize("path", CONFIGS, ids=[p.stem for p in CONFIGS])
def test_shipped_configuration_is_valid(path):
    if path.stem in BUILT_BY_A_GUIDE:
        from torchrom.errors import InputError

        assert (REPO / BUILT_BY_A_GUIDE[path.stem]).is_file()
        with pytest.raises(InputError, match=r"rom\w*\.npz: no such ROM file"):
            load_sweep_config(path)
        return
    cfg = load_sweep_config(path)
    assert cfg.cases and cfg.title


def test_uq_configuration_is_reproducible():
    a = load_sweep_config(REPO / "configs" / "uq_vdp.toml").cases
    b = load_sweep_config(REPO / "configs" / "uq_vdp.toml").cases
    assert a == b and len(a) == 300 and len({c["gamma"] for c in a}) == 100
