"""Linear solids CHEXA/CPENTA/CTETRA against closed forms: patch test, rigid modes, mass, and
the axial modes of a clamped bar."""

from __future__ import annotations

import numpy as np
import pytest

from torchrom.errors import InputError
from torchrom.fe.elements.solid import elasticity, solid_mass, solid_stiffness

from .fe_decks import model_of, new_deck

HEX = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
# distorted shapes (still convex), one per family
SHAPES = {
    8: HEX + 0.1 * np.array([[0, 0, 0], [0.2, 0.1, 0], [0.3, -0.2, 0.1], [0, 0.1, 0],
                             [0.1, 0, 0.2], [0, 0.2, 0], [0.2, 0, -0.1], [-0.1, 0, 0]]),
    6: np.array([[0, 0, 0], [1.2, 0.1, 0], [0.3, 0.9, 0], [0.1, 0, 1.1], [1.1, 0.2, 1.0],
                 [0.3, 1.0, 1.2]], float),
    4: np.array([[0, 0, 0], [1.1, 0.2, 0], [0.2, 0.9, 0.1], [0.3, 0.2, 1.0]], float),
}
# quadratic tetrahedron: the corners of the linear one, the edge grids at the mid-points in
# Nastran's order (1-2, 2-3, 3-1, 1-4, 2-4, 3-4)
_EDGES = ((0, 1), (1, 2), (2, 0), (0, 3), (1, 3), (2, 3))
SHAPES[10] = np.vstack([SHAPES[4]] + [(SHAPES[4][i] + SHAPES[4][j]) / 2 for i, j in _EDGES])


@pytest.mark.parametrize("nn", [8, 6, 4, 10])
def test_patch_test_rigid_modes_and_mass(nn):
    """A linear displacement field u = A x has constant strain: the element's strain energy is
    exactly ½ εᵀ D ε V; six rigid modes; the mass sums to ρ V (lumped and consistent)."""
    X = SHAPES[nn][None]
    E, nu, rho = np.array([7e10]), np.array([0.3]), np.array([2700.0])
    K = solid_stiffness(X, E, nu)[0]
    A = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.2, 0.6, 0.7]]) * 1e-3
    u = (X[0] @ A.T).reshape(-1)
    eps = np.array([A[0, 0], A[1, 1], A[2, 2], A[0, 1] + A[1, 0], A[1, 2] + A[2, 1],
                    A[2, 0] + A[0, 2]])
    M = solid_mass(X, rho, coupled=True)[0]
    V = M[0::3, 0::3].sum() / rho[0]
    assert 0.5 * u @ K @ u == pytest.approx(0.5 * eps @ elasticity(E, nu)[0] @ eps * V,
                                            rel=1e-12)
    lam = np.linalg.eigvalsh(K)
    assert np.all(np.abs(lam[:6]) <= 1e-10 * lam[-1]) and lam[6] > 1e-6 * lam[-1]
    Ml = solid_mass(X, rho, coupled=False)[0]
    assert np.trace(Ml) / 3 == pytest.approx(rho[0] * V, rel=1e-12)
    if nn in (4, 10):  # tetrahedron volume by the triple product
        a, b, c = X[0, 1:4] - X[0, 0]
        assert V == pytest.approx(abs(np.dot(a, np.cross(b, c))) / 6, rel=1e-12)


