"""Public Nastran decks beside MSC Nastran's own answers (their f06), see tests/decks/*/SOURCE.md.

Each deck is read as a new user would (default options: unsupported cards refused) and its
modes compared with the f06's first REAL EIGENVALUES table: every elastic mode within 1 %
(the issue's target; the measured differences are printed and listed in README). Rigid-body
modes (Nastran's frequency below 1e-4 of its largest: round-off, whose relative difference means
nothing) must be rigid here too (below 1e-4 of our largest). Exclusions are stated per deck.
Flutter: speed and frequency of the flutter points against the f06's FLUTTER SUMMARY.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.f06 import read_real_eigenvalues
from torchrom.fe import read_bdf

DECKS = Path(__file__).parent / "decks"

# folder, deck, f06, {mode number: reason} of modes outside the 1 % target (asserted looser)
MODES = [
    ("pynastran_pt145", "pt145.bdf", "pt145.f06", {}),
    ("pynastran_beam_modes", "beam_modes.dat", "beam_modes.f06", {}),
    ("pynastran_bah_plane", "bah_plane.bdf", "bah_plane.f06", {}),
    ("pynastran_bah_gust", "BAH_Plane_cont_gust_LINE5000000_10FREQs.bdf",
     "BAH_Plane_cont_gust_LINE5000000_10FREQs.f06", {}),
    ("pynastran_goland_sol200", "goland_final_test.bdf", "goland_final_test.f06", {}),
    ("pynastran_2_mode_flutter", "0012_flutter.bdf", "0012_flutter.f06", {}),
    ("ekm_swept_plane", "sol103_swept_plane.bdf", "sol103_swept_plane.f06", {}),
    ("ekm_bar_beam", "test_case.bdf", "test_case.f06", {}),
    # CROD with PARAM COUPMASS and CMASS1: MSC's coupled rod mass (axial [5 1; 1 5] / 12)
    ("cofe_ten_bar_truss", "modes.dat", "modes.f06", {}),
    # glider: tapered PBEAML TUBE, BOX (their shear factors), RBAR, free-free
    ("pynastran_fmondsp", "fmondsp.dat", "fmondsp.f06", {}),
    ("pynastran_bah_plane_mach0", "BAH_Plane.bdf", "BAH_Plane.f06", {}),
    ("pynastran_ha144d", "ha144da.bdf", "ha144da.f06", {}),
    ("pynastran_bah_ha146c", "ha146c.bdf", "ha146c.f06", {}),
    ("pynastran_actuator_tf", "actuator_tf_modeling.bdf", "actuator_tf_modeling.f06", {}),
    # The cylinder (curved CQUAD4 shell): all 14 elastic modes within 0.26 % since the residual
    # bending flexibility on the quad's constant transverse shear (2.1-2.6 % stiffer without).
    ("dakota_cylinder", "modal.bdf", "modal.f06", {}),
    # strut-braced wing: 65 PBEAMs, grids in CORD2R systems, RBE2, SUPORT, COUPMASS: 14 elastic
    # modes within 0.11 % (the CBEAM's torsional inertia lumped in its coupled mass, as MSC's)
    ("pynastran_buckled", "buckled.bdf", "buckled.f06", {}),
    # one of each: CHEXA, CPENTA, CTETRA, CQUAD4/CTRIA3 on PSHELL and PCOMP, CBEAM/PBEAM, CBAR,
    # CROD. +0.90, +0.15, +1.56 % with the CHEXA's and CPENTA's incompatible modes (fully
    # integrated: +1.45, +0.92, +2.37 %): mode 3 still outside 1 %, asserted within 3 %; not
    # isolated further (solids 1000x stiffer: +2.9 to +5.4 %, shells 1000x stiffer: +5.3 to
    # +9.5 %, both with the fully integrated solids), see SOURCE.md.
    ("pynastran_solid_shell_bar", "mode_solid_shell_bar.bdf", "mode_solid_shell_bar.f06",
     {3: "+1.56 %, cause not isolated (SOURCE.md)"}),
]


@pytest.mark.parametrize("folder, deck, f06, loose", MODES, ids=[m[0] for m in MODES])
def test_modes_match_nastran(folder, deck, f06, loose):
    ref = read_real_eigenvalues(DECKS / folder / f06)[0].cycles
    fe = read_bdf(DECKS / folder / deck)
    rigid = np.abs(ref) < 1e-4 * np.abs(ref).max()
    # the f06 lists its rigid-body modes among its n; torchrom counts them apart (never as
    # 0 Hz elastic modes) and computes the elastic ones past them
    modes = fe.modes(int((~rigid).sum()))
    assert modes.n_rigid == int(rigid.sum())
    f = np.concatenate([np.zeros(modes.n_rigid), modes.frequencies_hz])
    assert len(f) == len(ref)
    diff = 100 * (f[~rigid] - ref[~rigid]) / ref[~rigid]
    modes = np.flatnonzero(~rigid) + 1
    print(folder, "diff % by mode:", dict(zip(modes.tolist(), np.round(diff, 4).tolist())))
    for m, d in zip(modes, diff):
        assert abs(d) <= (3.0 if m in loose else 1.0), (m, d)


def test_flutter_pt145_ke_against_its_f06():
    """pt145 (KE, Mach 0.45): the f06's crossing of POINT 2, linearly interpolated in the same
    9 reduced frequencies as ours. Measured with Nastran's parabolic DLM kernel (the default of
    ``run_deck``): speed +0.47 %, frequency -0.28 % (target 2 %). With the quartic kernel they
    were +1.46 % and -2.37 %: the unstable root's damping g(k) then sits up to 0.0075 below
    Nastran's, and g crosses zero at a shallow angle (0.03 per k step), so the crossing moves
    by a quarter of a step; speeds and frequencies at each k agree within 0.3 % with either."""
    from torchrom.aero.nastran_flutter import compare_f06, run_deck

    folder = DECKS / "pynastran_pt145"
    res = run_deck(folder / "pt145.bdf", log=lambda *_: None)
    text, records = compare_f06(res, folder / "pt145.f06")
    print(text)
    (rec,) = [r for r in records if r["velocity"] is not None]
    assert rec["nastran_velocity"] == pytest.approx(6004.2, rel=1e-4)
    assert abs(rec["velocity_diff_pct"]) <= 2.0
    assert abs(rec["frequency_diff_pct"]) <= 2.0
    # each k of the f06's POINT 2 (its V-g table): damping within 0.005 (measured: 0.0023 from
    # k = 0.111 to 0.333, 0.0043 at k = 0.5; the quartic kernel: up to 0.0075)
    nastran_g = [0.13659, 0.08610, 0.04501, 0.01086, -0.01723, -0.03892, -0.05286, -0.05649,
                 -0.04729]
    sw = res.results[0].sweep
    order = np.argsort(sw.k[:, 1])
    assert np.abs(sw.damping[order, 1] - nastran_g).max() <= 0.005


def test_flutter_two_mode_pknl_against_its_f06s():
    """0012_flutter (PKNL matched path, 93 points) against its two f06s. Simcenter Nastran 2024
    (0012_flutter2.f06): speed +0.01 %, frequency +1.24 % (target 2 %: met), and both roots'
    damping at each of the first 20 rows within 0.0005 (measured 0.00013: the pitch root
    -0.00622 vs -0.00626 at the first row). MSC Nastran 2005 (0012_flutter.f06): speed -0.35 %,
    frequency -5.5 % (asserted within 6 %): its pitch root's aerodynamic damping is 20 % below
    both torchrom's and Simcenter's (-0.00520 at the first row), so its roots coalesce later in
    frequency; the f06 of the old MSC run, not torchrom, is the outlier (quartic kernel against
    Simcenter: frequency -1.1 %)."""
    from torchrom.aero.nastran_flutter import compare_f06, run_deck
    from torchrom.f06 import read_flutter_summary

    folder = DECKS / "pynastran_2_mode_flutter"
    res = run_deck(folder / "0012_flutter.bdf", log=lambda *_: None)
    for f06, freq_tol in (("0012_flutter2.f06", 2.0), ("0012_flutter.f06", 6.0)):
        text, records = compare_f06(res, folder / f06)
        print(f06, text)
        (rec,) = [r for r in records if r["velocity"] is not None]
        assert abs(rec["velocity_diff_pct"]) <= 2.0
        assert abs(rec["frequency_diff_pct"]) <= freq_tol
    sweep = res.results[0].sweep
    for table in read_flutter_summary(folder / "0012_flutter2.f06"):
        ours = sweep.damping[:20, table.point - 1]
        np.testing.assert_allclose(ours, table.damping[:20], rtol=0, atol=5e-4)


def _bah_plane_both_subcases(tmp_path) -> Path:
    """bah_plane as its f06 was run: SUBCASE 2 (FMETHOD = 502, Mach 0.2) restored (the deck
    ships with it commented out), the includes beside it."""
    folder = DECKS / "pynastran_bah_plane"
    for inc in folder.glob("*.inc"):
        (tmp_path / inc.name).write_text(inc.read_text())
    text = (folder / "bah_plane.bdf").read_text()
    text = text.replace("$SUBCASE 2\n$  FMETHOD = 502", "SUBCASE 2\n  FMETHOD = 502")
    assert "\nSUBCASE 2\n  FMETHOD = 502" in text
    path = tmp_path / "bah_plane.bdf"
    path.write_text(text)
    return path


def _bah_plane_rom(path, n_linear: int, n_dual: int, n_amplitudes: int):
    """The free-free bah_plane identified (Python API of ``torchrom identify``): its rigid-body
    modes first at 0 Hz, dual modes on the transverse combinations of the elastic modes."""
    from torchrom.identify.basis import DualModeOptions, transverse_combinations
    from torchrom.identify.build import IdentifyOptions, identify

    fe = read_bdf(path)
    m = fe.modes(n_linear)
    kinds = (["rigid-body"] * m.n_rigid + list(m.kinds))[:n_linear]
    opt = IdentifyOptions(n_linear=n_linear, n_dual=n_dual, dual=DualModeOptions(
        combinations=transverse_combinations(kinds), n_amplitudes=n_amplitudes))
    return fe, identify(fe, opt).rom


def test_identify_bah_plane_free_free():
    """bah_plane (free-free: plunge and pitch) identified with 4 linear modes and 1 dual mode
    (reduced form of the slow chain below): the 2 rigid-body modes at 0 Hz with zero rows in
    K1, K2, K3 (the dual-mode static solves under inertia relief converged), the elastic ones
    the f06's 2.454 and 3.754 Hz (4 digits printed in the f06 table: 1e-3)."""
    f06 = read_real_eigenvalues(DECKS / "pynastran_bah_plane" / "bah_plane.f06")[0]
    _, rom = _bah_plane_rom(DECKS / "pynastran_bah_plane" / "bah_plane.bdf", 4, 1, 2)
    f = np.asarray(rom.frequencies_hz)
    assert np.all(f[:2] == 0.0)
    assert np.allclose(f[2:4], np.asarray(f06.cycles)[2:4], rtol=1e-3)
    for name in ("K1", "K2", "K3"):
        A = np.asarray(getattr(rom, name))
        assert all(np.abs(np.take(A, [0, 1], axis=ax)).max() == 0.0 for ax in range(A.ndim))
    assert np.all(np.diag(np.asarray(rom.K1))[2:4] > 0)


