"""The unit systems (torchrom.units): SI factors against exact definitions, the deck rule,
the metadata a file records, and the refusal of files of different systems."""

import pytest

from torchrom.errors import InputError
from torchrom.units import (
    LEGACY_SYSTEM,
    SYSTEMS,
    file_units,
    infer_units,
    recorded_units,
    resolve_units,
    speed_system,
    unit_system,
)


def test_factors_against_exact_definitions():
    """Exact definitions (NIST SP 811): 1 ft = 0.3048 m, 1 in = 0.0254 m, 1 lbf =
    4.4482216152605 N, so 1 slug = 14.5939029 kg and 1 lbf s^2/in = 175.126836 kg (8 digits
    published: 1e-8); sea-level density 1.225 kg/m^3 in each system: 2.3768924e-3 slug/ft^3
    (REFERENCE Sec. 1 prints 2.376891e-3: 2e-6)."""
    assert SYSTEMS["ft-slug-s"].kilogram == pytest.approx(14.593903, rel=1e-7)
    assert SYSTEMS["in-lbf-s"].kilogram == pytest.approx(175.126836, rel=1e-8)
    assert SYSTEMS["ft-slug-s"].sea_level_density == pytest.approx(2.376891e-3, rel=2e-6)
    assert SYSTEMS["mm-t-s"].sea_level_density == pytest.approx(1.225e-12, rel=1e-14)
    assert SYSTEMS["ft-slug-s"].pressure_si == pytest.approx(47.880259, rel=1e-8)  # psf
    assert SYSTEMS["in-lbf-s"].pressure_si == pytest.approx(6894.7573, rel=1e-8)  # psi
    assert SYSTEMS["in-lbf-s"].gravity == pytest.approx(386.08858, rel=1e-8)
    assert unit_system("ft") is SYSTEMS["ft-slug-s"]
    labels = SYSTEMS["si"].labels()
    assert labels["speed"] == "m/s" and labels["dynamic_pressure"] == "Pa"
    with pytest.raises(InputError, match=r"--units: expected one of si, ft-slug-s, in-lbf-s, "
                                         r"mm-t-s, got 'imperial'"):
        unit_system("imperial")


@pytest.mark.parametrize("rhoref, grav, wtmass, expected", [
    ([1.225], [], None, "si"),  # BAH aircraft
    ([0.0023769], [], None, "ft-slug-s"),
    ([1.1468e-7], [], 0.0025907, "in-lbf-s"),  # HA146C: RHOREF and WTMASS agree
    ([1.145e-7], [], None, "in-lbf-s"),  # pt145 (RHOREF at altitude)
    ([1.225e-12], [9810.0], None, "mm-t-s"),
    ([], [32.174], 0.031081, "ft-slug-s"),  # HA144D-style weight units in ft
    ([], [], 0.00259, "in-lbf-s"),
    ([1.0], [], None, None),  # density-ratio convention: says nothing
    ([], [], None, None),
])
def test_deck_rule(rhoref, grav, wtmass, expected):
    found, evidence = infer_units(rhoref, grav, wtmass)
    assert (found.name if found else None) == expected
    assert bool(evidence) == (expected is not None)


def test_conflicting_cards_and_declared_units_are_refused():
    with pytest.raises(InputError, match=r"AERO RHOREF 1.225 says si but PARAM WTMASS "
                                         r"0.00259 says in-lbf-s; declare"):
        infer_units([1.225], [], 0.00259, "bah.bdf")
    found, evidence = infer_units([1.225])
    assert resolve_units(None, found, evidence, "x").name == "si"
    assert resolve_units("si", found, evidence, "x").name == "si"
    assert resolve_units("in-lbf-s", None, [], "x").name == "in-lbf-s"
    with pytest.raises(InputError, match=r"x: --units in-lbf-s: the deck's AERO RHOREF 1.225 "
                                         r"says si"):
        resolve_units("in-lbf-s", found, evidence, "x")


