"""Column units of result tables (torchrom.study.units): kept in the parquet file, used for
axis labels."""

import pandas as pd

from torchrom.study.units import axis_label, column_units, sweep_units


def test_sweep_units_physical_and_generalized_outputs():
    cols = ["altitude_ft", "gamma", "alpha", "amplitude", "amplitude_A_Tz", "amplitude_q1",
            "ratio_q1_q2", "frequency_hz", "t_end", "my_parameter"]
    u = sweep_units(cols, ["A_Tz", "q1"], "ft")
    assert u["amplitude"] == "ft" and u["amplitude_A_Tz"] == "ft" and u["amplitude_q1"] == "-"
    assert (u["altitude_ft"], u["gamma"], u["alpha"], u["frequency_hz"], u["t_end"]) == (
        "ft", "s", "1/s", "Hz", "s")
    assert u["ratio_q1_q2"] == "-" and "my_parameter" not in u
    # a generalized first output (Van der Pol sum of coordinates) is dimensionless
    assert sweep_units(["amplitude"], ["sum"], None)["amplitude"] == "-"


def test_units_survive_parquet_and_label_axes(tmp_path):
    t = pd.DataFrame({"gamma": [1e-4], "amplitude": [1.0], "speed": [3.0]})
    t.attrs["units"] = {"amplitude": "ft", "speed": "ft/s"}
    t.to_parquet(tmp_path / "t.parquet")
    back = pd.read_parquet(tmp_path / "t.parquet")
    assert column_units(back) == {"gamma": "s", "amplitude": "ft", "speed": "ft/s"}
    assert axis_label(back, "speed") == "speed (ft/s)"
    assert axis_label(back, "gamma") == "γ (s)"
    # a CSV has no metadata: known columns are still named and labelled with their units
    csv = pd.DataFrame({"altitude_ft": [1.0], "amplitude": [1.0], "frequency_hz": [2.0],
                        "ratio_q1_q2": [3.0]})
    assert axis_label(csv, "altitude_ft") == "altitude (ft)"
    # an altitude's column names its unit, in the metadata and on the axis (issue 46 item 6)
    metres = pd.DataFrame({"altitude_m": [1000.0], "gamma": [0.0]})
    assert sweep_units(list(metres.columns), [], "m")["altitude_m"] == "m"
    assert axis_label(metres, "altitude_m") == "altitude (m)"
    assert axis_label(csv, "frequency_hz") == "LCO frequency (Hz)"
    assert axis_label(csv, "ratio_q1_q2") == "amplitude ratio q1/q2"
    assert axis_label(csv, "amplitude") == "LCO amplitude"  # its unit is the output's: unknown


def test_every_known_column_has_a_name_and_its_label_a_unit():
    """One table names every known column; a known unit always reaches the label."""
    from torchrom.study.units import KNOWN, LABELS

    assert set(KNOWN) <= set(LABELS)
    t = pd.DataFrame({k: [1.0] for k in KNOWN})
    for k, unit in KNOWN.items():
        if unit:
            assert axis_label(t, k) == f"{LABELS[k]} ({unit})"
