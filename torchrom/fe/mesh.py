"""Plain-array description of a structural model, independent of the Nastran reader.

:mod:`torchrom.fe.bdf_read` fills a :class:`Mesh` from a pyNastran BDF object; the element
modules and :class:`torchrom.fe.model.FEModel` only see these arrays. Grids are referred to by
their row in ``grid_ids``; all positions and directions are in the basic system; every grid has
six DOFs (T1, T2, T3, R1, R2, R3) whose components are measured in that grid's displacement
system (columns of ``cd_axes``), as in Nastran.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields

import numpy as np


def _empty(n: int, *shape: int, dtype=float) -> np.ndarray:
    return np.zeros((n, *shape), dtype=dtype)


@dataclass
class RodSet:
    """CROD/CONROD: axial Green-strain truss plus a linear torsion spring (G J / L)."""

    eids: np.ndarray = field(default_factory=lambda: _empty(0, dtype=int))
    nodes: np.ndarray = field(default_factory=lambda: _empty(0, 2, dtype=int))
    E: np.ndarray = field(default_factory=lambda: _empty(0))
    G: np.ndarray = field(default_factory=lambda: _empty(0))
    A: np.ndarray = field(default_factory=lambda: _empty(0))
    J: np.ndarray = field(default_factory=lambda: _empty(0))
    rho: np.ndarray = field(default_factory=lambda: _empty(0))
    nsm: np.ndarray = field(default_factory=lambda: _empty(0))

    def __len__(self) -> int:
        return len(self.eids)


@dataclass
class _ShellSet:
    """The fields a CQUAD4 and a CTRIA3 set share (PSHELL or PCOMP shells); ``nodes`` is
    (n, 4) or (n, 3) grid rows in the subclasses."""

    eids: np.ndarray = field(default_factory=lambda: _empty(0, dtype=int))
    nodes: np.ndarray = field(default_factory=lambda: _empty(0, 4, dtype=int))
    t: np.ndarray = field(default_factory=lambda: _empty(0))
    E: np.ndarray = field(default_factory=lambda: _empty(0))
    nu: np.ndarray = field(default_factory=lambda: _empty(0))
    G: np.ndarray = field(default_factory=lambda: _empty(0))
    rho: np.ndarray = field(default_factory=lambda: _empty(0))
    nsm: np.ndarray = field(default_factory=lambda: _empty(0))
    bend_E: np.ndarray = field(default_factory=lambda: _empty(0))
    bend_nu: np.ndarray = field(default_factory=lambda: _empty(0))
    shear_G: np.ndarray = field(default_factory=lambda: _empty(0))

    # PCOMP laminates (zeros elsewhere): membrane A, bending D, transverse shear (per element)
    lam_A: np.ndarray = field(default_factory=lambda: _empty(0, 3, 3))
    lam_D: np.ndarray = field(default_factory=lambda: _empty(0, 3, 3))
    lam_shear: np.ndarray = field(default_factory=lambda: _empty(0))
    #: ZOFFS: offset of the reference (mid-)plane from the plane of the grids along the element
    #: normal (0: none)
    zoffs: np.ndarray = field(default_factory=lambda: _empty(0))

    def __post_init__(self):
        n = len(self.eids)
        if len(self.lam_A) != n:
            self.lam_A, self.lam_D = np.zeros((n, 3, 3)), np.zeros((n, 3, 3))
            self.lam_shear = np.zeros(n)
        if len(self.zoffs) != n:
            self.zoffs = np.zeros(n)

    @property
    def laminated(self) -> np.ndarray:
        """(n,) True for PCOMP elements (stiffness from ``lam_A``/``lam_D``)."""
        return np.any(self.lam_A != 0.0, axis=(1, 2))

    @property
    def offset(self) -> np.ndarray:
        """(n,) True for elements with a ZOFFS offset."""
        return self.zoffs != 0.0

    def select(self, mask: np.ndarray):
        """The elements where ``mask`` (n,) is True, as a set of the same class."""
        return type(self)(**{f.name: getattr(self, f.name)[mask] for f in fields(self)})

    def __len__(self) -> int:
        return len(self.eids)


@dataclass
class QuadSet(_ShellSet):
    """CQUAD4/PSHELL: Green-strain membrane, optional linear bending (MITC4), drilling spring.

    ``bend_E``/``bend_nu`` come from PSHELL MID2 scaled by 12I/t³ (0 where MID2 is blank:
    membrane only); ``shear_G`` is the transverse shear modulus times TS/T.
    """


@dataclass
class TriaSet(_ShellSet):
    """CTRIA3/PSHELL: Green-strain CST membrane, optional linear DKT bending, drilling spring
    (fields as :class:`QuadSet`; ``shear_G`` is unused: DKT is a thin-plate element)."""

    nodes: np.ndarray = field(default_factory=lambda: _empty(0, 3, dtype=int))


@dataclass
class SolidSet:
    """CHEXA/CPENTA/CTETRA (one family: 8, 20, 6, 15, 4 or 10 grids) with PSOLID/MAT1: small-strain
    linear elastic solids."""

    eids: np.ndarray
    nodes: np.ndarray  # (n, nn) grid rows
    E: np.ndarray
    nu: np.ndarray
    rho: np.ndarray

    def __len__(self) -> int:
        return len(self.eids)


@dataclass
class ShearSet:
    """CSHEAR/PSHEAR: in-plane shear only (Green shear strain at the panel centre)."""

    eids: np.ndarray = field(default_factory=lambda: _empty(0, dtype=int))
    nodes: np.ndarray = field(default_factory=lambda: _empty(0, 4, dtype=int))
    t: np.ndarray = field(default_factory=lambda: _empty(0))
    G: np.ndarray = field(default_factory=lambda: _empty(0))
    rho: np.ndarray = field(default_factory=lambda: _empty(0))
    nsm: np.ndarray = field(default_factory=lambda: _empty(0))

    def __len__(self) -> int:
        return len(self.eids)


@dataclass
class Taper:
    """A CBEAM's section along its length (tapered PBEAM/PBEAML, MSC QRG PBEAM): stations ``x``
    (fractions of the length from end A, 0 first, 1 last, increasing) and the area, moments of
    inertia, torsion constant, non-structural mass per length and its torsional inertia per
    length at each; each varies linearly between stations."""

    x: np.ndarray
    A: np.ndarray
    I1: np.ndarray
    I2: np.ndarray
    I12: np.ndarray
    J: np.ndarray
    nsm: np.ndarray
    nsi: np.ndarray

    @property
    def varies(self) -> bool:
        """True if the stiffness properties (A, I1, I2, I12, J) differ between stations."""
        return not all(np.allclose(v, v[0], rtol=1e-12, atol=0.0)
                       for v in (self.A, self.I1, self.I2, self.I12, self.J))

    def at(self, xi: np.ndarray) -> dict[str, np.ndarray]:
        """The properties at the fractions ``xi`` of the length (linear between stations)."""
        return {name: np.interp(xi, self.x, getattr(self, name))
                for name in ("A", "I1", "I2", "I12", "J", "nsm", "nsi")}


@dataclass
class BarSet:
    """CBAR/CBEAM: linear beam; ``v`` is the orientation vector in basic axes; ``k1``/``k2``
    the shear area factors of planes 1/2 (0: no shear flexibility, Euler–Bernoulli);
    ``polar`` the torsional mass moment of inertia per length (CBEAM: ρ (I1 + I2); CBAR: 0);
    ``I12`` the product of inertia ∫ y z dA; ``wa``/``wb`` the rigid offsets (basic) from grid
    A/B to the element's ends; ``pa``/``pb`` (n, 6) 1.0 where a component (element system) is
    released by a pin flag at end A/B; ``taper`` maps the row of a tapered CBEAM to its
    :class:`Taper` (its scalar section fields then hold end A's values); ``na`` (n, 4) the
    PBEAM neutral axis (N1A, N2A, N1B, N2B), element system, relative to the shear centre."""

    eids: np.ndarray = field(default_factory=lambda: _empty(0, dtype=int))
    nodes: np.ndarray = field(default_factory=lambda: _empty(0, 2, dtype=int))
    v: np.ndarray = field(default_factory=lambda: _empty(0, 3))
    A: np.ndarray = field(default_factory=lambda: _empty(0))
    I1: np.ndarray = field(default_factory=lambda: _empty(0))
    I2: np.ndarray = field(default_factory=lambda: _empty(0))
    J: np.ndarray = field(default_factory=lambda: _empty(0))
    E: np.ndarray = field(default_factory=lambda: _empty(0))
    G: np.ndarray = field(default_factory=lambda: _empty(0))
    rho: np.ndarray = field(default_factory=lambda: _empty(0))
    nsm: np.ndarray = field(default_factory=lambda: _empty(0))
    k1: np.ndarray = field(default_factory=lambda: _empty(0))
    k2: np.ndarray = field(default_factory=lambda: _empty(0))
    polar: np.ndarray = field(default_factory=lambda: _empty(0))
    I12: np.ndarray = field(default_factory=lambda: _empty(0))
    wa: np.ndarray = field(default_factory=lambda: _empty(0, 3))
    wb: np.ndarray = field(default_factory=lambda: _empty(0, 3))
    pa: np.ndarray = field(default_factory=lambda: _empty(0, 6))
    pb: np.ndarray = field(default_factory=lambda: _empty(0, 6))
    taper: dict[int, Taper] = field(default_factory=dict)
    na: np.ndarray = field(default_factory=lambda: _empty(0, 4))

    def __post_init__(self):
        n = len(self.eids)
        for name in ("k1", "k2", "polar", "I12"):
            if len(getattr(self, name)) != n:
                setattr(self, name, np.zeros(n))
        for name, width in (("wa", 3), ("wb", 3), ("pa", 6), ("pb", 6), ("na", 4)):
            if len(getattr(self, name)) != n:
                setattr(self, name, np.zeros((n, width)))

    def __len__(self) -> int:
        return len(self.eids)


@dataclass
class PointMass:
    """CONM2: rigid mass at ``offset`` (basic) from its grid, inertia about its CG (basic)."""

    eid: int
    grid: int  # row
    mass: float
    offset: np.ndarray
    inertia: np.ndarray


@dataclass
class ScalarMass:
    """CMASS2: scalar mass between (grid1, comp1) and (grid2, comp2); grid2 = -1 is ground."""

    eid: int
    mass: float
    grid1: int
    comp1: int  # 0..5
    grid2: int
    comp2: int


@dataclass
class ScalarSpring:
    """CELAS1/CELAS2: scalar spring k (u1 − u2)² / 2 between (grid1, comp1) and (grid2, comp2);
    grid2 = -1 is ground."""

    eid: int
    stiffness: float
    grid1: int
    comp1: int  # 0..5
    grid2: int
    comp2: int


@dataclass
class Bush:
    """CBUSH (or to ground, ``grid2`` = -1): six springs K1..K6 along and about the axes
    (columns of ``axes``, basic) of its element system, at the spring point, which is rigidly
    linked to each grid: ``arm1``/``arm2`` (basic) from grid 1/2 to it (zero for coincident
    grids)."""

    eid: int
    grid1: int
    grid2: int
    stiffness: np.ndarray  # (6,)
    axes: np.ndarray  # (3, 3)
    arm1: np.ndarray = field(default_factory=lambda: np.zeros(3))
    arm2: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass
class MassMatrix6:
    """CONM1: a symmetric 6x6 mass matrix at a grid, in basic axes (T1..T3, R1..R3)."""

    eid: int
    grid: int  # row
    matrix: np.ndarray


@dataclass
class LinearMPC:
    """MPC: Σ a_i u_i = 0 over (grid row, component 0..5 in the grid's CD system); the first
    term's DOF is the dependent one: u_0 = −Σ_(i>0) (a_i / a_0) u_i."""

    sid: int
    terms: list[tuple[float, int, int]]  # (coefficient, grid row, component)


@dataclass
class RigidRBE2:
    """RBE2: components ``comps`` (0..5) of the ``dependent`` rows follow grid ``independent``."""

    eid: int
    independent: int
    comps: list[int]
    dependent: list[int]


@dataclass
class RigidRBE1:
    """RBE1: the grids move as one rigid body whose motion is set by the ``independent``
    (grid row, component 0..5) pairs (six, from one or several grids); the ``dependent`` pairs
    follow it."""

    eid: int
    independent: list[tuple[int, int]]
    dependent: list[tuple[int, int]]


@dataclass
class InterpRBE3:
    """RBE3: reference grid components ``ref_comps`` = weighted least-squares rigid fit of the
    groups (weight, components 0..5, grid rows)."""

    eid: int
    ref: int
    ref_comps: list[int]
    groups: list[tuple[float, list[int], list[int]]]


@dataclass
class GeneralElement:
    """GENEL: a stiffness matrix ``K`` (n, n) on n scalar DOFs ``dofs`` (grid row, component
    0..5 in the grid's displacement system), independent ones first (see
    :func:`torchrom.fe.mass.genel_stiffness`)."""

    eid: int
    dofs: list[tuple[int, int]]
    K: np.ndarray


@dataclass
class Mesh:
    """Everything the FE model needs, in basic axes and grid rows."""

    grid_ids: np.ndarray
    xyz: np.ndarray
    cd_axes: np.ndarray  # (n_grid, 3, 3): columns are the displacement-system axes in basic
    rods: RodSet = field(default_factory=RodSet)
    quads: QuadSet = field(default_factory=QuadSet)
    trias: TriaSet = field(default_factory=TriaSet)
    solids: list[SolidSet] = field(default_factory=list)
    shears: ShearSet = field(default_factory=ShearSet)
    bars: BarSet = field(default_factory=BarSet)
    conm2: list[PointMass] = field(default_factory=list)
    cmass2: list[ScalarMass] = field(default_factory=list)
    celas: list[ScalarSpring] = field(default_factory=list)
    bushes: list[Bush] = field(default_factory=list)
    conm1: list[MassMatrix6] = field(default_factory=list)
    genel: list[GeneralElement] = field(default_factory=list)
    rbe2: list[RigidRBE2] = field(default_factory=list)
    rbe1: list[RigidRBE1] = field(default_factory=list)
    rbe3: list[InterpRBE3] = field(default_factory=list)
    mpc: list[LinearMPC] = field(default_factory=list)
    spc: list[tuple[int, int]] = field(default_factory=list)  # (grid row, comp 0..5)
    spc_source: dict[tuple[int, int], str] = field(default_factory=dict)
    coupled_mass: bool = False

    @property
    def n_grid(self) -> int:
        return len(self.grid_ids)

    def grid_row(self) -> dict[int, int]:
        return {int(g): i for i, g in enumerate(self.grid_ids)}