def test_recorded_units_of_old_and_new_files():
    assert recorded_units({"unit_system": "si"}).name == "si"
    # rom.npz of the Goland deck before the field: its units dict
    assert recorded_units({"units": {"length": "ft", "mass": "slug", "time": "s"}}).name \
        == "ft-slug-s"
    assert recorded_units({"units": "ft, slug, s"}).name == "ft-slug-s"  # old aero.npz
    # an FE model's units (the Goland deck's)
    assert recorded_units({"length": "ft", "mass": "slug", "time": "s"}).name == "ft-slug-s"
    assert recorded_units({"units": {"system": "consistent units of the deck"}}) is None
    assert recorded_units({}) is None


def test_files_of_different_systems_are_refused_and_legacy_said():
    si, ft = {"unit_system": "si"}, {"unit_system": "ft-slug-s"}
    with pytest.raises(InputError, match=r"rom.npz is in si but aero.npz in ft-slug-s: files "
                                         r"of different unit systems"):
        file_units({"rom.npz": si, "aero.npz": ft})
    assert file_units({"rom.npz": si, "aero.npz": si}) == (SYSTEMS["si"], "")
    system, note = file_units({"rom.npz": {}, "aero.npz": {}})
    assert system.name == LEGACY_SYSTEM and "assumed ft-slug-s" in note
    system, note = file_units({"rom.npz": {}, "aero.npz": {}}, declared="si")
    assert system.name == "si" and "declared" in note
    system, note = file_units({"rom.npz": si, "aero.npz": {}})
    assert system.name == "si" and "assumed for aero.npz" in note
    with pytest.raises(InputError, match=r"--units ft-slug-s: rom.npz records si"):
        file_units({"rom.npz": si, "aero.npz": {}}, declared="ft-slug-s")


def test_recorded_units_of_an_identified_rom_before_the_field():
    """A ROM identified before the field keeps its FE model's units under source.units."""
    meta = {"source": {"units": {"length": "ft", "mass": "slug", "time": "s", "force": "lbf"}}}
    assert recorded_units(meta).name == "ft-slug-s"
    assert recorded_units({"source": "goland.bdf"}) is None


def test_air_density_of_a_system():
    """A density is an air density of a system within 0.01..2 of its sea level (USSA-76 at
    31 km is 0.0126 of sea level): SI sea level and 30 km pass, the same density in slug/ft^3
    (515x smaller) or lbf s^2/in^4 does not."""
    from torchrom.aero.atmosphere import atmosphere
    from torchrom.units import is_air_density

    si = SYSTEMS["si"]
    assert is_air_density(1.225, si)
    assert is_air_density(float(atmosphere(30000.0, "si").density), si)
    assert not is_air_density(SYSTEMS["ft-slug-s"].sea_level_density, si)
    assert not is_air_density(1.225, SYSTEMS["ft-slug-s"])


@pytest.mark.parametrize("speeds, expected", [
    ([2000.0, 9000.0], "in-lbf-s"),  # above 1,312 ft/s and 400 m/s, below 10,000 mm/s
    ([4774.3, -5542.34], "in-lbf-s"),  # bah_plane's FLFACT 3 (a negative V: the sign is a flag)
    ([12.0, 25.0], "si"),  # below 32.8 ft/s
    ([30.0, 450.0], None),  # m/s and ft/s and (450) in/s: overlaps say nothing
    ([250.0, 4750.0], None),  # BAH Mach 0: 250 is m/s, 4750 in/s
    ([1.0, 121.0], None),  # Pazy's tunnel sweep: 1 m/s lies in no range
    ([147.5, 174.8], None),  # the 2-mode deck: m/s or ft/s
    ([5000.0, 20000.0], None),  # 20,000 is no in/s of a subsonic sweep, 5,000 no mm/s
    ([0.0], None),
    ([], None),
])
def test_flutter_speeds_tell_a_system_only_outside_the_overlaps(speeds, expected):
    """The typical sweep 10..400 m/s is ft/s 32.8..1312.3, in/s 393.7..15748, mm/s
    10,000..400,000 (exact: 1 ft = 0.3048 m, 1 in = 0.0254 m); a list names a system only when
    all its speeds are in that range and none in another."""
    found = speed_system(speeds)
    assert (found.name if found else None) == expected


