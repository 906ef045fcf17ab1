"""The flutter mode (torchrom.aero.flutter_mode) of Hodges & Pierce's typical section
(tests/aeroelastic_fixtures.py, exact Theodorsen GAFs): the eigenpair at the p-k flutter point
solves the p-k equation (residual at rounding), is an eigenpair of the same matrices by a second
method (scipy's generalised eigen-solver on the first-order pencil, not the p-k's M⁻¹ form), and
its root is the flutter point's: zero damping and the crossing's frequency."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from torchrom.aero.flutter import AeroTable, ModalStructure
from torchrom.aero.flutter_mode import pk_flutter_mode, pk_matrices
from torchrom.aero.flutter_speed import flutter_speed_pk_at_density

from .aeroelastic_fixtures import section_aero, section_rom


@pytest.fixture(scope="module")
def flutter_point():
    rom = section_rom()
    aero = section_aero(rom)
    st = ModalStructure.from_rom(rom, 2)
    table = AeroTable.from_gaf(aero.gaf)
    res, sweep = flutter_speed_pk_at_density(st, table, 0.0017, aero.mach)
    assert res.velocity is not None
    return st, table, res, sweep


def test_flutter_mode_solves_the_pk_equation(flutter_point):
    st, table, res, sweep = flutter_point
    fm = pk_flutter_mode(st, table, res.velocity, res.density, sweep, res.mode)
    # p-k residual relative to the size of its terms: rounding (measured ~1e-16)
    assert fm.residual < 1e-12
    # second method: the first-order pencil A x = s B x at the same k, scipy's QZ
    M, C, K = pk_matrices(st, table, fm.velocity, fm.density, fm.k)
    m = M.shape[0]
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-K, -C]])
    B = np.block([[np.eye(m), np.zeros((m, m))], [np.zeros((m, m)), M]])
    s, X = scipy.linalg.eig(A, B)
    i = int(np.argmin(np.abs(s - fm.eigenvalue)))
    assert abs(s[i] - fm.eigenvalue) <= 1e-10 * abs(fm.eigenvalue)
    x = X[:m, i]
    mac = abs(np.vdot(x, fm.vector)) ** 2 / (np.vdot(x, x).real * np.vdot(fm.vector,
                                                                           fm.vector).real)
    assert mac > 1 - 1e-10
    # normalised: the largest coordinate is 1 + 0i
    assert fm.vector[np.argmax(np.abs(fm.vector))] == pytest.approx(1.0, abs=1e-14)


def test_the_root_is_the_flutter_points(flutter_point):
    """The crossing is refined between the sweep's speeds by a root solve, so the root there
    has g = 0 to that solve's tolerance: |g| < 1e-6 (measured -1.1e-9) and the crossing's
    frequency within 1e-6 (measured 2e-9 relative); k = ω b / V."""
    st, table, res, sweep = flutter_point
    fm = pk_flutter_mode(st, table, res.velocity, res.density, sweep, res.mode)
    print("flutter mode g, f, crossing f:", fm.damping_g, fm.frequency_hz, res.frequency_hz)
    assert abs(fm.damping_g) < 1e-6
    assert fm.frequency_hz == pytest.approx(res.frequency_hz, rel=1e-6)
    assert fm.k == pytest.approx(2 * np.pi * fm.frequency_hz * table.semichord / fm.velocity,
                                 rel=1e-9)
