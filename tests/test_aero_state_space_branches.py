"""torchrom.aero.state_space_branches: the state-space roots ordered by physics, not by the
eigensolver (whose order changes between BLAS kernels).

Case: the Hodges & Pierce typical section of tests/test_aero_flutter.py (2 modes, 8-lag RFA,
Mach 0.5, ft-slug-s) at one density, speeds up to past its flutter speed.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from torchrom.aero.flutter_speed import flutter_speed_at_density
from torchrom.aero.rfa import fit_minimum_state
from torchrom.aero.state_space_branches import state_space_branches

from .test_aero_flutter import _altitude_case

RHO = 0.002  # slug/ft^3


@pytest.fixture(scope="module")
def case():
    from torchrom.aero.flutter import AeroTable, ModalStructure

    _, st, gaf, mach = _altitude_case()
    rfa = fit_minimum_state(gaf, n_lags=8)
    st = ModalStructure(st.M, st.K, alpha=0.5, gamma=1e-4)  # damped: C = α M + γ K
    return st, rfa, AeroTable.from_gaf(gaf), mach


def test_each_branch_root_solves_the_flutter_equation(case):
    """Independent check of every entry: s is a root of the p-method equation the state space
    stands for, det(M s² + C s + K + q Q̃(s b / V)) = 0 with the RFA's Q̃ at the complex
    p = s b / V (rfa.evaluate_p), and q (the branch's shape) its null vector:
    |A(s) q| <= 1e-9 |A| |q| (the eigensolver's rounding; 1e-16 measured with the shape
    normalised). The damping and reduced frequency are Nastran's g = 2 Re s / |Im s| and
    k = |Im s| b / V."""
    st, rfa, _, _ = case
    v = np.linspace(50.0, 700.0, 27)
    sw = state_space_branches(st, rfa, v, RHO)
    assert sw.eigenvalues.shape == (27, 2) and sw.method == "state-space"
    for i, V in enumerate(v):
        q_inf = 0.5 * RHO * V**2
        for j in range(2):
            s, q = sw.eigenvalues[i, j], sw.vectors[i, :, j]
            a = (st.M * s**2 + st.C * s + st.K
                 + q_inf * rfa.evaluate_p([s * rfa.semichord / V])[0])
            assert np.linalg.norm(a @ q) <= 1e-9 * np.linalg.norm(a) * np.linalg.norm(q)
            if s.imag > 0:
                assert sw.damping[i, j] == pytest.approx(2 * s.real / s.imag, rel=1e-12)
                assert sw.k[i, j] == pytest.approx(s.imag * rfa.semichord / V, rel=1e-12)


def test_branches_start_from_the_in_vacuo_modes_and_find_the_flutter_speed(case):
    """At a low speed (10 ft/s) branch j is mode j of the structure with its added air mass
    (ascending frequency): the closed form of the V -> 0 limit, the modes of (K, M + ½ ρ b² A2)
    (the state space's M̄ = M + q (b/V)² A2 keeps ½ ρ b² A2 at any speed), within 0.2 %
    (0.06 % measured; 2.8 % from the in-vacuo modes); the branch that goes unstable is the
    one whose damping crosses zero between the two speeds that bracket the state-space
    flutter speed solved by Brent's method
    (:func:`torchrom.aero.flutter_speed.flutter_speed_at_density`), at its frequency (within
    2 %: speeds 3 % apart)."""
    st, rfa, table, mach = case
    ref = flutter_speed_at_density(st, rfa, table, RHO, mach=mach)
    assert ref.velocity is not None
    v = np.geomspace(10.0, 1.5 * ref.velocity, 90)
    sw = state_space_branches(st, rfa, v, RHO)
    b = rfa.semichord
    w2 = scipy.linalg.eigh(st.K, st.M + 0.5 * RHO * b**2 * rfa.A2, eigvals_only=True)
    np.testing.assert_allclose(sw.frequency_hz[0], np.sqrt(w2) / (2 * np.pi), rtol=2e-3)
    g = sw.damping
    up = [(i, j) for j in range(2) for i in range(len(v) - 1)
          if g[i, j] < -1e-3 and g[i + 1, j] > 1e-3]
    (i, j), *_ = sorted(up)
    assert v[i] <= ref.velocity <= v[i + 1]
    assert sw.frequency_hz[i + 1, j] == pytest.approx(ref.frequency_hz, rel=0.02)


def test_labels_do_not_depend_on_the_order_of_the_coordinates(case):
    """Metamorphic: the same section with its coordinates swapped ([α, h] for [h, α]; M, K,
    C, and the RFA's A0, A1, A2, D, E permuted) gives the same branches: branch j is the root
    that continues in-vacuo mode j, whatever the order of the matrices, so no index depends on
    an eigensolver's (or a BLAS kernel's) ordering. Eigenvalues equal within 1e-9 relative
    (rounding of the permuted sums)."""
    from dataclasses import replace

    from torchrom.aero.flutter import ModalStructure

    st, rfa, _, _ = case
    p = np.array([[0.0, 1.0], [1.0, 0.0]])
    swapped = ModalStructure(p @ st.M @ p.T, p @ st.K @ p.T, alpha=st.alpha, gamma=st.gamma)
    rfa_swapped = replace(rfa, A0=p @ rfa.A0 @ p.T, A1=p @ rfa.A1 @ p.T, A2=p @ rfa.A2 @ p.T,
                          D=p @ rfa.D, E=rfa.E @ p.T)
    v = np.linspace(50.0, 700.0, 27)
    a = state_space_branches(st, rfa, v, RHO).eigenvalues
    b = state_space_branches(swapped, rfa_swapped, v, RHO).eigenvalues
    np.testing.assert_allclose(b, a, rtol=1e-9, atol=1e-9 * np.abs(a).max())