@pytest.mark.slow
def test_rom_flutter_bah_plane_free_free_against_the_deck(tmp_path):
    """The free-free ROM chain on bah_plane: identify (8 linear modes, 2 of them rigid at
    0 Hz, + 1 dual), GAFs on the same 8 modes (the deck's boxes, splines and MKAERO k, the
    deck flutter's parabolic kernel), p-k of the ROM's linear part at the deck's FLUTTER 502
    condition (Mach 0.2, ρ = 1.225 kg/m³ = RHOREF × FLFACT 4, V = 30..450 m/s) against the
    deck's own answer (``torchrom flutter`` of the same deck without residual vectors, the
    ROM's basis). Measured: ROM 394.30 m/s, 3.1779 Hz, sustained; deck 393.43, 3.1784 Hz
    (+0.22 %, −0.02 %); f06 394.04 (+0.07 %), bracketed by the f06's speeds 390 and 420.
    Target (issue 35): 2 % and inside the bracket. No rigid-body root crosses (as in the f06
    at these speeds, apart from its real POINT 2 root, see the test above). ~15 s."""
    from torchrom.aero.build import build_from_deck
    from torchrom.aero.crossings import pk_crossings
    from torchrom.aero.flutter import AeroTable, ModalStructure, pk_sweep
    from torchrom.aero.nastran_flutter import NASTRAN_KERNEL, load_deck, run_deck

    path = _bah_plane_both_subcases(tmp_path)
    fe, rom = _bah_plane_rom(path, 8, 1, 4)
    aero = build_from_deck(path, fe, 0.2, 8, kernel=NASTRAN_KERNEL)
    assert np.array_equal(aero.metadata["frequencies_hz"][:2], [0.0, 0.0])
    structure = ModalStructure.from_rom(rom, 8, 0.0, 0.0)
    table = AeroTable.from_gaf(aero.gaf)
    sweep = pk_sweep(structure, table, np.arange(30.0, 451.0, 30.0), 1.225, mach=0.2,
                     eps=1e-7)
    found = pk_crossings(structure, table, sweep)
    assert not found.rigid_body
    (rom_point,) = found.flutter
    deck = run_deck(load_deck(path, resvec=False), fe, log=lambda *_: None)
    (m02,) = [r for r in deck.results if r.mach == 0.2]
    (deck_point,) = m02.points
    print(f"ROM {rom_point.velocity:.2f} m/s {rom_point.frequency_hz:.4f} Hz; deck "
          f"{deck_point.velocity:.2f} m/s {deck_point.frequency_hz:.4f} Hz")
    assert rom_point.kind == deck_point.kind == "sustained"
    assert rom_point.velocity == pytest.approx(deck_point.velocity, rel=0.02)
    assert rom_point.frequency_hz == pytest.approx(deck_point.frequency_hz, rel=0.02)
    assert 390.0 < rom_point.velocity < 420.0


