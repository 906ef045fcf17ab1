"""Solids CHEXA/CPENTA/CTETRA (linear and quadratic) against closed forms: patch tests, rigid
modes, mass, the axial modes of a clamped bar, the bending mode of a cantilever block against
Timoshenko's beam; the 8- and 6-grid elements' incompatible modes against pure bending (exact)
and the Timoshenko beam, and their patch test (Taylor's form passes, Wilson's fails)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla
from scipy.optimize import brentq

from torchrom.errors import InputError
from torchrom.fe.elements.solid import (
    _HEX20_EDGES,
    _PENTA15_EDGES,
    RULES,
    elasticity,
    solid_mass,
    solid_stiffness,
)

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
# quadratic hexahedron and wedge: the distorted corners, the edge grids off the mid-points (curved
# edges) in Nastran's order
_BOW = np.array([[0.03, -0.02, 0.04], [-0.04, 0.03, 0.02], [0.02, 0.04, -0.03]])
SHAPES[20] = np.vstack([SHAPES[8]] + [(SHAPES[8][i] + SHAPES[8][j]) / 2 + _BOW[k % 3]
                                      for k, (i, j) in enumerate(_HEX20_EDGES)])
SHAPES[15] = np.vstack([SHAPES[6]] + [(SHAPES[6][i] + SHAPES[6][j]) / 2 + _BOW[k % 3]
                                      for k, (i, j) in enumerate(_PENTA15_EDGES)])


@pytest.mark.parametrize("nn", [20, 15])
def test_quadratic_shape_functions(nn):
    """Each N_a is 1 at its own grid and 0 at the others (grids in Nastran's order, natural
    coordinates), the N_a sum to 1, and the analytic derivatives match central differences
    (step 1e-5: truncation ~1e-10 on these quadratics-to-cubics, tolerance 1e-8)."""
    shape = RULES[nn][0]
    if nn == 20:
        corners = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                            [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)
        edges = _HEX20_EDGES
    else:
        corners = np.array([[0, 0, -1], [1, 0, -1], [0, 1, -1], [0, 0, 1], [1, 0, 1],
                            [0, 1, 1]], float)
        edges = _PENTA15_EDGES
    nodes = np.vstack([corners] + [(corners[i] + corners[j]) / 2 for i, j in edges])
    assert np.array([shape(x)[0] for x in nodes]) == pytest.approx(np.eye(nn), abs=1e-14)
    p, h = np.array([0.21, 0.33, -0.47]), 1e-5
    N, d = shape(p)
    assert N.sum() == pytest.approx(1.0, abs=1e-14)
    for k in range(3):
        e = h * np.eye(3)[k]
        fd = (shape(p + e)[0] - shape(p - e)[0]) / (2 * h)
        assert d[k] == pytest.approx(fd, abs=1e-8)


@pytest.mark.parametrize("nn", [8, 6, 4, 10, 20, 15])
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
    if nn in (20, 15):  # HRZ lumping: positive diagonal, the element's mass ρV
        assert np.all(np.diag(Ml) > 0)
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
    fe.set_wing_axes(up="z")  # a square bar has no up direction of its own: say one
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
    with pytest.raises(InputError, match="CTETRA 1: field G10: edge grid blank while other edge"):
        model_of(m)


def _reference_nodes(nn: int) -> tuple[np.ndarray, float]:
    """Natural-coordinate grids of the quadratic hexahedron or wedge and the reference volume."""
    if nn == 20:
        c = np.array([[-1, -1, -1], [1, -1, -1], [1, 1, -1], [-1, 1, -1],
                      [-1, -1, 1], [1, -1, 1], [1, 1, 1], [-1, 1, 1]], float)
        return np.vstack([c] + [(c[i] + c[j]) / 2 for i, j in _HEX20_EDGES]), 8.0
    c = np.array([[0, 0, -1], [1, 0, -1], [0, 1, -1], [0, 0, 1], [1, 0, 1], [0, 1, 1]], float)
    return np.vstack([c] + [(c[i] + c[j]) / 2 for i, j in _PENTA15_EDGES]), 1.0


@pytest.mark.parametrize("nn", [20, 15])
def test_quadratic_mass_is_rho_volume(nn):
    """An affine image x = A ξ + b of the reference hexahedron (volume 8) or wedge (volume 1)
    has the volume |det A| × that: the consistent and the lumped (HRZ) mass both total ρ V
    (rounding only, 1e-12)."""
    ref, v_ref = _reference_nodes(nn)
    A = np.array([[0.9, 0.2, -0.1], [0.1, 1.3, 0.3], [-0.2, 0.1, 0.7]])
    X = (ref @ A.T + [1.0, -2.0, 0.5])[None]
    rho = np.array([2700.0])
    V = abs(np.linalg.det(A)) * v_ref
    for coupled in (True, False):
        M = solid_mass(X, rho, coupled)[0]
        assert M[0::3, 0::3].sum() == pytest.approx(rho[0] * V, rel=1e-12)
        assert M[1::3, 1::3].sum() == pytest.approx(rho[0] * V, rel=1e-12)


def _lattice(n: int = 2, seed: int = 3) -> np.ndarray:
    """(2n+1)³ grid points of an n×n×n block of unit cells, all moved at random by up to 0.06 of
    a cell (so the elements are distorted, with curved edges)."""
    m = 2 * n + 1
    ijk = np.stack(np.meshgrid(*(np.arange(m),) * 3, indexing="ij"), -1).reshape(-1, 3)
    rng = np.random.default_rng(seed)
    return ijk / 2.0 + rng.uniform(-0.06, 0.06, (len(ijk), 3)), ijk


def _patch_connectivity(nn: int, n: int = 2) -> list[list[int]]:
    """Elements of the n×n×n block on the lattice of :func:`_lattice`: 20-grid hexahedra, or
    each cell as two 15-grid wedges (split along its x-y diagonal)."""
    m = 2 * n + 1
    ref, _ = _reference_nodes(nn)
    out = []
    for cell in np.ndindex(n, n, n):
        base = 2 * np.array(cell)
        if nn == 20:
            maps = [lambda p: p + 1]
        else:  # wedge natural (r, s, ζ) onto two halves of the cell (natural −1..1)
            maps = [lambda p: np.stack((2 * p[:, 0] + 2 * p[:, 1], 2 * p[:, 1], p[:, 2] + 1), 1),
                    lambda p: np.stack((2 * p[:, 0], 2 * p[:, 0] + 2 * p[:, 1], p[:, 2] + 1), 1)]
        for f in maps:
            loc = np.rint(f(ref)).astype(int) + base
            out.append(list(loc[:, 0] * m * m + loc[:, 1] * m + loc[:, 2]))
    return out


@pytest.mark.parametrize("nn", [20, 15])
def test_quadratic_patch_test(nn):
    """Patch test (Irons): a 2×2×2 block of distorted 20-grid hexahedra (or 16 wedges of 15
    grids) with the boundary grids moved by a linear field u = A x + c; the stiffness equations
    give the interior grids exactly that field (1e-10 relative to the field's size: the
    isoparametric elements reproduce linear fields, and the rules integrate the constant-strain
    energy exactly)."""
    X, ijk = _lattice()
    elems = np.array(_patch_connectivity(nn))
    used = np.unique(elems)
    K = np.zeros((3 * len(X),) * 2)
    Ke = solid_stiffness(X[elems], np.full(len(elems), 7e10), np.full(len(elems), 0.3))
    dofs = (elems[:, :, None] * 3 + np.arange(3)).reshape(len(elems), -1)
    for d, k in zip(dofs, Ke):
        K[np.ix_(d, d)] += k
    boundary = np.any((ijk == 0) | (ijk == ijk.max()), axis=1)
    inner = used[~boundary[used]]
    outer = used[boundary[used]]
    assert len(inner) > 0
    A = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.2, 0.6, 0.7]]) * 1e-3
    u = X @ A.T + [1e-3, -2e-3, 5e-4]
    di = (inner[:, None] * 3 + np.arange(3)).reshape(-1)
    do = (outer[:, None] * 3 + np.arange(3)).reshape(-1)
    ui = np.linalg.solve(K[np.ix_(di, di)], -K[np.ix_(di, do)] @ u[outer].reshape(-1))
    assert np.abs(ui - u[inner].reshape(-1)).max() <= 1e-10 * np.abs(u).max()


def _timoshenko_cantilever_hz(E, G, rho, b, h, L, kappa, guess):
    """First bending frequency of a clamped-free Timoshenko beam, from the beam equations
    κGA (w″ − ψ′) + ρAω² w = 0, EI ψ″ + κGA (w′ − ψ) + ρIω² ψ = 0: the transfer matrix
    exp(L S(ω)) of the state (w, w′, ψ, ψ′) from the clamped root (w = ψ = 0) to the free tip
    (ψ′ = 0, w′ − ψ = 0), whose 2×2 determinant vanishes at the natural frequency (brentq)."""
    A, I = b * h, b * h**3 / 12

    def det(f):
        w2 = (2 * np.pi * f) ** 2
        S = np.array([[0, 1, 0, 0],
                      [-rho * w2 / (kappa * G), 0, 0, 1],
                      [0, 0, 0, 1],
                      [0, -kappa * G * A / (E * I), (kappa * G * A - rho * I * w2) / (E * I), 0]])
        T = sla.expm(L * S)[:, [1, 3]]  # the root's free unknowns w′(0), ψ′(0)
        return np.linalg.det(np.array([T[3], T[1] - T[2]]))

    return brentq(det, 0.8 * guess, 1.2 * guess, xtol=1e-12)


def _cantilever_block(nn: int, n: int, L=1.0, h=0.1):
    """Block L × h × h along x, clamped at x = 0 (all grids there), ν = 0: n quadratic hexahedra
    (or 2n wedges) along x, one across the section; consistent mass."""
    m = new_deck()
    ref, _ = _reference_nodes(nn)
    grid = {}

    def gid(i, j, k):  # lattice point (i along x in half cells, j, k across)
        if (i, j, k) not in grid:
            grid[i, j, k] = len(grid) + 1
            m.add_grid(grid[i, j, k], [L * i / (2 * n), h * j / 2, h * k / 2],
                       ps="123456" if i == 0 else "456")
        return grid[i, j, k]

    m.add_mat1(1, 2.0e11, None, 0.0, rho=7800.0)
    m.add_psolid(1, 1)
    m.add_param("COUPMASS", [1])
    eid = 1
    for c in range(n):
        if nn == 20:
            halves = [ref + 1]
        else:
            halves = [np.stack((2 * ref[:, 0] + 2 * ref[:, 1], 2 * ref[:, 1], ref[:, 2] + 1), 1),
                      np.stack((2 * ref[:, 0], 2 * ref[:, 0] + 2 * ref[:, 1], ref[:, 2] + 1), 1)]
        for loc in halves:
            loc = np.rint(loc).astype(int)
            # natural (ξ, η, ζ) → (x, y, z) with x along the span
            nodes = [gid(2 * c + q[0], q[1], q[2]) for q in loc]
            (m.add_chexa if nn == 20 else m.add_cpenta)(eid, 1, nodes)
            eid += 1
    return model_of(m)


@pytest.mark.parametrize("nn", [20, 15])
def test_quadratic_cantilever_bending_frequency(nn):
    """First bending frequency of a clamped block (L/h = 10, ν = 0, so the section is free of
    Poisson restraint and κ = 5/6 for the rectangle) from 6 quadratic hexahedra (or 12 wedges)
    along the span, one across the section, vs the Timoshenko beam (its transcendental frequency
    equation solved numerically; 0.65 % below Euler–Bernoulli's): within 0.5 %. Observed +0.19 %
    (hexahedra) and +0.18 % (wedges); the hexahedra give +0.085 % with 12 cells, so about
    0.1 % is the mesh and the rest the 3-D block's stiffer clamped root, which the beam omits."""
    fe = _cantilever_block(nn, 6)
    f = fe.modes(2).frequencies_hz[0]
    E, G, rho, h, L = 2.0e11, 1.0e11, 7800.0, 0.1, 1.0
    euler = 1.875104**2 / (2 * np.pi) * np.sqrt(E * h**2 / 12 / (rho * L**4))
    ref = _timoshenko_cantilever_hz(E, G, rho, h, h, L, 5 / 6, euler)
    assert f == pytest.approx(ref, rel=5e-3)


def _reference_hexa20_grids():
    """A deck with the 20 grids of the reference hexahedron and steel (MAT1 1)."""
    m = new_deck()
    for k, x in enumerate(_reference_nodes(20)[0]):
        m.add_grid(k + 1, list(x))
    m.add_mat1(1, 2.0e11, None, 0.3, rho=7800.0)
    return m


def test_partly_quadratic_hexa_is_refused():
    """A CHEXA with its 8 corners and only some of the 12 edge grids: one-line error naming the
    file, element and the first blank field."""
    m = _reference_hexa20_grids()
    m.add_psolid(1, 1)
    m.add_chexa(7, 1, list(range(1, 11)) + [None] * 10)
    with pytest.raises(InputError, match=r"^test.bdf: CHEXA 7: field G11: edge grid blank while "
                       r"other edge grids are given: expected all 12 edge grids or none"):
        model_of(m)


def test_reduced_integration_request_is_noted():
    """PSOLID ISOP = REDUCED on a 20-grid CHEXA: the full rule is used, and the model says so."""
    m = _reference_hexa20_grids()
    m.add_psolid(1, 1, isop="REDUCED")
    m.add_chexa(7, 1, list(range(1, 21)))
    fe = model_of(m)
    assert any(n.startswith("PSOLID 1: IN = None, ISOP = REDUCED (reduced integration) on "
                            "CHEXA 7 with edge grids: the full Gauss rule is used")
               for n in fe.notes), fe.notes


def test_full_integration_request_on_linear_hexa_is_noted():
    """PSOLID ISOP = FULL on an 8-grid CHEXA: the incompatible-mode element is used anyway, and
    the model says so; no note without ISOP."""
    notes = {}
    for isop in ("FULL", None):
        m = new_deck()
        for k, x in enumerate(HEX):
            m.add_grid(k + 1, list(x))
        m.add_mat1(1, 2.0e11, None, 0.3, rho=7800.0)
        m.add_psolid(1, 1, isop=isop)
        m.add_chexa(7, 1, list(range(1, 9)))
        notes[isop] = model_of(m).notes
    assert any(n.startswith("PSOLID 1: ISOP = FULL (full integration) on CHEXA 7 without edge "
                            "grids: the element with incompatible (bubble) modes is used")
               for n in notes["FULL"]), notes["FULL"]
    assert not any("ISOP" in n for n in notes[None])


def test_partly_quadratic_hexa_through_the_command_line(tmp_path, capsys):
    """The same deck through ``torchrom modes``: exit status 2 and a one-line message naming
    the file, the element and the field (tests/test_bad_input.py's contract)."""
    from torchrom.cli import main

    m = _reference_hexa20_grids()
    m.add_psolid(1, 1)
    m.add_chexa(7, 1, list(range(1, 11)) + [None] * 10)
    m.add_eigrl(10, nd=4)
    path = tmp_path / "block.bdf"
    m.write_bdf(str(path), enddata=True)
    assert main(["modes", str(path)]) == 2
    lines = [ln for ln in capsys.readouterr().err.splitlines() if ln.strip()]
    assert "Traceback" not in "\n".join(lines)
    assert "block.bdf: CHEXA 7: field G11: edge grid blank" in lines[-1]


# --- incompatible modes of the 8-grid hexahedron and the 6-grid wedge ---------------------------


def _linear_connectivity(nn: int, n: int = 2) -> np.ndarray:
    """n×n×n cells on the (n+1)³ lattice points (index i (n+1)² + j (n+1) + k): 8-grid hexahedra
    (Nastran's order), or each cell as two 6-grid wedges (split along its x-y diagonal)."""
    m = n + 1
    out = []
    for c in np.ndindex(n, n, n):
        q = [np.array(c) + o for o in ((0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0))]
        a = [int(i * m * m + j * m + k) for i, j, k in q]
        b = [g + 1 for g in a]  # the same corners one layer up in z
        if nn == 8:
            out.append(a + b)
        else:
            out += [[a[0], a[1], a[2], b[0], b[1], b[2]], [a[0], a[2], a[3], b[0], b[2], b[3]]]
    return np.array(out)


def _assemble(X, elems, E, nu, rho=None, incompatible="taylor"):
    """Global K (and consistent M when rho is given) with 3 DOFs per point."""
    K = np.zeros((3 * len(X),) * 2)
    M = np.zeros_like(K)
    n = len(elems)
    Ke = solid_stiffness(X[elems], np.full(n, E), np.full(n, nu), incompatible=incompatible)
    Me = solid_mass(X[elems], np.full(n, rho or 0.0), coupled=True)
    for e, k, me in zip(elems, Ke, Me):
        d = (e[:, None] * 3 + np.arange(3)).reshape(-1)
        K[np.ix_(d, d)] += k
        M[np.ix_(d, d)] += me
    return K, M


def _dofs(points):
    return (np.asarray(points)[:, None] * 3 + np.arange(3)).reshape(-1)


@pytest.mark.parametrize("nn", [8, 6])
def test_incompatible_modes_patch_test(nn):
    """Patch test (Irons) of the elements with incompatible modes: a 2×2×2 block of distorted
    8-grid hexahedra (or 16 wedges), every grid moved at random by up to 0.12 of an element
    (warped faces), the boundary grids given u = A x + c: the interior grid takes that field to
    1e-10 of its size with Taylor's centre-Jacobian derivatives (∫ ∂P/∂x dV = 0 exactly, so the
    bubbles do not couple to constant strain; measured ~2e-16) and with none; Wilson's plain
    derivatives J⁻¹ ∂P/∂ξ fail it (measured 2.3e-3 hexa, 2.8e-3 wedge; asserted > 1e-4)."""
    X, ijk = _lattice(1)  # 3×3×3 points, 2×2×2 elements of size 0.5, moved by up to ±0.06
    elems = _linear_connectivity(nn)
    boundary = np.any((ijk == 0) | (ijk == ijk.max()), axis=1)
    inner, outer = np.flatnonzero(~boundary), np.flatnonzero(boundary)
    A = np.array([[1.0, 0.3, -0.2], [0.1, -0.5, 0.4], [0.2, 0.6, 0.7]]) * 1e-3
    u = X @ A.T + [1e-3, -2e-3, 5e-4]
    di, do = _dofs(inner), _dofs(outer)
    err = {}
    for inc in ("taylor", None, "wilson"):
        K = _assemble(X, elems, 7e10, 0.3, incompatible=inc)[0]
        ui = np.linalg.solve(K[np.ix_(di, di)], -K[np.ix_(di, do)] @ u[outer].reshape(-1))
        err[inc] = np.abs(ui - u[inner].reshape(-1)).max() / np.abs(u).max()
    print(nn, err)
    assert err["taylor"] <= 1e-10 and err[None] <= 1e-10
    assert err["wilson"] > 1e-4


@pytest.mark.parametrize("nn", [8, 6])
def test_incompatible_modes_rigid_modes_and_softening(nn):
    """A free distorted element with its bubbles condensed: exactly six zero-energy modes
    (rigid: 1e-10 of the largest eigenvalue) and the seventh clearly positive; the condensed
    stiffness is the plain one minus a positive semi-definite matrix (K_ci K_ii⁻¹ K_ic), so
    every Rayleigh quotient drops or stays (eigenvalues of the difference ≥ −1e-10 of the
    largest), and it does drop (the difference is not zero)."""
    X = SHAPES[nn][None]
    E, nu = np.array([7e10]), np.array([0.3])
    Kt = solid_stiffness(X, E, nu, incompatible="taylor")[0]
    K0 = solid_stiffness(X, E, nu, incompatible=None)[0]
    lam = np.linalg.eigvalsh(Kt)
    assert np.all(np.abs(lam[:6]) <= 1e-10 * lam[-1]) and lam[6] > 1e-6 * lam[-1]
    diff = np.linalg.eigvalsh(K0 - Kt)
    assert diff.min() >= -1e-10 * lam[-1] and diff.max() > 1e-3 * lam[-1]
    # the rigid motions themselves: zero forces
    w = np.array([0.3, -0.2, 0.5])
    u = (np.cross(w, X[0]) + [1.0, 2.0, -1.0]).reshape(-1)
    assert np.abs(Kt @ u).max() <= 1e-10 * np.abs(Kt).max() * np.abs(u).max()


def _beam_row(n: int, L: float, b: float, h: float, nn: int = 8):
    """One row of n rectangular 8-grid hexahedra along x (b along y, h along z), or each cell as
    two 6-grid wedges whose axis (ζ) runs along x."""
    X = np.array([[L * i / n, y, z] for i in range(n + 1)
                  for (y, z) in ((0, 0), (b, 0), (b, h), (0, h))], float)
    elems = []
    for i in range(n):
        a, c = [4 * i + j for j in range(4)], [4 * (i + 1) + j for j in range(4)]
        if nn == 8:
            elems.append(a + c)
        else:
            elems += [[a[0], a[1], a[2], c[0], c[1], c[2]], [a[0], a[2], a[3], c[0], c[2], c[3]]]
    return X, np.array(elems)


@pytest.mark.parametrize("nn", [8, 6])
def test_incompatible_pure_bending_is_exact(nn):
    """Cantilever of one row of 4 rectangular hexahedra (or 8 wedges, their axis ζ along the
    span, so that the wedge's bubble (1 − ζ²) is the x² of bending; L = 1, b = 0.1, h = 0.2, ν = 0),
    clamped at x = 0 (where the exact field vanishes), tip moment M as the consistent load of
    the linear end stress (± M / (2h) along x on the top and bottom grids): the exact
    displacement u = −κ x z, w = κ x² / 2 (κ = M / EI) lies in the element's space (the bubble
    (1 − ξ²) carries the x²), so every tip grid deflects by Euler–Bernoulli's w = M L² / (2 EI)
    to round-off (asserted 1e-8). The plain element locks: for ν = 0 its tip deflection is
    1 / (1 + ½ (a/h)²) of the exact one (a = element length; the parasitic shear of its bending
    mode), asserted to 1e-8 too — 0.561 here, for the wedges as for the hexahedra. (A wedge bent
    in the plane of its triangles has no bubble for that and stays stiff.)"""
    E, L, b, h, Mt = 2.0e11, 1.0, 0.1, 0.2, 1.0e3
    X, elems = _beam_row(4, L, b, h, nn)
    tip = np.flatnonzero(np.isclose(X[:, 0], L))
    F = np.zeros(3 * len(X))
    F[3 * tip] = Mt / (2 * h) * np.sign(X[tip, 2] - h / 2)
    free = _dofs(np.flatnonzero(X[:, 0] > 0))
    w_exact = -Mt * L**2 / (2 * E * b * h**3 / 12)  # +moment about y: tip moves down (−z)
    ratio = {}
    for inc in ("taylor", None):
        K = _assemble(X, elems, E, 0.0, incompatible=inc)[0]
        u = np.zeros_like(F)
        u[free] = np.linalg.solve(K[np.ix_(free, free)], F[free])
        ratio[inc] = u[3 * tip + 2] / w_exact
        if inc == "taylor":  # the tip section's axial motion: u = −κ L z about mid-depth
            kappa = Mt / (E * b * h**3 / 12)
            assert u[3 * tip] == pytest.approx(kappa * L * (X[tip, 2] - h / 2), rel=1e-8)
    print(ratio)
    assert ratio["taylor"] == pytest.approx(np.ones(4), rel=1e-8)
    a = L / 4
    assert ratio[None] == pytest.approx(np.full(4, 1 / (1 + 0.5 * (a / h) ** 2)), rel=1e-8)


@pytest.mark.parametrize("nn", [8, 6])
def test_incompatible_cantilever_bending_frequency(nn):
    """First bending frequency of a clamped block (L/h = 10, square section, ν = 0, consistent
    mass) from 6 hexahedra along the span and one across (or 12 wedges, axis along the span:
    the same numbers to 1e-8), vs the Timoshenko beam (κ = 5/6, the
    frequency equation solved numerically; 0.65 % below Euler–Bernoulli): within 1 % with the
    incompatible modes (measured +0.40 %; +0.16 % with 12 elements, so it converges to the
    beam: the rest is the coarse consistent mass), while the plain element is +54 % (asserted
    > 40 % off; +16 % with 12 elements)."""
    E, G, rho, h, L = 2.0e11, 1.0e11, 7800.0, 0.1, 1.0
    euler = 1.875104**2 / (2 * np.pi) * np.sqrt(E * h**2 / 12 / (rho * L**4))
    ref = _timoshenko_cantilever_hz(E, G, rho, h, h, L, 5 / 6, euler)
    X, elems = _beam_row(6, L, h, h, nn)
    free = _dofs(np.flatnonzero(X[:, 0] > 0))
    f = {}
    for inc in ("taylor", None):
        K, M = _assemble(X, elems, E, 0.0, rho, incompatible=inc)
        lam = sla.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], eigvals_only=True,
                       subset_by_index=[0, 0])
        f[inc] = np.sqrt(lam[0]) / (2 * np.pi) / ref - 1
    print(f)
    assert abs(f["taylor"]) <= 1e-2
    assert f[None] > 0.4


def test_incompatible_modes_are_the_default():
    """The model's solids take Taylor's form unless told otherwise; an unknown choice is
    refused."""
    X = SHAPES[8][None]
    E, nu = np.array([7e10]), np.array([0.3])
    assert np.array_equal(solid_stiffness(X, E, nu), solid_stiffness(X, E, nu, "taylor"))
    assert not np.allclose(solid_stiffness(X, E, nu), solid_stiffness(X, E, nu, None))
    with pytest.raises(ValueError, match="incompatible must be one of"):
        solid_stiffness(X, E, nu, "qm6")
