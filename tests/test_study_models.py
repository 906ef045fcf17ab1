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
    at 10,000 ft; 2e-5 as that table): its altitudes are in m (altitude_m: a tunnel case at
    0 m has 1.225 kg/m^3, a matched point at 3,048 m V = M a(h) in m/s), the same model built
    with altitude_unit ft takes altitude_ft 10,000 to the same numbers (1e-12: 0.3048 m/ft
    exactly), an altitude in the other unit is refused (one unit per run, nothing converted),
    and the ft-slug-s model's are the same physical numbers in ft/s and slug/ft^3 (1e-12:
    exact conversions)."""
    files = _files(tmp_path)
    si = build_model(ModelSpec(files.source, rom=files.rom, aero=files.aero, units="si"))
    si_ft = build_model(ModelSpec(files.source, rom=files.rom, aero=files.aero, units="si",
                                  aeroelastic={"altitude_unit": "ft"}))
    ft = build_model(files)
    assert (si.altitude_column, si_ft.altitude_column) == ("altitude_m", "altitude_ft")
    assert si_ft.units.labels()["altitude"] == "ft" and si.units.labels()["altitude"] == "m"
    cases = [{"speed": 100.0, "altitude_m": 0.0}, {"altitude_m": 10000.0 * FT}]
    V, rho, alt = flight_conditions(si, cases)
    assert rho[0] == pytest.approx(1.225, rel=2e-5) and V[0] == 100.0
    assert rho[1] == pytest.approx(0.90477, rel=2e-5)
    assert V[1] == pytest.approx(si.mach * 1077.40 * FT, rel=2e-5)
    assert np.array_equal(alt, [0.0, 10000.0 * FT])
    V2, rho2, alt2 = flight_conditions(si_ft, [{"speed": 100.0, "altitude_ft": 0.0},
                                               {"altitude_ft": 10000.0}])
    assert V2 == pytest.approx(V, rel=1e-12) and rho2 == pytest.approx(rho, rel=1e-12)
    assert np.array_equal(alt2, [0.0, 10000.0])
    with pytest.raises(InputError, match="altitude_ft: the model's altitudes are in m"):
        flight_conditions(si, [{"altitude_ft": 10000.0}])
    V_ft, rho_ft, _ = flight_conditions(ft, [{"altitude_ft": 10000.0}])
    assert V_ft[0] * FT == pytest.approx(V[1], rel=1e-12)
    assert rho_ft[0] * ft.units.density_si == pytest.approx(rho[1], rel=1e-12)


def _free_files(folder, kappa=2.0e-3):
    """A free 'aircraft' of two mass-normalised modes: a rigid one (0 Hz) whose only
    aerodynamics is a negative steady stiffness, Q = [[-kappa, 0], [0, 0]] at every k (a
    statically unstable pitch), and an elastic 5 Hz mode without aerodynamics."""
    from torchrom.aero.dlm import GAF
    from torchrom.aero.rfa import RFA

    folder.mkdir(parents=True, exist_ok=True)
    w = 2 * np.pi * 5.0
    NonlinearROM(np.eye(2), np.diag([0.0, w * w]), frequencies_hz=[0.0, 5.0],
                 metadata={"unit_system": "si"}).save(folder / "rom.npz")
    a0 = np.diag([-kappa, 0.0])
    k = np.array([0.0, 0.1, 1.0])
    gaf = GAF(0.2, 1.0, k, np.repeat(a0[None], len(k), axis=0).astype(complex))
    z = np.zeros((2, 2))
    rfa = RFA(a0, z, z, np.zeros((2, 1)), -np.eye(1), np.zeros((1, 2)), np.ones(1),
              "minimum-state", 1.0, 0.2)
    save_aero(AeroData(gaf, rfa, {"unit_system": "si"}), folder / "aero.npz")
    return ModelSpec(folder / "c.toml", rom=folder / "rom.npz", aero=folder / "aero.npz")


def test_rigid_body_support_and_growth_against_closed_forms(tmp_path):
    """K1 += ω_s² M on the 0 Hz coordinate only: the supported ROM's linear frequencies are
    (f_s, 5 Hz) exactly; the largest real root of the state space is the closed form
    s = sqrt(q κ - ω_s²) of m s² + (ω_s² - q κ) = 0 (free: sqrt(q κ)), to round-off."""
    from torchrom.study.models import with_rigid_body_support

    spec = _free_files(tmp_path)
    free = build_model(spec)
    assert free.free and free.rigid_body_support_hz is None
    q = 0.5 * 1.225 * 100.0**2
    assert free.rigid_body_growth(100.0, 1.225, 0.0, 0.0) == pytest.approx(
        np.sqrt(q * 2.0e-3), rel=1e-10)
    held = build_model(ModelSpec(spec.source, rom=spec.rom, aero=spec.aero,
                                 rigid_body_support_hz=0.5))
    assert held.rigid_body_support_hz == 0.5
    np.testing.assert_allclose(held.rom.linear_frequencies_hz(), [0.5, 5.0], rtol=1e-12)
    np.testing.assert_array_equal(held.rom.frequencies_hz, [0.0, 5.0])  # the GAFs' modes
    assert held.rom.metadata["rigid_body_support_hz"] == 0.5
    ws = 2 * np.pi * 0.5
    assert held.rigid_body_growth(100.0, 1.225, 0.0, 0.0) == pytest.approx(
        np.sqrt(q * 2.0e-3 - ws**2), rel=1e-10)
    rom = NonlinearROM.load(spec.rom)
    with pytest.raises(InputError, match=r"rigid_body_support_hz: expected a frequency between "
                                         r"0 and 1\.667 Hz"):
        with_rigid_body_support(rom, 2.0, 2)
    clamped = rom.replace(K1=np.diag([1.0, 4.0]), frequencies_hz=[0.159, 0.318])
    with pytest.raises(InputError, match="no rigid-body"):
        with_rigid_body_support(clamped, 0.01, 2)