def test_state_space_flutter_of_free_bah_plane_is_its_rfa_pk(tmp_path):
    """The state-space (RFA) path of ROM flutter on the free aircraft: bah_plane's 8 modes
    (2 rigid at 0 Hz; the ROM's linear part, modal), GAFs at Mach 0.2, 13-lag RFA, at
    rho = 1.225 kg/m³. Independent reference: p-k on the RFA's own Q(ik) (the state space is
    exact for it): the same flutter speed and frequency (1e-5: p-k's convergence), from an
    elastic root; the root of a rigid-body mode (oscillatory with its aerodynamic stiffness,
    0.7 Hz) that crosses zero on the way is listed apart. Without the rigid-body and round-off
    rules the largest growth rate put the flutter point at 32.8 m/s on the untouched,
    undamped 8.70 Hz mode. Measured: 230.46 m/s, 3.5562 Hz; p-k on the tabulated GAFs
    394.30 m/s, 3.1779 Hz: the RFA's fit (13.5 % rms, 52 % on the entry of rigid mode 2
    and mode 4) is the difference, not the state space."""
    from torchrom.aero.build import build_from_deck
    from torchrom.aero.crossings import pk_crossings
    from torchrom.aero.flutter import AeroTable, ModalStructure, pk_sweep
    from torchrom.aero.flutter_speed import flutter_speed_at_density
    from torchrom.aero.nastran_flutter import NASTRAN_KERNEL

    path = _bah_plane_both_subcases(tmp_path)
    # the deck's MKAERO list at Mach 0.2, the RFA fitted on all of it (the default before
    # issue 46; the default now fits k <= 1, tests/test_bah.py): the 13.5 % fit whose state
    # space is checked here against the p-k on its own Q
    mkaero = [0.001, 0.05, 0.1, 0.2, 0.5, 1.0, 1.2, 1.5, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 10.0]
    aero = build_from_deck(path, read_bdf(path), 0.2, 8, k_list=mkaero, kernel=NASTRAN_KERNEL)
    structure = ModalStructure.from_modes(aero.metadata["frequencies_hz"])
    table = AeroTable.from_gaf(aero.gaf)
    ss = flutter_speed_at_density(structure, aero.rfa, table, 1.225, speeds=(30.0, 450.0),
                                  mach=0.2)
    rfa_table = AeroTable(lambda k: aero.rfa.evaluate([k])[0], aero.gaf.semichord,
                          k_max=table.k_max)
    rfa_table.k_damp = table.k_damp
    sweep = pk_sweep(structure, rfa_table, np.arange(30.0, 451.0, 30.0), 1.225, mach=0.2,
                     eps=1e-7)
    (pk,) = pk_crossings(structure, rfa_table, sweep).flutter
    assert ss.velocity == pytest.approx(pk.velocity, rel=1e-5)
    assert ss.frequency_hz == pytest.approx(pk.frequency_hz, rel=1e-5)
    ((mode, at),) = ss.rigid_body_crossings
    assert mode in (0, 1) and 30.0 < at < 450.0  # a rigid-body mode (measured: 2, 343 m/s)


