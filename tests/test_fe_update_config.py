"""Targets files of torchrom update (torchrom.fe.update_config): parsing and bad input."""

from __future__ import annotations

import pytest

from torchrom.errors import InputError
from torchrom.fe.update_config import load_update_spec

GOOD = """
[modes]
n = 6
[optimizer]
regularization = 0.01
[[target]]
frequency_hz = 1.69
kind = "bending"
[[target]]
frequency_hz = 3.05
kind = "torsion"
weight = 2.0
[[parameter]]
name = "nsm"
card = "pshell"
ids = [1, 2]
field = "NSM"
lower = 0.0
upper = 1.0
"""


def test_good_file(tmp_path):
    p = tmp_path / "t.toml"
    p.write_text(GOOD)
    spec = load_update_spec(p)
    assert [t.kind for t in spec.targets] == ["bending", "torsion"]
    assert spec.targets[1].weight == 2.0
    par = spec.parameters[0]
    assert (par.card, par.ids, par.field, par.stiffness) == ("PSHELL", (1, 2), "nsm", False)
    assert spec.options.n_modes == 6 and spec.options.regularization == 0.01


@pytest.mark.parametrize("old,new,message", [
    ('kind = "torsion"', 'kind = "twist"', "[[target]] 2: kind: expected one of"),
    ('field = "NSM"', 'field = "rho"', "PSHELL fields are nsm, t"),
    ("lower = 0.0", "lower = -1.0", "must stay non-negative"),
    ("upper = 1.0", "upper = 0.0", "expected lower < upper"),
    ("n = 6", "n = 1", "[modes]: n: expected at least the 2 targets"),
    ("n = 6", 'n = 6\npairing = "shape"', "[modes]: pairing: expected one of mac, kind"),
    ("frequency_hz = 1.69", "frequency_hz = -1.69", "frequency_hz: expected a positive"),
    ("regularization", "regularisation", "[optimizer]: unknown key(s) regularisation"),
])
def test_bad_files_name_the_key(tmp_path, old, new, message):
    p = tmp_path / "t.toml"
    p.write_text(GOOD.replace(old, new))
    with pytest.raises(InputError) as exc:
        load_update_spec(p)
    assert message in str(exc.value) and str(p) in str(exc.value)
