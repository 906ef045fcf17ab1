"""USSA-76 atmosphere against REFERENCE.md Sec. 1 (geometric altitude, ft and SI units)."""

import numpy as np
import pytest

from torchrom.aero.atmosphere import (
    FT,
    SLUG_PER_FT3,
    atmosphere,
    density,
    flight_condition,
    speed_of_sound,
)
from torchrom.errors import InputError

# REFERENCE Sec. 1 (ambiance and fluids agree to 6 digits):
# altitude ft, T K, p Pa, rho kg/m3, rho slug/ft3, a ft/s
TABLE = [
    (0.0, 288.150, 101325.0, 1.22500, 2.376891e-3, 1116.45),
    (4000.0, 280.227, 87513.0, 1.08793, 2.110933e-3, 1100.99),
    (10000.0, 268.347, 69694.6, 0.90477, 1.755549e-3, 1077.40),
    (11275.0, 265.824, 66318.2, 0.86911, 1.686358e-3, 1072.33),
    (20000.0, 248.564, 46600.7, 0.65312, 1.267258e-3, 1036.93),
]


@pytest.mark.parametrize("h_ft, T, p, rho_si, rho_ft, a_ft", TABLE)
def test_matches_reference_table_to_5_digits(h_ft, T, p, rho_si, rho_ft, a_ft):
    st = atmosphere(h_ft, "ft")
    si = atmosphere(h_ft * FT, "si")
    # acceptance "5 significant digits": 2e-5 relative covers the table's own rounding
    assert st.temperature == pytest.approx(T, rel=2e-5)
    assert si.pressure == pytest.approx(p, rel=2e-5)
    assert si.density == pytest.approx(rho_si, rel=2e-5)
    assert st.density == pytest.approx(rho_ft, rel=2e-5)
    assert st.speed_of_sound == pytest.approx(a_ft, rel=2e-5)


def test_units_are_consistent_between_ft_and_si():
    h = np.array([0.0, 5000.0, 30000.0])
    ft, si = atmosphere(h, "ft"), atmosphere(h * FT, "si")
    np.testing.assert_allclose(ft.density * SLUG_PER_FT3, si.density, rtol=1e-12)
    np.testing.assert_allclose(ft.speed_of_sound * FT, si.speed_of_sound, rtol=1e-12)
    assert density(4000.0) == pytest.approx(2.110933e-3, rel=2e-5)
    assert speed_of_sound(0.0) == pytest.approx(1116.45, rel=2e-5)


def test_paper_flutter_point_flight_condition():
    # REFERENCE Sec. 1: M 0.70 at 11,275 ft -> V = 750.6 ft/s, q = 475.1 psf
    fc = flight_condition(0.7, 11275.0)
    assert fc.velocity == pytest.approx(750.6, abs=0.05)
    assert fc.dynamic_pressure == pytest.approx(475.1, abs=0.05)


def test_vectorised_matched_point():
    fc = flight_condition(0.7, [0.0, 10000.0])
    assert fc.velocity.shape == (2,) and fc.velocity[0] > fc.velocity[1]


@pytest.mark.parametrize(
    "call, match",
    [
        (lambda: atmosphere(300000.0), "outside the USSA-76 range"),
        (lambda: atmosphere(-20000.0, "ft"), "outside the USSA-76 range"),
        (lambda: atmosphere(1000.0, "furlongs"), "units"),
        (lambda: atmosphere(float("nan")), "finite"),
        (lambda: flight_condition(-0.5, 0.0), "mach"),
    ],
)
def test_bad_input_gives_one_line_error(call, match):
    with pytest.raises(InputError, match=match) as exc:
        call()
    assert "\n" not in str(exc.value)