def test_flutter_bah_plane_free_free_pk_against_its_f06(tmp_path):
    """bah_plane: a free-free aircraft (wing, fuselage beam, tail; SPC only on x, y, roll and yaw
    at the root: plunge and pitch are rigid-body modes), PK at Mach 0.2, 30 speeds. Its 2
    rigid-body modes are kept in the basis at 0 Hz (as Nastran's ND = 8 counts them), and, as in
    the f06, LMODES = 10 takes 2 residual vectors past the 8 eigenmodes (Nastran's default
    RESVEC; torchrom's inertia-relief vectors: 39.02 and 56.557 Hz where the f06 has 41.229 and
    56.557, see torchrom.fe.resvec).

    Measured: flutter of POINT 4 (the 3.75 Hz mode) at 393.23 vs 394.04 (-0.21 %) and 3.1791
    vs 3.1784 Hz (+0.02 %); target 2 %. Without residual vectors (``resvec=False``, 8 modes):
    393.43 (-0.15 %) and 3.1784 Hz (0.00 %). The short-period root (the rigid pitch-plunge
    pair, POINT 2 of the f06) at V = 30: s = -0.6560 + 0.5677i vs -0.6448 + 0.5640i (1.7 % and
    0.7 %), asserted within 3 %: it checks the rigid-body aerodynamics (wing and tail) without
    elastic coupling; the cause of the 1.7 % is not isolated (Q_I/k interpolated at k = 0.038
    between MKAERO 0.001 and 0.05, as in Nastran, or the basis). Excluded: the f06's
    divergence-type crossing of POINT 2 at 437.8 (a real root): the f06 prints only the most
    positive real root per point and moves the others to 'LESS CRITICAL REAL ROOTS' lists, so
    which branch carries it is Nastran's bookkeeping; torchrom follows the short-period pair
    into the more damped of its two real roots. Mach 0 (FLUTTER 501): no crossing in either."""
    from torchrom.aero.nastran_flutter import compare_f06, run_deck

    res = run_deck(_bah_plane_both_subcases(tmp_path), log=lambda *_: None)
    assert np.array_equal(res.frequencies_hz[:2], [0.0, 0.0]) and len(res.frequencies_hz) == 10
    text, records = compare_f06(res, DECKS / "pynastran_bah_plane" / "bah_plane.f06")
    print(text)
    # the second residual vector is Nastran's 10th mode (56.557 Hz; f06: 5.655734E+01)
    assert res.frequencies_hz[9] == pytest.approx(56.55734, rel=1e-5)
    ours = [r for r in records if r["velocity"] is not None]
    (rec,) = ours  # one crossing, matched
    # the branch of the 3.75 Hz mode (the f06's POINT 4), told by its in-vacuo frequency, not
    # by its index
    assert rec["mach"] == 0.2
    assert res.frequencies_hz[rec["mode"] - 1] == pytest.approx(3.754, rel=1e-3)
    # unstable to the last speed (450) in both; the rigid-body modes' roots cross nowhere here
    assert rec["kind"] == rec["nastran_kind"] == "sustained"
    assert not any(r.rigid_points for r in res.results)
    # FLUTTER 501 (Mach 0, 4774 to 5542): no crossing in either, but the f06's POINT 4 is
    # unstable from the first speed (g = +0.0678 at 2.32 Hz), and so is ours (measured +0.0740
    # at 2.155 Hz: within 0.01 in g; the 7 % in frequency not isolated), reported as such
    # (by its damping and frequency: which root index carries it depends on the eigensolver's
    # ordering, which differs between BLAS kernels)
    osc = [(r, j) for r, j in res.unstable_at_start() if r.sweep.frequency_hz[0, j] > 0]
    assert [r.case.sid for r, _ in osc] == [501]
    ((r501, j),) = osc
    assert r501.sweep.damping[0, j] == pytest.approx(0.0678, abs=0.01)
    assert r501.sweep.frequency_hz[0, j] == pytest.approx(2.155, rel=0.01)
    assert rec["nastran_velocity"] == pytest.approx(394.04, abs=0.01)
    assert abs(rec["velocity_diff_pct"]) <= 2.0
    assert abs(rec["frequency_diff_pct"]) <= 2.0
    (m02,) = [r for r in res.results if r.mach == 0.2]
    # the in-plane mode (8.70 Hz, the 5th) and the second residual vector (56.56 Hz), which the
    # flat boxes do not load (|g| <= 3e-16 and 2e-9, measured), are listed as such (issue 46);
    # nothing diverges in 30..450
    assert [res.frequencies_hz[j] for j in m02.not_loaded] == pytest.approx([8.7026, 56.557],
                                                                           rel=1e-4)
    assert m02.divergence_points == []
    # V = 30, the short-period root: the oscillatory one of the rigid-body modes' branches
    # (which of the two 0 Hz branches carries it is the basis' order, not physics)
    rigid = np.flatnonzero(res.frequencies_hz == 0.0)
    (s,) = [s for s in m02.sweep.eigenvalues[0, rigid] if s.imag > 0]
    assert m02.sweep.velocity[0] == 30.0
    assert abs(s.real / -0.64477 - 1) <= 0.03 and abs(s.imag / 0.56398 - 1) <= 0.03


def test_flutter_bah_plane_at_mach_0_equals_mach_0_2(tmp_path):
    """bah_plane's FLUTTER 502 (30 to 450, free-free, AERO ACSID 2) at Mach 0 instead of 0.2:
    no f06 at Mach 0 is public, so the reference is physics: compressibility at Mach 0.2
    (β = 0.98) moves a subsonic flutter point by well under 1 %. Measured: the first crossing
    is still POINT 4's, at 393.88 (Mach 0.2: 393.23 here, 394.04 in the f06), 3.1822 Hz (3.1791;
    f06 3.1784); asserted within 0.5 % of the f06's Mach 0.2 point, with no earlier crossing
    of any root (rigid-body roots included: the Mach 0 steady GAF and the Mach 0 DLM kernel)."""
    from torchrom.aero.nastran_flutter import run_deck

    path = _bah_plane_both_subcases(tmp_path)
    text = path.read_text().replace("FLFACT,5,.2 $mach", "FLFACT,5,0. $mach")
    # 15 speeds instead of 30 (test time): the crossing is refined between speeds anyway
    text = text.replace("FLFACT,6,30., THRU, 450., 30", "FLFACT,6,30., THRU, 450., 15")
    assert "FLFACT,5,0. $mach" in text and "450., 15" in text
    path.write_text(text.replace("SUBCASE 1\n  FMETHOD = 501\n", ""))
    res = run_deck(path, log=lambda *_: None)
    (m0,) = [r for r in res.results if r.case.sid == 502]
    assert m0.mach == 0.0
    first = min(m0.points, key=lambda p: p.velocity)
    print("Mach 0:", first.velocity, first.frequency_hz, first.mode)
    # the branch of the 3.75 Hz mode (the f06's POINT 4), by its in-vacuo frequency
    assert res.frequencies_hz[first.mode] == pytest.approx(3.754, rel=1e-3)
    assert first.velocity == pytest.approx(394.04, rel=5e-3)
    assert first.frequency_hz == pytest.approx(3.1784, rel=5e-3)


