"""The model a sweep runs (torchrom.study.models): built from its parsed [model] table
(ModelSpec, build_model), in the unit system its files record or [model] units declares; the
flight conditions of its cases in that system."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.aero.atmosphere import FT
from torchrom.aero.files import AeroData, save_aero
from torchrom.aero.rfa import fit_minimum_state
from torchrom.errors import InputError
from torchrom.rom import NonlinearROM
from torchrom.study.cases import flight_conditions
from torchrom.study.models import ModelSpec, build_model

from .test_aero_flutter import _altitude_case


def _files(folder, rom_meta=None, aero_meta=None):
    folder.mkdir(parents=True, exist_ok=True)
    _, st, gaf, _ = _altitude_case()
    NonlinearROM(st.M, st.K, metadata=rom_meta or {}).save(folder / "rom.npz")
    save_aero(AeroData(gaf, fit_minimum_state(gaf, n_lags=4), aero_meta or {}),
              folder / "aero.npz")
    return ModelSpec(folder / "c.toml", rom=folder / "rom.npz", aero=folder / "aero.npz")


def test_units_recorded_declared_or_assumed(tmp_path):
    spec = _files(tmp_path)
    assert build_model(spec).units.name == "ft-slug-s"  # neither records one: assumed
    declared = ModelSpec(spec.source, rom=spec.rom, aero=spec.aero, units="si")
    assert build_model(declared).units.name == "si"
    spec = _files(tmp_path / "mixed", {"unit_system": "si"}, {"unit_system": "ft-slug-s"})
    with pytest.raises(InputError, match=r"c.toml: \[model\]: rom.npz is in si but aero.npz "
                                         r"in ft-slug-s"):
        build_model(spec)


def test_flight_conditions_in_the_models_units(tmp_path):
    """An SI model's cases against USSA-76 in SI (the atmosphere's own table, REFERENCE
    Sec. 1: 1.22500 kg/m^3 at sea level, 0.90477 kg/m^3 and a = 1077.40 ft/s = 328.392 m/s
    at 10,000 ft; 2e-5 as that table): a tunnel case at altitude_ft 0 has 1.225 kg/m^3, a
    matched point at 10,000 ft (altitude_ft stays in ft) V = M a(h) in m/s; the ft-slug-s
    model's are the same physical numbers in ft/s and slug/ft^3 (1e-12: exact conversions)."""
    files = _files(tmp_path)
    si = build_model(ModelSpec(files.source, rom=files.rom, aero=files.aero, units="si"))
    ft = build_model(files)
    cases = [{"speed": 100.0, "altitude_ft": 0.0}, {"altitude_ft": 10000.0}]
    V, rho, alt = flight_conditions(si, cases)
    assert rho[0] == pytest.approx(1.225, rel=2e-5) and V[0] == 100.0
    assert rho[1] == pytest.approx(0.90477, rel=2e-5)
    assert V[1] == pytest.approx(si.mach * 1077.40 * FT, rel=2e-5)
    assert np.array_equal(alt, [0.0, 10000.0])
    V_ft, rho_ft, _ = flight_conditions(ft, cases[1:])
    assert V_ft[0] * FT == pytest.approx(V[1], rel=1e-12)
    assert rho_ft[0] * ft.units.density_si == pytest.approx(rho[1], rel=1e-12)
