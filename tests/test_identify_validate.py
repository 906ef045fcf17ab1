"""Validation machinery (static Newton, free decay, metrics) on a model whose ROM is exact:
REFERENCE Sec. 5 as callables with the identity basis, so ROM and "FE" must agree to rounding."""

import numpy as np
import pytest

from torchrom.identify import validate as v
from torchrom.identify.build import IdentifyOptions, identify

from .identify_fixtures import touze_backend


@pytest.fixture(scope="module")
def exact_pair():
    be = touze_backend()
    be._outputs = {"A_Tx": 1, "A_Ty": 1, "A_Tz": 0}
    be._transverse_dofs = np.array([0])
    be._load_shapes = {"uniform": np.array([1.0, 0.5]), "step": np.array([1.0, -1.0])}
    res = identify(be, IdentifyOptions(n_linear=2, n_dual=0, damping="exact"))
    return be, res


def test_static_validation_of_an_exact_rom(exact_pair):
    be, res = exact_pair
    for shape, load in be.load_shapes().items():
        c = v.static_validation(be, res.rom, res.basis.Phi, shape, load, max_tip_fraction=0.25)
        assert c.tip_pct_span.max() >= 25.0 * (1 - 5e-3)  # levels stop within 0.5 %
        # same equations solved twice by Newton to 1e-10: agreement ~1e-9 relative
        assert max(c.errors.values()) < 1e-8, c.errors


def test_static_validation_refuses_in_one_line_when_no_fe_solve_converges(exact_pair,
                                                                           monkeypatch):
    """A deck whose first static solve fails (the wingbox before its up axis was found: the
    report's traceback "zero-size array to reduction operation maximum") gets a one-line
    ConvergenceError (exit 2), the ROM already written."""
    from torchrom.errors import ConvergenceError

    be, res = exact_pair

    def fail(*_a, **_k):
        raise ConvergenceError("Newton did not converge")

    monkeypatch.setattr(be, "static_solve", fail)
    with pytest.raises(ConvergenceError, match="uniform load: the FE's static solve failed at "
                                               "the first level") as exc:
        v.static_validation(be, res.rom, res.basis.Phi, "uniform", be.load_shapes()["uniform"])
    assert "\n" not in str(exc.value)


def test_free_decay_of_an_exact_rom(exact_pair):
    be, res = exact_pair
    dec = v.free_decay_validation(be, res.rom, res.basis.Phi, be.load_shapes()["uniform"],
                                  tip_fraction=0.2, gamma=0.02, cycles=4, dt=0.1)
    # identical equations and integrator: differences are Newton tolerances
    assert np.abs(dec.rom - dec.fe).max() < 1e-7 * np.abs(dec.fe).max()
    assert dec.metrics["envelope_error"] < 1e-6 and dec.metrics["frequency_error"] < 1e-6
    assert dec.metrics["extrema"] == 8


def test_compare_decay_on_known_signals():
    t = np.linspace(0, 10, 20001)
    fe = 2.0 * np.exp(-0.05 * t) * np.cos(2 * np.pi * 1.0 * t)
    rom = 2.0 * 1.02 * np.exp(-0.05 * t) * np.cos(2 * np.pi * 1.005 * t)
    m = v.compare_decay(t, fe, rom, cycles=5)
    assert m["frequency_fe_hz"] == pytest.approx(1.0, rel=1e-4)
    assert m["frequency_error"] == pytest.approx(0.005, rel=2e-2)
    assert m["envelope_error"] == pytest.approx(0.02, abs=5e-3)


def test_compare_damping_identical_is_zero(exact_pair):
    _, res = exact_pair
    Q = np.random.default_rng(0).normal(size=(50, 2))
    out = v.compare_damping(res.rom, res.rom, Q, Q[::-1])
    assert out["D3_rel_diff"] == 0.0 and out["power_max_rel_diff"] == 0.0


#: tests/test_bad_input.py's 3-bar beam set free (its SPC removed) with rotary inertia on the
#: tip CONM2, so that each of its six rigid-body motions carries mass (inertia relief needs it)
def _free_beam_deck() -> str:
    from .test_bad_input import DECK

    return (DECK.replace("SPC1    1       123456  1\n", "").replace("SPC = 1\n", "")
            .replace("CONM2   10      4               1.0\n",
                     "CONM2   10      4               1.0\n"
                     "        0.01            0.01                    0.01\n"))


