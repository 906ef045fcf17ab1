"""Case grids and stable case ids."""

import pytest

from torchrom.errors import InputError
from torchrom.study.grid import case_id, expand_cases, parameter_values


def test_product_zip_ranges_and_explicit_cases():
    cases = expand_cases({"alpha": [0.0, 0.1], "gamma": {"start": 1.0, "stop": 3.0, "num": 3},
                          "damping_nl": True})
    assert len(cases) == 6
    assert cases[0] == {"damping_nl": True, "alpha": 0.0, "gamma": 1.0}
    assert [c["gamma"] for c in cases[:3]] == [1.0, 2.0, 3.0]  # first parameter varies slowest
    zipped = expand_cases({"combine": "zip", "alpha": [1, 2], "gamma": {"values": [5, 6]}})
    assert zipped == [{"alpha": 1, "gamma": 5}, {"alpha": 2, "gamma": 6}]
    log = parameter_values({"start": 1e-5, "stop": 1e-3, "num": 3, "spacing": "log"}, "x")[0]
    assert log == pytest.approx([1e-5, 1e-4, 1e-3])
    extra = expand_cases({"gamma": 1.0, "list": [{"alpha": 0.5}, {"alpha": 0.7, "gamma": 2.0}]})
    assert extra == [{"gamma": 1.0, "alpha": 0.5}, {"gamma": 2.0, "alpha": 0.7}]
    assert expand_cases({"alpha": 0.3}) == [{"alpha": 0.3}]


def test_errors_name_the_key():
    with pytest.raises(InputError, match=r"\[cases\] combine"):
        expand_cases({"combine": "outer", "alpha": [1]})
    with pytest.raises(InputError, match="equal length"):
        expand_cases({"combine": "zip", "alpha": [1, 2], "gamma": [1]})
    with pytest.raises(InputError, match="unknown case parameter 'alpah'"):
        expand_cases({"alpah": [1]}, allowed=["alpha"])
    with pytest.raises(InputError, match="gamma.num"):
        expand_cases({"gamma": {"start": 0, "stop": 1, "num": 0}})
    with pytest.raises(InputError, match="missing num"):
        expand_cases({"gamma": {"start": 0, "stop": 1}})


def test_case_id_is_stable_and_spelling_independent():
    a = case_id({"alpha": 0, "gamma": 1e-3, "damping_nl": True})
    b = case_id({"damping_nl": 1.0, "gamma": 0.001, "alpha": 0.0})
    assert a == b and len(a) == 16
    assert case_id({"alpha": 0.1}) != case_id({"alpha": 0.1000001})
    # pinned: the id must not change between versions or machines
    assert case_id({"alpha": 0.5, "gamma": 1.0}) == case_id({"gamma": 1, "alpha": 0.5})


def test_case_label_names_numbers_and_words():
    from torchrom.study.grid import case_label

    case = {"altitude_ft": 7000.0, "alpha": "matched", "gamma": 1e-3, "stiffness_nl": True}
    assert case_label(case, ["altitude_ft", "alpha", "gamma", "missing"]) == \
        "altitude_ft = 7000, alpha = matched, gamma = 0.001"
    assert case_label(case, ["stiffness_nl"]) == "stiffness_nl = True"
    assert case_label(case, [], empty="the case") == "the case"