def test_flutter_bah_plane_mach_0_coarse_speeds_against_its_f06():
    """BAH_Plane (pyNastran's MATLAB example, MSC 2012 f06): bah_plane at Mach 0 with speeds
    250 apart, no residual vectors. The f06's unstable root (its POINT 3 from 500 on; at 250
    its POINT 3 is another, damped root: Nastran's branches swap in the first step) has g
    +0.0523, -0.0239, +0.4027 at 500, 750, 1000: the root goes unstable, stable, unstable, and
    the summary's linear interpolation puts crossings at 458 (across the swap) and 764. Ours is
    the same root on the branch of the 3.75 Hz mode: +0.0601, -0.0209, +0.4121 (asserted
    within 0.01) at 3.046, 3.088, 3.236 Hz (f06 3.048, 3.090, 3.253; within 1 %); interpolated
    as the f06 does, its second crossing is at 762.1 (f06 763.89, -0.23 %). Solved at speeds
    between (torchrom.aero.crossings) the first crossing is 393.8, where the Mach 0.2 f06 with
    fine speeds has it (394.04): the coarse list, not the aerodynamics, moves Nastran's.
    Before the p-k steps were halved when tracking fails, two of our branches (2.45 and
    3.75 Hz) converged to this one root from 500 on and the damped one was lost. The 9.0 and
    14.5 Hz branches also ended on one root at some of these speeds, halvings or not, until a
    branch that lands on a root another holds was solved again with the held roots excluded
    (torchrom.aero.flutter._pk_solve_all): no two branches share a root now."""
    from dataclasses import replace

    from torchrom.aero.flutter import _mac, _shared_roots
    from torchrom.aero.nastran_flutter import load_deck, run_deck

    folder = DECKS / "pynastran_bah_plane_mach0"
    deck = load_deck(folder / "BAH_Plane.bdf")
    deck.cases = [replace(deck.cases[0], values=np.array([250.0, 500.0, 750.0, 1000.0]))]
    res = run_deck(deck, log=lambda *_: None)
    sw = res.results[0].sweep
    # the branches of the 2.45 and 3.75 Hz modes (by in-vacuo frequency, not index) stay on
    # two roots (they shared one before)
    a, b = (int(np.argmin(np.abs(res.frequencies_hz - f))) for f in (2.454, 3.754))
    assert res.frequencies_hz[[a, b]] == pytest.approx([2.454, 3.754], rel=1e-3)
    for s, vec in zip(sw.eigenvalues, sw.vectors):
        assert (abs(s[a] - s[b]) > 1e-6 * np.abs(s).max()
                or _mac(vec[:, a], vec[:, b]) < 0.99)
        assert not _shared_roots(s, vec)
    g = sw.damping[1:, b]
    f = np.abs(sw.eigenvalues[1:, b].imag) / (2 * np.pi)
    np.testing.assert_allclose(g, [0.052279, -0.023851, 0.40266], rtol=0, atol=0.01)
    np.testing.assert_allclose(f, [3.04824, 3.08958, 3.25317], rtol=0.01)
    crossing = 750 + 250 * -g[1] / (g[2] - g[1])
    assert crossing == pytest.approx(763.89, rel=0.02)


