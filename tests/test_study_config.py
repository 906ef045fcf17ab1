"""Sweep configurations from a dict as from a TOML file (torchrom.study.config): one validation
path, so the same tables give the same configuration and the same refusal, named by the file or
by ``<dict>`` (or the caller's name)."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.io import tomllib
from torchrom.study import config_from_dict, load_sweep_config

from .conftest import REPO

CONFIG = """title = "dict or file"
method = "newmark"
[model]
builtin = "van_der_pol_duffing"
frequencies_hz = [1.0, 2.3]
c1 = [-0.6, 0.05]
d3 = [1.0, 1.0]
[initial]
q0 = 0.05
mode = 1
[integrator]
dt = 0.01
t_end = 40.0
iterations = 2
[lco]
outputs = ["q1", "q2"]
rtol = 1e-3
[cases]
alpha = [0.0, 0.3]
gamma = { distribution = "lognormal", median = 1.0, sigma = 0.3 }
samples = 3
seed = 7
[plot]
x = "alpha"
hue = "gamma"
[variants.short]
integrator = { t_end = 20.0 }
"""


def _raw() -> dict:
    return tomllib.loads(CONFIG)


#: shipped configurations whose model needs no file a guide builds first
SHIPPED = ["demo_vdp", "uq_vdp", "calibrate_vdp", "bifurcation_subcritical", "goland_tunnel"]


@pytest.mark.parametrize("stem", SHIPPED)
def test_a_file_and_its_dict_give_the_same_configuration(stem):
    """The file's tables through config_from_dict named by the file are the loader's
    configuration field by field; named ``<dict>`` they differ only in that name (same hash,
    hence the same run key and case ids, same cases)."""
    path = REPO / "configs" / f"{stem}.toml"
    raw = tomllib.loads(path.read_text())
    from_file = load_sweep_config(path)
    assert config_from_dict(raw, name=path) == from_file
    from_dict = config_from_dict(raw)
    assert str(from_dict.source) == "<dict>"
    assert from_dict.hash == from_file.hash and from_dict.cases == from_file.cases
    assert from_dict.title == from_file.title and from_dict.integrator == from_file.integrator


def test_a_variant_is_merged_as_from_a_file(tmp_path):
    path = tmp_path / "study.toml"
    path.write_text(CONFIG)
    cfg = config_from_dict(_raw(), "short")
    assert cfg.t_end == 20.0 == load_sweep_config(path, "short").t_end
    assert cfg.hash == load_sweep_config(path, "short").hash != config_from_dict(_raw()).hash


def test_python_values_are_held_as_toml_would_hold_them():
    """Tuples, NumPy arrays and scalars and paths are what a notebook has at hand: they become
    the lists, numbers and strings a TOML file gives (same hash), and the dict is copied."""
    raw = _raw()
    same = _raw()
    same["model"]["frequencies_hz"] = np.array([1.0, 2.3])
    same["model"]["c1"] = (np.float64(-0.6), 0.05)
    same["initial"]["mode"] = np.int64(1)
    same["lco"]["outputs"] = ("q1", "q2")
    same["cases"]["samples"] = np.int32(3)
    cfg = config_from_dict(same)
    assert cfg.hash == config_from_dict(raw).hash and cfg.cases == config_from_dict(raw).cases
    assert type(cfg.raw["initial"]["mode"]) is int and cfg.raw["lco"]["outputs"] == ["q1", "q2"]
    same["cases"]["alpha"].append(0.5)  # the caller's dict changes later: the configuration not
    assert len({c["alpha"] for c in cfg.cases}) == 2


BAD = {
    # name: (TOML text edit old -> new, the message after "<source>: ")
    "negative dt": (("dt = 0.01", "dt = -0.01"),
                    "[integrator] dt: expected a positive number, got -0.01"),
    "unknown key": (("rtol = 1e-3", "rtool = 1e-3"),
                    "[lco]: unknown key 'rtool'; expected one of ['cycles', 'decay_ratio', "
                    "'max_amplitude', 'outputs', 'ring', 'rtol']"),
    "unknown method": (('method = "newmark"', 'method = "euler"'),
                       "method: expected one of ['newmark', 'hb', 'shooting'], got 'euler'"),
    "unknown table": (("[plot]", "[plots]"), None),
    "mode not a number": (("mode = 1", 'mode = "1"'),
                          "[initial] mode: expected a basis function number >= 1, got '1'"),
    "unknown variant": (None, "[variants]: no variant 'long'; the file has ['short']"),
}


@pytest.mark.parametrize("name", BAD)
def test_a_refusal_names_the_key_as_for_a_file(name, tmp_path):
    """The same damaged tables are refused with the same one-line message, the file's name
    replaced by ``<dict>`` or by the name the caller gives."""
    edit, expected = BAD[name]
    text = CONFIG.replace(*edit) if edit else CONFIG
    assert text != CONFIG or edit is None
    variant = "long" if edit is None else None
    path = tmp_path / "study.toml"
    path.write_text(text)
    with pytest.raises(InputError) as from_file:
        load_sweep_config(path, variant)
    with pytest.raises(InputError) as from_dict:
        config_from_dict(tomllib.loads(text), variant)
    with pytest.raises(InputError) as named:
        config_from_dict(tomllib.loads(text), variant, name="cell 3")
    message = str(from_file.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    assert str(from_dict.value) == "<dict>: " + message.removeprefix(f"{path}: ")
    assert str(named.value) == "cell 3: " + message.removeprefix(f"{path}: ")
    if expected is not None:
        assert message == f"{path}: {expected}"


@pytest.mark.parametrize(("edit", "expected"), [
    (lambda raw: raw["cases"].update(alpha=[0.0, None]),
     r"^<dict>: \[cases\] alpha: expected a TOML value .*, got NoneType None$"),
    (lambda raw: raw["cases"]["gamma"].update(median=object()),
     r"^<dict>: \[cases\] gamma\.median: expected a TOML value .*, got object <object"),
    (lambda raw: raw.update(title={1, 2}),
     r"^<dict>: title: expected a TOML value .*, got set \{1, 2\}$"),
    (lambda raw: raw["integrator"].update({3: 1.0}),
     r"^<dict>: \[integrator\]: key 3 is a int: expected string keys \(as in a TOML table\)$"),
])
def test_what_toml_cannot_hold_is_refused_naming_its_key(edit, expected):
    raw = _raw()
    edit(raw)
    with pytest.raises(InputError, match=expected):
        config_from_dict(raw)


def test_a_dict_must_be_a_mapping():
    with pytest.raises(InputError, match=r"^<dict>: top level: expected a dict of the "
                                         r"configuration's tables, got list$"):
        config_from_dict([("title", "x")])


def test_relative_paths_are_relative_to_the_named_folder(tmp_path, monkeypatch):
    """A file's paths are relative to its folder; a dict's to the folder of its name, the
    working directory for ``<dict>`` (as a notebook's cell runs)."""
    raw = {"model": {"rom": "missing.npz"}, "integrator": {"dt": 0.01, "t_end": 1.0},
           "cases": {"alpha": 0.1}}
    with pytest.raises(InputError) as named:
        config_from_dict(raw, name=tmp_path / "study" / "cell")
    assert str(named.value) == f"{tmp_path / 'study' / 'missing.npz'}: no such ROM file"
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError) as exc:
        config_from_dict(raw)
    assert str(exc.value) == "missing.npz: no such ROM file"
