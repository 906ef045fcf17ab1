"""Small in-memory Nastran decks (pyNastran BDF objects) shared by the FE tests."""

from __future__ import annotations

import numpy as np
from pyNastran.bdf.bdf import BDF

from torchrom.fe.bdf_read import from_pynastran


def new_deck() -> BDF:
    return BDF(debug=None)


def model_of(bdf: BDF, name: str = "test", **kw):
    return from_pynastran(bdf, source=f"{name}.bdf", name=name, **kw)


def rotation(axis, angle: float) -> np.ndarray:
    """Rodrigues rotation matrix."""
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * K + (1 - np.cos(angle)) * K @ K


def single_element(kind: str) -> BDF:
    """One unconstrained element of a Green-strain family: 'rod', 'membrane', 'shear' or 'tria'
    (a CTRIA3 membrane), or 'shell' (a CQUAD4 with bending and transverse shear).

    The quad is a slightly irregular (but planar) quadrilateral, tilted out of the x-y plane.
    """
    m = new_deck()
    m.add_mat1(1, 7.0e10, None, 0.3, rho=2700.0)
    if kind == "rod":
        m.add_grid(1, [0.1, -0.2, 0.3])
        m.add_grid(2, [1.3, 0.4, -0.2])
        m.add_prod(1, 1, 1e-4)
        m.add_crod(1, 1, [1, 2])
        return m
    R = rotation([1.0, 2.0, 0.5], 0.4)
    pts = np.array([[0.0, 0.0, 0.0], [1.2, 0.1, 0.0], [1.0, 0.9, 0.0], [-0.1, 0.8, 0.0]]) @ R.T
    for k, p in enumerate(pts):
        m.add_grid(k + 1, list(p))
    if kind == "tria":
        m.nodes.pop(4)
        m.add_pshell(1, mid1=1, t=0.01)
        m.add_ctria3(1, 1, [1, 2, 3])
    elif kind == "membrane":
        m.add_pshell(1, mid1=1, t=0.01)
        m.add_cquad4(1, 1, [1, 2, 3, 4])
    elif kind == "shell":
        m.add_pshell(1, mid1=1, t=0.05, mid2=1, mid3=1)
        m.add_cquad4(1, 1, [1, 2, 3, 4])
    else:
        m.add_pshear(1, 1, 0.01)
        m.add_cshear(1, 1, [1, 2, 3, 4])
    return m


def grid_lattice(m: BDF, nx: int, ny: int, Lx: float, Ly: float):
    """GRIDs of an (nx + 1) × (ny + 1) lattice over [0, Lx] × [0, Ly] in the x-y plane; returns
    the id of grid (i, j)."""
    def nid(i: int, j: int) -> int:
        return 1 + i * (ny + 1) + j

    for i in range(nx + 1):
        for j in range(ny + 1):
            m.add_grid(nid(i, j), [Lx * i / nx, Ly * j / ny, 0.0])
    return nid


def plate_strip(n_long: int, n_wide: int, L: float, b: float, t: float, E: float, nu: float,
                rho: float, bending: bool = True, coupled: bool = False,
                triangles: bool = False) -> BDF:
    """Cantilever strip of CQUAD4s (or two CTRIA3s per cell, alternating diagonals) in the x-y
    plane, clamped at x = 0."""
    m = new_deck()
    nid = grid_lattice(m, n_long, n_wide, L, b)
    m.add_mat1(1, E, None, nu, rho=rho)
    m.add_pshell(1, mid1=1, t=t, mid2=1 if bending else None, mid3=1 if bending else None)
    eid = 1
    for i in range(n_long):
        for j in range(n_wide):
            c = [nid(i, j), nid(i + 1, j), nid(i + 1, j + 1), nid(i, j + 1)]
            if triangles:
                a, b_, cc, d = c if (i + j) % 2 == 0 else c[1:] + c[:1]
                m.add_ctria3(eid, 1, [a, b_, cc])
                m.add_ctria3(eid + 1, 1, [a, cc, d])
                eid += 2
            else:
                m.add_cquad4(eid, 1, c)
                eid += 1
    m.add_spc1(1, "123456", [nid(0, j) for j in range(n_wide + 1)])
    if coupled:
        m.add_param("COUPMASS", [1])
    return m