def test_flutter_bah_plane_mach_0_crossings_labelled_against_its_f06():
    """BAH_Plane at Mach 0 over its 38 speeds (250 to 4750, and the negated speeds + 0.01 by
    magnitude): every oscillatory crossing of the f06's FLUTTER SUMMARY, labelled by the same
    rule (sustained: unstable to the last speed; hump: stable again), is matched by a crossing
    of ours of the same kind whose onset lies between the two f06 speeds that bracket Nastran's,
    and, for a hump, whose re-stabilisation lies in Nastran's bracket of it. Nastran's crossings
    (its first run of speeds; the second repeats them): POINT 3 hump 250-500 (stable again
    500-750), POINT 3 hump 750-1000 (stable again 4500-4750), POINT 6 hump 500-750 at 7.3 Hz
    (stable again 750-1000), POINT 10 hump 1250-1500 (2500-2750), POINT 9 sustained 2250-2500.
    Measured (solved between the speeds): 393.81 (stable again 693.81), 810.61 (4639.0), 659.42
    at 7.299 Hz (829.72), 1432.4 (2528.7), 2279.1 sustained. Not compared: Nastran's
    real-root (k = 0) crossings (POINT 2 at 496, 6 at 2535, 7 at 1233): Nastran prints the most
    positive real root of each point, torchrom follows an oscillatory pair into the more damped
    of its real roots (see the bah_plane test above). Ours also has a hump of the 14.5 Hz
    branch from 562.3 to 664.3 (peak g = +0.014) that lies between the f06's speeds 500 and 750
    (it was found by probing the sampled damping's maximum at 750; a sweep with speeds 12.5
    apart has g = +0.0001 at 562.5 and +0.0007 at 662.5, measured). The rigid-body modes'
    roots (0 Hz) are listed apart, never as flutter; no two branches share a root."""
    from torchrom.aero.flutter import _shared_roots
    from torchrom.aero.nastran_flutter import compare_f06, f06_flutter_points, run_deck
    from torchrom.f06 import read_flutter_summary

    folder = DECKS / "pynastran_bah_plane_mach0"
    res = run_deck(folder / "BAH_Plane.bdf", log=lambda *_: None)
    (r,) = res.results
    theirs = [t for t in f06_flutter_points(read_flutter_summary(folder / "BAH_Plane.f06"))
              if not t.real_root]
    assert {(t.point, t.kind) for t in theirs} >= {(3, "hump"), (6, "hump"), (10, "hump"),
                                                   (9, "sustained")}
    for t in theirs:
        match = [p for p in r.points if p.kind == t.kind
                 and t.bracket[0] <= p.velocity <= t.bracket[1]
                 and (t.kind == "sustained" or
                      t.stable_bracket[0] <= p.stable_velocity <= t.stable_bracket[1])]
        assert match, (t.point, t.kind, t.bracket)
    # the 7.3 Hz hump is the 9.00 Hz mode's branch (by in-vacuo frequency, not index)
    hump_7hz = [p for p in r.points if res.frequencies_hz[p.mode] == pytest.approx(9.0022,
                                                                                   rel=1e-4)]
    assert len(hump_7hz) == 1 and hump_7hz[0].frequency_hz == pytest.approx(7.3, abs=0.05)
    assert all(p.refined for p in r.points)
    assert all(res.frequencies_hz[p.mode] > 0 for p in r.points)
    assert r.rigid_points and all(res.frequencies_hz[p.mode] == 0 for p in r.rigid_points)
    sw = r.sweep
    assert not any(_shared_roots(s, v) for s, v in zip(sw.eigenvalues, sw.vectors))
    # --compare: each of ours beside a crossing of Nastran's of the same kind, except the hump
    # that lies between the f06's speeds; the f06's second run of speeds is not listed twice
    _, records = compare_f06(res, folder / "BAH_Plane.f06")
    # each by the in-vacuo frequency (Hz) of its branch, not the branch's index
    paired = [(round(float(res.frequencies_hz[rec["mode"] - 1]), 2), rec["kind"],
               rec["nastran_kind"]) for rec in records if rec["velocity"] is not None]
    assert paired == [(3.75, "hump", "hump"), (14.51, "hump", None), (9.0, "hump", "hump"),
                      (3.75, "hump", "hump"), (32.09, "hump", "hump"),
                      (22.16, "sustained", "sustained")]
    theirs_only = [(rec["nastran_kind"], round(rec["nastran_velocity"]))
                   for rec in records if rec["velocity"] is None]
    assert len(theirs_only) == len(set(theirs_only))


def test_cbush_static_against_its_punch_file():
    """cbush (SOL 101): a CBUSH between two coincident grids, one clamped, 1000 along x on the
    other: its displacement equals MSC Nastran's (the run's punch file; the f06 prints the
    external work, 5.0000002E-04 = u F / 2, and the bush force 1000) to 1e-6 relative."""
    folder = DECKS / "pynastran_cbush"
    fe = read_bdf(folder / "cbush.dat")
    u = fe.expand(fe.linear_static(fe.load_vector(1)))
    lines = (folder / "cbush.pch").read_text().splitlines()
    ref = {}
    for a, b in zip(lines, lines[1:]):
        if a.split()[1:2] == ["G"]:
            ref[int(a.split()[0])] = [float(x) for x in a[23:72].split() + b[23:72].split()]
    assert sorted(ref) == [1, 2]
    for row, grid in enumerate((1, 2)):
        np.testing.assert_allclose(u[row], ref[grid], rtol=1e-6, atol=1e-18)
    work = 0.5 * 1000.0 * u[1, 0]
    assert work == pytest.approx(5.0000002e-04, rel=1e-6)


def test_random_nx_modes_in_the_eigrl_range():
    """random_test (NX Nastran 8.5, SOL 111): CBAR/PBAR (K1, K2), CBUSH with rotational
    stiffness between coincident grids, CQUAD4 plate, CBEAM/PBEAM. Its EIGRL asks for the modes
    in 20-2000 Hz, so the f06 lists those only: ours are compared in the same band (our
    12.69 Hz mode lies below it). The model is clamped (SPC1 123456): no rigid-body mode,
    although the CBUSH's 1e9 rotational stiffness makes the stiffness-to-mass scale (a mean of
    diagonals) 8.7e12 and the first two modes' ω² 7e-10 and 3e-9 of it (RIGID_BODY_TOL was
    1e-8 and counted them as rigid-body modes; it is 3e-11).

    Measured: 13 of 14 modes within 0.93 %; mode 14 (1881.2 Hz, in-plane) +1.89 %, asserted
    within 3 %; not isolated (the coarse 2×2 CQUAD4 plate, 1 × 1 elements, t = 0.05, takes part
    in all modes but the first: its E × 1000 moves modes 2-14 by 4-96 %). The deck's SPCD
    (enforced base motion of the random response) is noted: its load sets are left out of
    the static loads, the modes are those of the SPC set."""
    folder = DECKS / "pynastran_random_nx"
    ref = read_real_eigenvalues(folder / "random_test_nx.f06")[0].cycles
    fe = read_bdf(folder / "random_test.bdf")
    assert any(n.startswith("SPCD (3) accepted") for n in fe.notes)
    with pytest.raises(InputError, match="load set 20 not found"):
        fe.load_vector(20)  # SPCD 20: enforced motion, not a load torchrom applies
    modes = fe.modes(len(ref) + 2)
    assert len(modes.rigid_eigenvalues) == 0
    f = np.sqrt(modes.eigenvalues) / (2 * np.pi)
    assert f[0] == pytest.approx(12.69, abs=0.01)  # below EIGRL V1 = 20 Hz
    band = f[(f >= 20.0) & (f <= 2000.0)]
    assert len(band) >= len(ref)
    diff = 100 * (band[: len(ref)] - ref) / ref
    print("random_nx diff % by mode:", dict(enumerate(np.round(diff, 4).tolist(), start=1)))
    assert np.all(np.abs(diff[:13]) <= 1.0)
    assert abs(diff[13]) <= 3.0


