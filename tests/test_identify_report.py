"""The identification report's labels (torchrom.identify.report): units from the FE model and
no NaN in the error tables (the full report is the slow test in test_identify_goland.py)."""

from types import SimpleNamespace

from torchrom.identify.report import _err, _units


def test_axis_units_come_from_the_fe_model():
    goland = SimpleNamespace(fe=SimpleNamespace(units={"length": "ft", "force": "lbf"}))
    assert _units(goland) == ("ft", "lbf/ft²")
    assert _units(SimpleNamespace(fe=SimpleNamespace(units={}))) == ("FE length units",
                                                                     "FE force/length²")
    assert _units(object()) == ("FE length units", "FE force/length²")


def test_undefined_relative_error_is_a_dash_not_nan():
    assert _err(float("nan")) == "–"
    assert _err(0.0123) == "0.0123" and _err(1.2e-4) == "1.200e-04"