def simply_supported_plate(n: int, a: float, t: float, E: float, nu: float, rho: float) -> BDF:
    """Square plate a × a of n × n CQUAD4 in the x-y plane, "hard" simple support on its four
    edges: w = 0 and the rotation about the edge normal (the edge's tangential slope) = 0, the
    Mindlin condition that matches Navier's Kirchhoff solution. The in-plane rigid motion is
    removed at three corners."""
    m = new_deck()
    nid = grid_lattice(m, n, n, a, a)
    m.add_mat1(1, E, None, nu, rho=rho)
    m.add_pshell(1, mid1=1, t=t, mid2=1, mid3=1)
    for i in range(n):
        for j in range(n):
            m.add_cquad4(1 + i * n + j, 1,
                         [nid(i, j), nid(i + 1, j), nid(i + 1, j + 1), nid(i, j + 1)])
    x_edges = [nid(i, j) for i in (0, n) for j in range(n + 1)]
    y_edges = [nid(i, j) for j in (0, n) for i in range(1, n)]
    m.add_spc1(1, "34", x_edges)  # edges x = 0, a: w and θx
    m.add_spc1(1, "35", y_edges)  # edges y = 0, a: w and θy
    m.add_spc1(1, "5", [nid(i, j) for i in (0, n) for j in (0, n)])  # corners: both slopes
    m.add_spc1(1, "12", [nid(0, 0), nid(n, 0)])
    m.add_spc1(1, "1", [nid(0, n)])
    return m


def flange_web_beam(n: int, L: float, h: float, A: float, t: float, E: float, nu: float,
                    rho: float) -> BDF:
    """Planar cantilever in the x-z plane: rod flanges at z = ±h/2, a CSHEAR web and vertical
    posts (the shear panel has no direct stiffness)."""
    m = new_deck()
    for i in range(n + 1):
        m.add_grid(100 + i, [L * i / n, 0.0, h / 2])
        m.add_grid(200 + i, [L * i / n, 0.0, -h / 2])
    m.add_mat1(1, E, None, nu, rho=rho)
    m.add_prod(1, 1, A)
    m.add_pshear(2, 1, t)
    m.add_prod(3, 1, A / 100)
    for i in range(n):
        m.add_crod(1 + i, 1, [100 + i, 101 + i])
        m.add_crod(101 + i, 1, [200 + i, 201 + i])
        m.add_cshear(201 + i, 2, [100 + i, 101 + i, 201 + i, 200 + i])
        m.add_crod(301 + i, 3, [101 + i, 201 + i])
    m.add_spc1(1, "123456", [100, 200])
    return m


def two_bar_truss(a: float, h: float, EA: float) -> BDF:
    """Von Mises truss: supports at (±a, 0, 0), apex at (0, 0, h), free only along z."""
    m = new_deck()
    m.add_grid(1, [-a, 0.0, 0.0])
    m.add_grid(2, [a, 0.0, 0.0])
    m.add_grid(3, [0.0, 0.0, h])
    m.add_mat1(1, EA, None, 0.3, rho=1.0)
    m.add_prod(1, 1, 1.0)
    m.add_crod(1, 1, [1, 3])
    m.add_crod(2, 1, [2, 3])
    m.add_spc1(1, "123456", [1, 2])
    m.add_spc1(1, "12456", [3])
    return m


def tip_mass_beam(n: int = 8, I1: float = 2e-6, I2: float = 8e-6, nsm=(1.0, 0.5),
                  tip_mass: float = 4.0, tip_x: float = 0.05) -> BDF:
    """Cantilever CBAR wing along y (L = 2 m, clamped at y = 0): PBAR 1 inboard, PBAR 2
    outboard (same section, NSM ``nsm``), vertical bending I1, chordwise bending I2; a tip
    CONM2 (eid 100) offset ``tip_x`` chordwise with a pitch inertia."""
    m = new_deck()
    L = 2.0
    for i in range(n + 1):
        m.add_grid(i + 1, [0.0, L * i / n, 0.0])
    m.add_mat1(1, 7.0e10, 2.7e10, None, rho=2700.0)
    for pid, ns in ((1, nsm[0]), (2, nsm[1])):
        m.add_pbar(pid, 1, A=1e-3, i1=I1, i2=I2, j=4e-6, nsm=ns)
    for i in range(n):
        m.add_cbar(i + 1, 1 if i < n // 2 else 2, [i + 1, i + 2], [0.0, 0.0, 1.0], None)
    m.add_conm2(100, n + 1, tip_mass, X=[tip_x, 0.0, 0.0], I=[0.0, 0.0, 0.02, 0.0, 0.0, 0.0])
    m.add_spc1(1, "123456", [1])
    return m


def assert_tangent_is_consistent(fe, u, symmetry_rtol: float, h: float = 1e-6) -> float:
    """K_T(u) against central differences of f(u) (step ``h``) to 1e-6 of max |K| (truncation
    and rounding of the differences sit near 1e-11), and symmetric to ``symmetry_rtol``;
    returns max |K| (the scale of later checks)."""
    K = fe.tangent_stiffness(u).toarray()
    Kfd = np.column_stack([(fe.internal_force(u + h * e) - fe.internal_force(u - h * e)) / (2 * h)
                           for e in np.eye(fe.n_dof)])
    scale = np.abs(K).max()
    assert np.abs(K - Kfd).max() <= 1e-6 * scale
    assert np.abs(K - K.T).max() <= symmetry_rtol * scale
    return scale