def _f06_displacements(path: Path) -> dict[int, np.ndarray]:
    """T1-T3 of the first DISPLACEMENT VECTOR table of an f06 (in each grid's CD system)."""
    lines = path.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if "D I S P L A C E M E N T" in line)
    out = {}
    for line in lines[start + 1:]:
        p = line.split()
        if len(p) == 8 and p[1] == "G":
            out[int(p[0])] = np.array([float(x) for x in p[2:5]])
        elif out and line.startswith("1"):
            break
    return out


def test_solid_shell_bar_static_in_basic_and_cylindrical_cd():
    """The mode_solid_shell_bar model statically (NX Nastran 8.5, SOL 101: 10,000 along z at
    the top of the solids), twice: grids in basic, and every grid with CD = a CORD2C about z
    (its displacements printed in radial, tangential, axial components; grids 1, 7, 12, 14, 18,
    22 lie on the axis, where NX takes the system's x-axis, here basic y, as radial). Ours,
    each in its grid's CD system, are within 1.5 % of the largest displacement (measured
    1.27 % in both with the solids' incompatible modes, 1.47 % fully integrated; up to 3.4 %
    on the components of at least 20 % of the largest, in the solids: see SOURCE.md), and the
    two runs are the same displacement field (1e-12) with the on-axis convention."""
    from torchrom.fe.coords import axes_at

    folder = DECKS / "pynastran_solid_shell_bar_static"
    fields = []
    for name in ("static_solid_shell_bar", "static_solid_shell_bar_global_radial_cd"):
        fe = read_bdf(folder / f"{name}.bdf")
        u = fe.expand(fe.linear_static(fe.load_vector(123458)))
        ref = _f06_displacements(folder / f"{name}.f06")
        assert len(ref) == 25
        rows = list(fe.mesh.grid_ids)
        big = max(np.abs(r).max() for r in ref.values())
        worst = 0.0
        for g, r in ref.items():
            row = rows.index(g)
            node = fe.bdf.nodes[g]
            axes = axes_at(fe.bdf.coords[node.cd], fe.mesh.xyz[row]) if node.cd else np.eye(3)
            worst = max(worst, np.abs(axes.T @ u[row, :3] - r).max() / big)
        print(name, "max |diff| / max |u|:", round(100 * worst, 3), "%")
        assert worst <= 0.015
        fields.append(u)
    np.testing.assert_allclose(fields[1], fields[0], rtol=0, atol=1e-12 * np.abs(fields[0]).max())


PAZY = DECKS / "aepw3_pazy_noskin_rigidtip"


def _gpwg_mass(path) -> np.ndarray:
    """The 6 × 6 rigid-body mass matrix MO about the basic origin printed by the f06's GRID
    POINT WEIGHT GENERATOR (PARAM GRDPNT 0)."""
    lines = Path(path).read_text().splitlines()
    start = next(k for k, s in enumerate(lines) if s.strip() == "M O")
    rows = [s.strip().strip("*").split() for s in lines[start + 1 : start + 7]]
    return np.array(rows, dtype=float)


def test_pazy_modes_and_mass_match_nastran():
    """The Pazy wing (AePW-3 GFEM without skin, rigid tip rod: PBEAM neutral-axis offsets N1/N2,
    CQUAD4/CTRIA3 spar plate and ribs, RBE2 tip, PARAM AUTOSPC YES) against its MSC Nastran
    2017.1 SOL 103 f06. Mass: the 6 × 6 rigid-body mass about the origin equals the f06's grid
    point weight generator's to 1e-6 of each row's largest (measured: rounding, its 7 digits;
    the z centre of gravity, −3.0e-5 m, is the structural mass at the neutral axes). Modes, by
    number (measured, %): +0.004, +0.002, +0.073, +0.001, +0.029, −1.80, +0.001, −9.56, −0.91,
    −0.28: the first six (the issue's target) within 2 %, the others within 2 % but mode 8
    (a rib/spar torsion mode set by the CQUAD4 drilling stiffness at the T-joints between the
    ribs and the spar plate: −18 % without drilling stiffness, +27 % with 10× the default;
    modes 1-5 and 7 move ≤ 0.1 % over that range), asserted within 12 %."""
    from torchrom.fe.mass import rigid_links
    from torchrom.fe.model import assemble_mass

    fe = read_bdf(PAZY / "sol103_noskin_stiftip.dat")
    assert fe.autospc == []  # every DOF has stiffness: AUTOSPC removes nothing
    D = rigid_links(fe.grid_xyz).reshape(-1, 6)
    M0 = D.T @ (assemble_mass(fe.mesh) @ D)
    ref_m = _gpwg_mass(PAZY / "sol103_noskin_stiftip.f06")
    assert np.all(np.abs(M0 - ref_m) <= 1e-6 * np.abs(ref_m).max(axis=1, keepdims=True))
    ref = read_real_eigenvalues(PAZY / "sol103_noskin_stiftip.f06")[0].cycles
    modes = fe.modes(len(ref))
    assert modes.n_rigid == 0
    diff = 100 * (modes.frequencies_hz - ref) / ref
    print("pazy diff % by mode:", dict(zip(range(1, len(ref) + 1), np.round(diff, 3).tolist())))
    assert np.all(np.abs(diff[:6]) <= 2.0), diff
    assert np.all(np.abs(np.delete(diff, 7)) <= 2.0) and abs(diff[7]) <= 12.0, diff


