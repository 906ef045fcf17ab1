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