@pytest.fixture(scope="module")
def free_beam(tmp_path_factory):
    """The free beam (small rotations: a linear FE, so the ROM of its 8 lowest modes, 6 rigid
    and 2 elastic, is exact for loads in their span) and its linear ROM."""
    from torchrom.fe import read_bdf
    from torchrom.identify.build import as_backend

    path = tmp_path_factory.mktemp("free") / "free_beam.bdf"
    path.write_text(_free_beam_deck())
    be = as_backend(read_bdf(path, rotations="small"))
    res = identify(be, IdentifyOptions(n_linear=8, n_dual=0))
    return be, res


def test_free_structure_static_validation_under_inertia_relief(free_beam):
    """identify --report on a free structure (issue 35): the FE and the ROM under inertia
    relief. Independent reference: the inertia load M φ₁ of the first elastic mode (the load
    of a deck without a pressure skin) has the closed-form INREL response φ₁/ω₁² (φ₁ is
    M-orthogonal to the rigid-body modes, so no part of the load is relieved): the FE's
    bordered solve gives it to 1e-9, with Gᵀ M u = 0 (1e-12 of |M u|). The ROM's projected
    INREL solve keeps its rigid-body coordinates at 0 (1e-12) and its static curve agrees
    with the FE's at every level (a linear FE and an exact ROM: 1e-8, Newton's tolerances)."""
    be, res = free_beam
    r = res.basis.n_rigid
    Phi = res.basis.Phi
    assert r == 6
    shapes = v.load_shapes(be, Phi, r)
    assert list(shapes) == ["mode1_inertia"]  # no pressure skin on a beam
    load = shapes["mode1_inertia"]
    w1 = 2 * np.pi * res.rom.frequencies_hz[r]
    u = v.linear_response(be, load)
    assert np.abs(u - Phi[:, r] / w1**2).max() <= 1e-9 * np.abs(Phi[:, r]).max() / w1**2
    M = be.mass_matrix()
    G = be.rigid_shapes()
    assert np.abs(G.T @ (M @ u)).max() <= 1e-12 * np.abs(M @ u).max()
    q = v.rom_static_solve(res.rom, Phi.T @ load, n_rigid=r)
    assert np.abs(q[:r]).max() <= 1e-12 * np.abs(q).max()
    assert q[r] == pytest.approx(1 / w1**2, rel=1e-9)
    outputs = v.validation_outputs(be, Phi, r)
    (name,) = outputs
    assert name.startswith("max_mode1 G")  # the deck names no point A
    c = v.static_validation(be, res.rom, Phi, "mode1_inertia", load, outputs=outputs,
                            n_rigid=r)
    assert c.tip_pct_span.max() >= 25.0 * (1 - 5e-3)
    assert max(c.errors.values()) < 1e-8, c.errors


def test_free_structure_report(free_beam, tmp_path):
    """write_report (``identify --report``) on the free beam: the static curve under inertia
    relief (an exact ROM: 1e-8) and a free decay released from it (the rigid-body modes at
    0 Hz left out of the period): the FE's frequency is the first elastic mode's damped one,
    f₁ √(1 − ζ²) with ζ = γ ω₁ / 2 for Kelvin–Voigt damping γ K (1e-3: Newmark's period error
    at 200 steps per period is 1e-4, the extrema's timing over 2 cycles the rest); ROM and FE
    agree to 1e-6 (the same Newmark scheme on the same linear equations); the report says so."""
    from torchrom.identify.report import write_report

    be, res = free_beam
    nums = write_report(res, be, tmp_path / "report", cycles=2)
    key = next(k for k in nums if k.startswith("static_mode1_inertia_max_mode1")
               and k.endswith("max_rel_error"))
    assert nums[key] < 1e-8
    f1 = res.rom.frequencies_hz[res.basis.n_rigid]
    zeta = 1e-3 * 2 * np.pi * f1 / 2  # write_report's default gamma = 1e-3 s
    assert nums["decay_frequency_fe_hz"] == pytest.approx(f1 * np.sqrt(1 - zeta**2), rel=1e-3)
    assert nums["decay_envelope_error"] < 1e-6 and nums["decay_frequency_error"] < 1e-6
    text = (tmp_path / "report" / "report.md").read_text()
    assert "inertia relief" in text and "inertia load M φ₁" in text