# The static bending sweep of Riso & Cesnik (SciTech 2022): a tip mass at the tip mid-chord under
# gravity, the self-weight solution subtracted, the tip's vertical displacement in % of the
# semispan. The mass: a CONM2 on grid 61, the tip rod's mid-point at x = 0.05 m (the mid-chord
# of the 0.1 m chord, x = 0 .. 0.1), where the deck's own 0.01 kg CONM2 sits; the displacement:
# the rigid tip section (RBE2 7330, independent grid 2366 at x = 0.043589 m, y = 0.5519937 m)
# at its mid-chord x = 0.05 m, w = T3 − R2 (0.05 − 0.043589), over the Pazy wing's nominal
# semispan 0.55 m. (These choices were found by matching: the rod's grid 61 itself over its
# span station 0.5568 m gives +0.08 %, over 0.55 m +1.3 %; by reciprocity the mass on the tip
# section's mid-chord and grid 61's displacement give the same linear numbers.)
PAZY_TIP_DECK = """SOL {sol}
CEND
SPC = 2000
SUBCASE 1
  LOAD = 1
  NLPARM = 1
BEGIN BULK
PARAM,AUTOSPC,YES
SPCADD,2000,1
NLPARM,1,{ninc}
CONM2,9001,61,,{mass}
GRAV,1,,9.81,0.,0.,-1.
include 'fem_noskin_stiftip.bdf'
include 'tip_rbe2_noskin.bdf'
include 'bcs_noskin.bdf'
ENDDATA
"""
PAZY_SEMISPAN = 0.55
PAZY_TIP_ARM = 0.05 - 0.043589  # from grid 2366 to the mid-chord, along x


def _pazy_sweep_table(name: str) -> np.ndarray:
    return np.loadtxt(PAZY / name)


def pazy_tip_mass_run(tmp_path, mass: float, sol: int = 101, ninc: int = 10,
                      *options) -> tuple[list[dict], float]:
    """``torchrom static`` on the Pazy deck with a CONM2 of ``mass`` kg at grid 61 and GRAV:
    (the steps of its one subcase, wall seconds)."""
    import json
    import shutil
    import time

    from torchrom.cli import main

    for name in ("fem_noskin_stiftip.bdf", "tip_rbe2_noskin.bdf", "bcs_noskin.bdf"):
        if not (tmp_path / name).exists():
            shutil.copy(PAZY / name, tmp_path / name)
    deck = tmp_path / f"pazy_tip_{mass:g}_{sol}.dat"
    deck.write_text(PAZY_TIP_DECK.format(sol=sol, ninc=ninc, mass=mass))
    out = deck.with_suffix(".json")
    t0 = time.perf_counter()
    assert main(["static", str(deck), "--json", str(out), "--force", "--quiet", *options]) == 0
    seconds = time.perf_counter() - t0
    return json.loads(out.read_text())["subcases"][0]["steps"], seconds


def pazy_tip_percent(step: dict, weight: dict) -> float:
    """Tip mid-chord vertical displacement (% of the semispan) of a step, the self-weight
    step ``weight`` subtracted."""
    d = np.array(step["displacements"]["2366"]) - np.array(weight["displacements"]["2366"])
    return 100.0 * (d[2] - d[4] * PAZY_TIP_ARM) / PAZY_SEMISPAN


def test_pazy_linear_tip_mass_matches_sol101_sweep(tmp_path):
    """3.5 kg (the sweep's largest) and 0 kg (self-weight), linear, through ``torchrom static``:
    the tip displacement −78.580 % of the semispan against the SOL 101 table's −78.584 %
    (measured −5e-5 of its value; asserted 1e-3: the table's linear response is one number times
    the mass, so this point checks the whole linear sweep's slope)."""
    table = _pazy_sweep_table("sweep_static_bending_GFEM_linear_sweep_wo_skin.txt")
    weight, _ = pazy_tip_mass_run(tmp_path, 0.0)
    loaded, _ = pazy_tip_mass_run(tmp_path, 3.5)
    ours = pazy_tip_percent(loaded[-1], weight[-1])
    ref = table[table[:, 0] == 3.5, 1][0]
    print(f"pazy 3.5 kg linear: {ours:.4f} % vs SOL 101 {ref:.4f} % ({ours / ref - 1:+.2e})")
    assert ours == pytest.approx(ref, rel=1e-3)


@pytest.mark.slow
def test_pazy_linear_sweep_all_masses(tmp_path):
    """The whole SOL 101 sweep, 15 tip masses 0 .. 3.5 kg, each its own deck through
    ``torchrom static`` (1e-3 of each value); prints the time of the sweep."""
    table = _pazy_sweep_table("sweep_static_bending_GFEM_linear_sweep_wo_skin.txt")
    weight, total = pazy_tip_mass_run(tmp_path, 0.0)
    worst = 0.0
    for mass, ref in table[1:]:
        steps, seconds = pazy_tip_mass_run(tmp_path, float(mass))
        total += seconds
        ours = pazy_tip_percent(steps[-1], weight[-1])
        worst = max(worst, abs(ours / ref - 1))
        assert ours == pytest.approx(ref, rel=1e-3), mass
    print(f"pazy linear sweep: 15 decks in {total:.1f} s; largest relative difference "
          f"{worst:.2e}")


@pytest.mark.slow
def test_pazy_nonlinear_tip_mass_runs(tmp_path):
    """SOL 400 decks (NLPARM NINC 5) of 0 and 3.5 kg through ``torchrom static``: every load
    step converges, and the 3.5 kg tip displacement (self-weight subtracted) is SOL 400's within
    0.5 % of the semispan — the same tolerance as tests/test_pazy.py's sweep, here through the
    command and its full Newton from zero load (before the co-rotational elements and the
    turned RBE2 arms it was −7.29 % against SOL 400's −51.32 %)."""
    table = _pazy_sweep_table("sweep_static_bending_GFEM_sweep_wo_skin.txt")
    weight, t0 = pazy_tip_mass_run(tmp_path, 0.0, 400, 5)
    loaded, t1 = pazy_tip_mass_run(tmp_path, 3.5, 400, 5)
    assert all(s["converged"] for s in weight + loaded) and loaded[-1]["load_factor"] == 1.0
    ours = pazy_tip_percent(loaded[-1], weight[-1])
    ref = table[table[:, 0] == 3.5, 1][0]
    print(f"pazy 3.5 kg nonlinear: {ours:.3f} % vs SOL 400 {ref:.3f} %; {t0:.0f} s + {t1:.0f} s")
    assert abs(ours - ref) <= 0.5