def _bar(kind: str, n: int = 20, L: float = 1.0, h: float = 0.1):
    """Bar along x of n cells (h x h section), ν = 0, clamped at x = 0: hexa, or each cell as two
    pentas, or as six tetras."""
    m = new_deck()
    nid = {}
    for i in range(n + 1):
        for j, (y, z) in enumerate(((0, 0), (h, 0), (h, h), (0, h))):
            nid[i, j] = 1 + 4 * i + j
            m.add_grid(nid[i, j], [L * i / n, y, z], ps="123456" if i == 0 else "456")
    m.add_mat1(1, 2.0e11, None, 0.0, rho=7800.0)
    m.add_psolid(1, 1)
    eid = 1
    for i in range(n):
        a = [nid[i, j] for j in range(4)]
        b = [nid[i + 1, j] for j in range(4)]
        if kind == "CHEXA":
            m.add_chexa(eid, 1, a + b)
            eid += 1
        elif kind == "CPENTA":
            m.add_cpenta(eid, 1, [a[0], a[1], a[2], b[0], b[1], b[2]])
            m.add_cpenta(eid + 1, 1, [a[0], a[2], a[3], b[0], b[2], b[3]])
            eid += 2
        else:
            c = a + b  # cube split into 6 tetrahedra around the diagonal 0-6
            for t in ((0, 1, 2, 6), (0, 2, 3, 6), (0, 3, 7, 6), (0, 7, 4, 6), (0, 4, 5, 6),
                      (0, 5, 1, 6)):
                m.add_ctetra(eid, 1, [c[k] for k in t])
                eid += 1
    return model_of(m)


@pytest.mark.parametrize("kind", ["CHEXA", "CPENTA", "CTETRA"])
def test_clamped_bar_axial_mode(kind):
    """First axial mode of a clamped-free bar, f = √(E/ρ) / (4L) (ν = 0: uniaxial): 20 cells with
    lumped mass within 0.5 % (observed −0.026 % for all three families)."""
    fe = _bar(kind)
    modes = fe.modes(12)
    axial = [f for f, k in zip(modes.frequencies_hz, modes.kinds) if k == "axial"]
    exact = np.sqrt(2.0e11 / 7800.0) / 4.0
    print(kind, axial[0] / exact - 1)
    assert axial[0] == pytest.approx(exact, rel=5e-3)


def test_quadratic_tetra_mass_closed_form():
    """Straight-edged 10-grid tetrahedron: consistent mass ρV/420 × (6 on a corner, 1 between
    corners, −4 between a corner and an edge through it, −6 otherwise, 32 on an edge, 16 between
    edges sharing a face, 8 between opposite edges) — Zienkiewicz & Taylor Vol. 1; lumped: the
    diagonal scaled to ρV (HRZ), corners 1/36 and edges 4/27 of ρV."""
    X = SHAPES[10][None]
    rho = np.array([2.0])
    M = solid_mass(X, rho, coupled=True)[0][0::3, 0::3]
    a, b, c = SHAPES[4][1:] - SHAPES[4][0]
    m = rho[0] * abs(np.dot(a, np.cross(b, c))) / 6 / 420
    assert M[0, 0] == pytest.approx(6 * m, rel=1e-12) and M[0, 1] == pytest.approx(m, rel=1e-12)
    assert M[0, 4] == pytest.approx(-4 * m, rel=1e-12)  # corner 1, edge 1-2
    assert M[0, 5] == pytest.approx(-6 * m, rel=1e-12)  # corner 1, edge 2-3
    assert M[4, 4] == pytest.approx(32 * m, rel=1e-12) and M[4, 5] == pytest.approx(16 * m)
    assert M[4, 9] == pytest.approx(8 * m, rel=1e-12)  # edges 1-2 and 3-4 (opposite)
    Ml = np.diag(solid_mass(X, rho, coupled=False)[0])[0::3] / (420 * m)
    assert Ml == pytest.approx([1 / 36] * 4 + [4 / 27] * 6, rel=1e-12)


def test_partly_quadratic_solids_are_refused():
    m = new_deck()
    for k in range(9):
        m.add_grid(k + 1, [k % 2, (k // 2) % 2, k // 4 * 0.5])
    m.add_mat1(1, 2.0e11, None, 0.3, rho=7800.0)
    m.add_psolid(1, 1)
    m.add_ctetra(1, 1, list(range(1, 10)))
    with pytest.raises(InputError, match="CTETRA 1: 9 grids: only 4 or 10 grids are supported"):
        model_of(m)