def test_in_lbf_s_and_mm_t_s_against_published_sea_level_values():
    """Sea level in the two other systems against published constants: rho = 2.376891e-3
    slug/ft^3 / 12^4 (1 slug/ft^3 = 1 lbf s^2/ft^4; REFERENCE Sec. 1, 2e-5), which is the
    1.1468e-7 lbf s^2/in^4 of MSC's in-lbf-s examples (RHOREF of HA145) to 0.05 % (MSC rounds
    from 0.002378 slug/ft^3), 1.225e-12 t/mm^3 (1.225 kg/m^3 exactly converted:
    1e-12), a = 13,397 in/s (1116.45 ft/s x 12, 2e-5 as the table above), p = 14.696 psi
    (1 atm, 5 digits: 5e-5)."""
    inch = atmosphere(0.0, "in-lbf-s")
    mm = atmosphere(0.0, "mm-t-s")
    assert inch.density == pytest.approx(2.376891e-3 / 12**4, rel=2e-5)
    assert inch.density == pytest.approx(1.1468e-7, rel=5e-4)
    assert inch.speed_of_sound == pytest.approx(1116.45 * 12, rel=2e-5)
    assert inch.pressure == pytest.approx(14.696, rel=5e-5)
    assert mm.density == pytest.approx(1.225e-12, rel=1e-12)
    assert mm.speed_of_sound == pytest.approx(atmosphere(0.0, "si").speed_of_sound * 1e3,
                                              rel=1e-12)
    assert mm.pressure == pytest.approx(0.101325, rel=1e-12)


def test_altitude_unit_of_each_system():
    """Altitude is in ft for the imperial systems, m for the metric ones: 10,000 ft gives the
    same state in ft-slug-s and in-lbf-s, and 3,048 m the same in si and mm-t-s (1e-12)."""
    ft, inch = atmosphere(10000.0, "ft-slug-s"), atmosphere(10000.0, "in-lbf-s")
    assert inch.temperature == pytest.approx(ft.temperature, rel=1e-12)
    assert inch.speed_of_sound == pytest.approx(12 * ft.speed_of_sound, rel=1e-12)
    si, mm = atmosphere(3048.0, "si"), atmosphere(3048.0, "mm-t-s")
    assert mm.temperature == pytest.approx(si.temperature, rel=1e-12)
    assert si.temperature == pytest.approx(ft.temperature, rel=1e-12)
    with pytest.raises(InputError, match="altitude 90000 m is outside"):
        atmosphere(90000.0, "si")
    with pytest.raises(InputError, match="units: expected one of"):
        atmosphere(0.0, "furlong")


@pytest.mark.parametrize("system", ["si", "ft-slug-s", "in-lbf-s", "mm-t-s"])
def test_altitude_given_with_its_unit(system):
    """The altitude travels with its unit: in every system, 10,000 ft (altitude_unit "ft")
    and 3,048 m (altitude_unit "m", closed form 10,000 x 0.3048 m/ft) give the same density,
    speed of sound and matched-point speed as the system's own unit does (1e-12: the
    conversion is exact, so only rounding differs); the state and the flight condition record
    the unit; the range error names it."""
    ft = atmosphere(10000.0, system, altitude_unit="ft")
    m = atmosphere(10000.0 * 0.3048, system, altitude_unit="m")
    own = atmosphere(10000.0 if system in ("ft-slug-s", "in-lbf-s") else 3048.0, system)
    for x in (ft, own):
        assert x.density == pytest.approx(m.density, rel=1e-12)
        assert x.speed_of_sound == pytest.approx(m.speed_of_sound, rel=1e-12)
    assert (ft.altitude_unit, m.altitude_unit) == ("ft", "m")
    fc_ft = flight_condition(0.7, [0.0, 10000.0], system, altitude_unit="ft")
    fc_m = flight_condition(0.7, [0.0, 3048.0], system, altitude_unit="m")
    assert fc_ft.velocity == pytest.approx(fc_m.velocity, rel=1e-12)
    assert fc_ft.dynamic_pressure == pytest.approx(fc_m.dynamic_pressure, rel=1e-12)
    assert fc_m.altitude_unit == "m" and list(fc_m.altitude) == [0.0, 3048.0]
    with pytest.raises(InputError, match="altitude 300000 ft is outside"):
        atmosphere(300000.0, system, altitude_unit="ft")


def test_unknown_altitude_unit_is_one_line():
    with pytest.raises(InputError, match="altitude_unit: expected one of m, ft, got 'km'") as e:
        atmosphere(1000.0, "si", altitude_unit="km")
    assert "\n" not in str(e.value)
