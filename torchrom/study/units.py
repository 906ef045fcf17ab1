"""Units of result-table columns, kept with the table (``DataFrame.attrs["units"]``, which
pandas stores in the parquet file's metadata) and used to label figure axes.

:func:`sweep_units` gives the units of a sweep's columns: the known parameter and result
columns (:data:`KNOWN`) and the amplitudes in the units of the decision output (the model's
length unit for a physical output such as point A's ``A_Tz``, ``-`` for generalized coordinates).
:func:`column_units` reads them back (a CSV has no metadata: the known columns are still
labelled; an altitude's column names its unit, ``altitude_ft`` or ``altitude_m``).
:func:`axis_label` names a column for a figure axis from :data:`LABELS` (one
table for every plot of the package) with its unit.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import pandas as pd

#: units of the columns every table of this package may hold ("-": dimensionless)
KNOWN = {
    "altitude_ft": "ft", "altitude_m": "m", "mach": "-", "alpha": "1/s", "gamma": "s",
    "stiffness_nl": "-",
    "damping_nl": "-", "amplitude_pct_span": "% of span", "frequency_hz": "Hz",
    "steps": "-", "t_end": "s", "amplitude_change": "-", "solver_error": "-",
    "reference_altitude_ft": "ft", "reference_altitude_m": "m", "flutter_frequency_hz": "Hz",
    "growth_rate": "1/s",
    "initial_amplitude": None, "threshold_amplitude": None,
    # flight condition of an aeroelastic sweep (ft-slug-s; a sweep's metadata gives its model's)
    "speed": "ft/s", "density": "slug/ft^3", "velocity": "ft/s", "dynamic_pressure": "lbf/ft^2",
}


def sweep_units(columns: Sequence[str], outputs: Sequence[str], length_unit: str | None,
                extra: Mapping[str, str] | None = None) -> dict[str, str]:
    """Units of a sweep table's ``columns``: :data:`KNOWN`, amplitudes (``amplitude`` in the first
    output's units, ``amplitude_<output>`` in each output's), ratios dimensionless."""

    def output_unit(name: str) -> str:
        generalized = name == "sum" or (name.startswith("q") and name[1:].isdigit())
        return "-" if generalized or not length_unit else length_unit

    units = {k: v for k, v in KNOWN.items() if k in columns and v is not None}
    if "amplitude" in columns and outputs:
        units["amplitude"] = output_unit(outputs[0])
    for name in outputs:
        if f"amplitude_{name}" in columns:
            units[f"amplitude_{name}"] = output_unit(name)
    units.update({c: "-" for c in columns if c.startswith("ratio_")})
    units.update(extra or {})
    return units


def column_units(table: pd.DataFrame) -> dict[str, str]:
    """Units of the table's columns: its metadata over :data:`KNOWN`."""
    known = {k: v for k, v in KNOWN.items() if v is not None and k in table.columns}
    return {**known, **dict(table.attrs.get("units", {}) or {})}


#: what each known column measures, as figure axes and legends name it
LABELS = {
    "altitude_ft": "altitude", "altitude_m": "altitude", "mach": "Mach number", "alpha": "α",
    "gamma": "γ",
    "stiffness_nl": "stiffness nonlinearity", "damping_nl": "damping nonlinearity",
    "amplitude": "LCO amplitude", "amplitude_pct_span": "LCO amplitude",
    "frequency_hz": "LCO frequency", "steps": "time steps", "t_end": "simulated time",
    "amplitude_change": "amplitude change per cycle", "solver_error": "solver error",
    "reference_altitude_ft": "reference altitude", "reference_altitude_m": "reference altitude",
    "flutter_frequency_hz": "flutter frequency",
    "growth_rate": "growth rate", "initial_amplitude": "initial amplitude",
    "threshold_amplitude": "threshold amplitude", "floquet_multiplier": "Floquet multiplier",
    "harmonic_distortion": "harmonic distortion", "q0": "initial q",
    "speed": "speed", "density": "air density", "velocity": "speed",
    "dynamic_pressure": "dynamic pressure",
}


def column_name(column: str) -> str:
    """What ``column`` measures (:data:`LABELS`; ``amplitude_<output>`` and ``ratio_<a>_<b>``
    by pattern; the column's own name otherwise)."""
    if column in LABELS:
        return LABELS[column]
    if column.startswith("ratio_") and column.count("_") == 2:
        a, b = column.split("_")[1:]
        return f"amplitude ratio {a}/{b}"
    if column.startswith("amplitude_"):
        return f"LCO amplitude of {column[len('amplitude_'):]}"
    return column


def axis_label(table: pd.DataFrame, column: str) -> str:
    """``name (unit)`` of a column (:func:`column_name`; ``-`` for a dimensionless one); the
    name alone when the unit is unknown."""
    unit = column_units(table).get(column)
    name = column_name(column)
    return f"{name} ({unit})" if unit else name