def test_flfact_velocities_break_a_tie_or_are_refused_against_the_cards():
    """Where RHOREF tells the system, agreeing velocities join the evidence, undecided ones are
    silent and contradicting ones are refused naming both cards; without a telling card, FLFACT
    densities (RHOREF 1) and velocities must agree (either alone tells nothing)."""
    found, evidence = infer_units([1.1468e-7], velocities={"FLFACT 3": [2000.0, 9000.0]})
    assert found.name == "in-lbf-s"
    assert evidence == ["AERO RHOREF 1.1468e-07", "FLFACT 3 velocities 2000..9000"]
    found, evidence = infer_units([1.225], velocities={"FLFACT 3": [4774.3, 5542.34],
                                                       "FLFACT 6": [30.0, 450.0]})
    assert found.name == "si" and evidence == ["AERO RHOREF 1.225"]  # bah_plane: 30..5542
    with pytest.raises(InputError, match=r"^bah.bdf: units: FLFACT 3 velocities "
                                         r"4774.3..5542.34 are in/s \(in-lbf-s\) but AERO "
                                         r"RHOREF 1.225 says si; correct the FLFACT or declare "
                                         r"the deck's system with --units$"):
        infer_units([1.225], where="bah.bdf", velocities={"FLFACT 3": [4774.3, -5542.34]})
    with pytest.raises(InputError, match=r"FLFACT 9 velocities 12..25 are m/s \(si\) but "
                                         r"PARAM WTMASS 0.00259 says in-lbf-s"):
        infer_units([], [], 0.00259, velocities={"FLFACT 9": [12.0, 25.0]})
    found, evidence = infer_units([1.0], densities={"FLFACT 1": [1.1468e-7]},
                                  velocities={"FLFACT 3": [2000.0, 9000.0]})
    assert found.name == "in-lbf-s"
    assert evidence == ["FLFACT 1 densities 1.1468e-07..1.1468e-07",
                        "FLFACT 3 velocities 2000..9000"]
    # the 2-mode deck: densities that are SI air, velocities of m/s or ft/s: nothing told
    assert infer_units([1.0], densities={"FLFACT 51": [0.0179, 1.5525]},
                       velocities={"FLFACT 53": [147.5, 174.8]}) == (None, [])
    assert infer_units(densities={"FLFACT 1": [1.225]},
                       velocities={"FLFACT 3": [2000.0, 9000.0]}) == (None, [])
    assert infer_units(velocities={"FLFACT 3": [2000.0, 9000.0]}) == (None, [])


def test_a_system_with_another_altitude_unit():
    """with_altitude: the labels and the altitude factor carry the run's unit (0.3048 m/ft,
    exact), the rest of the system is unchanged; the system's own unit or None returns it as
    it is; an unknown unit is one line naming where it was given."""
    from torchrom.units import ALTITUDE_COLUMNS, altitude_column

    si = SYSTEMS["si"]
    si_ft = si.with_altitude("ft")
    assert si_ft.labels()["altitude"] == "ft" and si_ft.altitude_metre == 0.3048
    assert si_ft.name == "si" and si_ft.labels()["speed"] == "m/s"
    assert si.with_altitude(None) is si and si.with_altitude("m") is si
    assert SYSTEMS["ft-slug-s"].with_altitude("m").labels()["altitude"] == "m"
    assert altitude_column("m") == "altitude_m" and ALTITUDE_COLUMNS["altitude_ft"] == "ft"
    with pytest.raises(InputError, match="--altitude-unit: expected one of m, ft, got 'km'"):
        si.with_altitude("km")
