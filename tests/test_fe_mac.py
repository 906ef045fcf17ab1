"""MAC and target pairing (torchrom.fe.mac)."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.fe.mac import mac_matrix, pair_by_kind, pair_by_mac


def test_mac_of_mass_orthonormal_modes_is_identity():
    """Mass-normalised eigenvectors of a random symmetric pencil: MAC = I exactly (to rounding)
    with the mass weighting, and invariant to scaling and sign of the shapes."""
    rng = np.random.default_rng(1)
    A = rng.standard_normal((6, 6))
    K = A @ A.T + 6 * np.eye(6)
    B = rng.standard_normal((6, 6))
    M = B @ B.T + 6 * np.eye(6)
    import scipy.linalg as la

    _, V = la.eigh(K, M)
    np.testing.assert_allclose(mac_matrix(V, -3.0 * V, M), np.eye(6), atol=1e-12)
    assert mac_matrix(V[:, :1], V[:, :1])[0, 0] == pytest.approx(1.0)


def test_pair_by_mac_is_one_to_one():
    """Greedy row-wise argmax would give column 0 twice; the assignment maximises the sum."""
    mac = np.array([[0.9, 0.8, 0.0], [0.85, 0.1, 0.0]])
    assert list(pair_by_mac(mac)) == [1, 0]


def test_pair_by_kind():
    kinds = ["bending", "torsion", "bending", "in-plane", "torsion"]
    assert list(pair_by_kind(kinds, ["bending", "torsion", "transverse", "in-plane", "any"])) \
        == [0, 1, 2, 3, 4]
    assert list(pair_by_kind(kinds, ["in-plane", "torsion", "torsion"])) == [3, 1, 4]
    assert list(pair_by_kind(kinds, ["any", "bending"], fixed=[2, None])) == [2, 0]
    with pytest.raises(InputError, match="target 2: no axial mode"):
        pair_by_kind(kinds, ["bending", "axial"])
    assert list(pair_by_kind(kinds, ["bending", "axial"], strict=False)) == [0, 1]
