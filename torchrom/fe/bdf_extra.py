"""Readers of the cards added for real decks, mixed into the bulk-data reader.

Like :mod:`torchrom.fe.bdf_read` (whose ``_Reader`` inherits these methods and
provides ``self.m`` (the pyNastran model), ``self.f`` (file name), ``self.xyz``, ``self.ids``,
``self.rows``, ``self.prop``, ``self.mat1``, ``self.err`` and ``self.notes``): linear and
quadratic solids (CHEXA/CPENTA/CTETRA + PSOLID), PCOMP shells, CELAS1/CELAS2, CBUSH, CONM1, RBAR,
RBE1 and MPC/MPCADD, and the zero-area check of CTRIA3. Kept in their own module so that the core
reader stays small.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from .coords import axes_at as _axes_at
from .coords import components as _comps
from .elements.solid import solid_volumes
from .laminate import laminate
from .mass import genel_stiffness
from .mesh import (
    Bush,
    GeneralElement,
    LinearMPC,
    MassMatrix6,
    Mesh,
    RigidRBE1,
    RigidRBE2,
    ScalarSpring,
)

#: solid elements and the numbers of grids supported: the corner grids alone, or with all the
#: edge grids (the quadratic forms)
SOLID_GRIDS = {"CHEXA": (8, 20), "CPENTA": (6, 15), "CTETRA": (4, 10)}


class ExtraCards:
    """Card readers mixed into :class:`torchrom.fe.bdf_read._Reader`."""

    def _solid(self, e):
        """CHEXA, CPENTA, CTETRA with their corner grids alone (linear) or with all their edge
        grids (quadratic), PSOLID and MAT1."""
        eid, card = e.eid, e.type
        corners = SOLID_GRIDS[card][0]
        given = [n not in (None, 0) for n in e.nodes]
        edges = given[corners:]
        if any(edges) and not all(edges):
            k = corners + edges.index(False)
            raise self.err(f"{card} {eid}: field G{k + 1}: edge grid blank while other edge grids"
                           f" are given: expected all {SOLID_GRIDS[card][1] - corners} edge grids"
                           " or none (partly quadratic solids are not supported)")
        nodes = [n for n in e.nodes if n not in (None, 0)]
        if len(nodes) not in SOLID_GRIDS[card]:
            forms = " or ".join(str(k) for k in SOLID_GRIDS[card])
            raise self.err(f"{card} {eid}: {len(nodes)} grids: only {forms} grids are supported"
                           f" (the edge grids of CHEXA/CPENTA, all or none of CTETRA's)")
        p = self.prop(e.pid, card, eid, ("PSOLID",))
        E, _, nu, rho = self.mat1(p.mid, f"PSOLID {p.pid}", "MID")
        if not (E > 0 and -1.0 < nu < 0.5):
            raise self.err(f"PSOLID {p.pid}: MAT1 {p.mid}: a solid needs E > 0 and -1 < NU < 0.5,"
                           f" got E = {E}, NU = {nu}")
        if len(nodes) > corners:
            self._note_reduced_integration(p, card, eid)
        elif card != "CTETRA":
            self._note_full_integration(p, card, eid)
        rows = self.rows(nodes, card, eid)
        if not abs(solid_volumes(self.xyz[rows][None])[0]) > 0:
            raise self.err(f"{card} {eid}: zero volume (grids {nodes})")
        return dict(eids=eid, nodes=rows, E=E, nu=nu, rho=rho)

    def _note_reduced_integration(self, p, card: str, eid: int) -> None:
        """PSOLID IN = 2 or ISOP = 0/REDUCED asks Nastran for reduced integration of the
        quadratic forms; the full rule is used here (:mod:`torchrom.fe.elements.solid`)."""
        integ, isop = str(p.integ or "").upper(), str(p.isop if p.isop is not None else "")
        if integ in ("2", "TWO") or isop.upper() in ("0", "REDUCED"):
            note = (f"PSOLID {p.pid}: IN = {p.integ}, ISOP = {p.isop} (reduced integration) on"
                    f" {card} {eid} with edge grids: the full Gauss rule is used")
            if not any(n.startswith(f"PSOLID {p.pid}: IN") for n in self.notes):
                self.notes.append(note)

    def _note_full_integration(self, p, card: str, eid: int) -> None:
        """PSOLID ISOP = 1/FULL on an 8-grid CHEXA or 6-grid CPENTA asks Nastran for the plain
        fully integrated element; the incompatible-mode element is used here regardless
        (:mod:`torchrom.fe.elements.solid`)."""
        isop = str(p.isop if p.isop is not None else "").upper()
        if isop in ("1", "FULL"):
            note = (f"PSOLID {p.pid}: ISOP = {p.isop} (full integration) on {card} {eid} without"
                    " edge grids: the element with incompatible (bubble) modes is used")
            if not any(n.startswith(f"PSOLID {p.pid}: ISOP") for n in self.notes):
                self.notes.append(note)

    def _check_trias(self, trias) -> None:
        """Triangles with a zero area (collinear or coincident grids) are refused."""
        if not len(trias):
            return
        X = self.xyz[trias.nodes]
        c = np.linalg.norm(np.cross(X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]), axis=1)
        edge = np.linalg.norm(X - np.roll(X, 1, axis=1), axis=2).max(axis=1)
        bad = ~(c > 1e-10 * edge**2)
        if bad.any():
            k = int(np.argmax(bad))
            grids = [int(g) for g in self.ids[trias.nodes[k]]]
            raise self.err(f"CTRIA3 {int(trias.eids[k])}: zero-area element (grids {grids})")

    def _pcomp_shell(self, e, p):
        """CQUAD4/CTRIA3 with PCOMP: the equivalent laminate (:mod:`torchrom.fe.laminate`)."""
        eid, card = e.eid, e.type
        theta = e.theta_mcid
        if isinstance(theta, int) and theta:
            raise self.err(f"{card} {eid}: field MCID: a material coordinate system is not "
                           "supported with PCOMP (give THETA)")
        try:
            lam = laminate(p, self.m.materials, float(theta or 0.0))
        except InputError as exc:
            raise self.err(str(exc)) from None
        t = lam.thickness
        if card == "CQUAD4" and np.abs(lam.A[:2, 2]).max() > 1e-9 * np.abs(lam.A).max():
            raise self.err(f"PCOMP {p.pid}: unbalanced laminate (A16/A26 ≠ 0) on CQUAD4 {eid}: "
                           "its membrane integrates the shear apart from the normal strains")
        note = f"PCOMP {p.pid}: equivalent laminate stiffness (A, D of classical lamination theory)"
        if note not in self.notes:
            self.notes.append(note)
        nodes = self._surface(e, card)
        return dict(eids=eid, nodes=nodes, t=t, E=lam.A[0, 0] / t, nu=0.0, G=lam.A[2, 2] / t,
                    rho=lam.mass_per_area / t, nsm=float(p.nsm or 0.0), bend_E=1.0, bend_nu=0.0,
                    shear_G=lam.shear / t, lam_A=lam.A, lam_D=lam.D, lam_shear=lam.shear)

    def _celas(self, e) -> ScalarSpring:
        if e.type == "CELAS1":
            p = self.m.properties.get(e.pid)
            if p is None or p.type != "PELAS":
                raise self.err(f"CELAS1 {e.eid}: field PID: PELAS {e.pid} not found")
            k, ge = float(p.k), float(p.ge or 0.0)
        else:
            k, ge = float(e.k), float(e.ge or 0.0)
        if ge:
            self.notes.append(f"{e.type} {e.eid}: structural damping GE = {ge:g} ignored")
        return ScalarSpring(e.eid, k, *self._scalar_pair(e))

    def _genel(self, e) -> GeneralElement:
        """GENEL: stiffness (K) or flexibility (Z, inverted) of the UI DOFs, the lower triangle
        column by column, and S for the UD DOFs (:func:`torchrom.fe.mass.genel_stiffness`)."""
        eid = e.eid
        where = f"GENEL {eid}"

        def dofs(pairs, field):
            out = []
            for nid, comp in np.asarray(pairs, dtype=int).reshape(-1, 2):
                (g,) = self.rows([int(nid)], "GENEL", eid, field)
                cs = _comps(str(comp), self.f, f"{where}: field {field}")
                if len(cs) != 1:
                    raise self.err(f"{where}: field {field}: grid {nid}: expected one "
                                   f"component 1-6, got {comp}")
                out.append((g, cs[0]))
            return out

        ui = dofs(e.ul, "UI")
        ud = dofs(e.ud, "UD") if e.ud is not None and len(e.ud) else []
        lower = e.k if e.k is not None else e.z
        n = len(ui)
        tri = np.asarray(lower, dtype=float).reshape(-1)
        if len(tri) != n * (n + 1) // 2:
            raise self.err(f"{where}: field {'K' if e.k is not None else 'Z'}: expected "
                           f"{n * (n + 1) // 2} terms (lower triangle of {n} UI DOFs), "
                           f"got {len(tri)}")
        L = np.zeros((n, n))
        L.T[np.triu_indices(n)] = tri  # column by column: the upper triangle of Lᵀ, row-major
        mat = L + np.tril(L, -1).T
        if e.k is None:
            try:
                mat = np.linalg.inv(mat)
            except np.linalg.LinAlgError:
                raise self.err(f"{where}: field Z: the flexibility matrix is singular") from None
        S = None
        if ud:
            if e.s is None or len(np.ravel(e.s)) != n * len(ud):
                raise self.err(f"{where}: field S: expected {n} x {len(ud)} terms for the UD "
                               "DOFs (S may not be left out here)")
            S = np.asarray(e.s, dtype=float).reshape(n, len(ud))
        return GeneralElement(eid, ui + ud, genel_stiffness(mat, S))

    def _cbush(self, e) -> Bush:
        """CBUSH/PBUSH (stiffness only; MSC QRG CBUSH): to ground, between coincident grids (CID
        needed) or between separate grids, at the spring point S on the line GA-GB (OCID = -1)
        rigidly linked to both. Element axes: CID's (0: basic) or, with CID blank, x from GA to
        GB and y in the plane of x and the orientation vector (X1-X3 in GA's displacement
        system, or GA → G0), z = x × y."""
        eid = e.eid
        where = f"CBUSH {eid}"
        p = self.prop(e.pid, "CBUSH", eid, ("PBUSH",))
        n1, n2 = (list(e.nodes) + [None])[:2]
        (g1,) = self.rows([n1], "CBUSH", eid, "GA")
        g2, gap = -1, np.zeros(3)
        if n2 not in (None, 0):
            (g2,) = self.rows([n2], "CBUSH", eid, "GB")
            gap = self.xyz[g2] - self.xyz[g1]
        apart = np.linalg.norm(gap) > 1e-4  # Nastran's coincidence distance (QRG CBUSH)
        if e.cid is not None and e.cid >= 0:
            if e.cid and e.cid not in self.m.coords:
                raise self.err(f"{where}: field CID: coordinate system {e.cid} not found")
            axes = _axes_at(self.m.coords[e.cid], self.xyz[g1]) if e.cid else np.eye(3)
        elif not apart:
            raise self.err(f"{where}: field CID: expected a coordinate system for a bush "
                           "between coincident grids or to ground, got blank")
        else:
            axes = self._bush_axes(e, where, g1, gap)
        arm1, arm2 = np.zeros(3), np.zeros(3)
        if apart:
            if e.ocid not in (None, -1):
                raise self.err(f"{where}: field OCID: only the spring on the line GA-GB "
                               f"(OCID = -1, blank) is supported, got {e.ocid}")
            s = 0.5 if e.s is None else float(e.s)
            if not 0.0 <= s <= 1.0:
                raise self.err(f"{where}: field S: expected 0 <= S <= 1, got {e.s}")
            arm1, arm2 = s * gap, (s - 1.0) * gap
        k = np.zeros(6)
        k[: len(p.Ki)] = [float(x or 0.0) for x in p.Ki]
        if any(float(x or 0.0) for x in list(p.Bi) + list(p.GEi)):
            note = f"PBUSH {p.pid}: damping B/GE ignored (real modes and undamped flutter)"
            if note not in self.notes:
                self.notes.append(note)
        return Bush(eid, g1, g2, k, axes, arm1, arm2)

    def _bush_axes(self, e, where: str, g1: int, gap: np.ndarray) -> np.ndarray:
        """Element axes (columns, basic) of a CBUSH between separate grids with CID blank."""
        if e.g0 not in (None, 0):
            (g0,) = self.rows([e.g0], "CBUSH", e.eid, "G0")
            v = self.xyz[g0] - self.xyz[g1]
        elif e.x is not None and any(x is not None for x in e.x):
            cd = self.m.nodes[int(self.ids[g1])].cd
            x = np.array([float(c or 0.0) for c in e.x])
            v = _axes_at(self.m.coords[cd], self.xyz[g1]) @ x if cd else x
        else:
            raise self.err(f"{where}: fields X1-X3/G0/CID: expected an orientation vector or a "
                           "coordinate system, got none")
        ex = gap / np.linalg.norm(gap)
        vy = v - (v @ ex) * ex
        if not np.linalg.norm(vy) > 1e-9 * max(np.linalg.norm(v), 1e-300):
            raise self.err(f"{where}: fields X1-X3/G0: orientation vector is parallel to GA-GB "
                           "or zero")
        ey = vy / np.linalg.norm(vy)
        return np.column_stack((ex, ey, np.cross(ex, ey)))

    def _conm1(self, c, wtmass: float) -> MassMatrix6:
        (g,) = self.rows([c.nid], "CONM1", c.eid)
        M = np.asarray(c.mass_matrix, dtype=float)
        cid = int(c.cid or 0)
        if cid:
            coord = self.m.coords.get(cid)
            if coord is None:
                raise self.err(f"CONM1 {c.eid}: field CID: coordinate system {cid} not found")
            R = _axes_at(coord, self.xyz[g])
            B = np.zeros((6, 6))
            B[:3, :3] = B[3:, 3:] = R
            M = B @ M @ B.T
        return MassMatrix6(c.eid, g, M * wtmass)

    def _rbar(self, c) -> RigidRBE2:
        """RBAR as the rigid element it is when one end carries all six independent DOFs."""
        eid = c.eid
        ga, gb = self.rows([c.ga, c.gb], "RBAR", eid, "G")
        cna = _comps(c.cna, self.f, f"RBAR {eid}: field CNA")
        cnb = _comps(c.cnb, self.f, f"RBAR {eid}: field CNB")
        cma = _comps(c.cma, self.f, f"RBAR {eid}: field CMA")
        cmb = _comps(c.cmb, self.f, f"RBAR {eid}: field CMB")
        if not cma and not cmb:  # MSC QRG RBAR: blank CMA, CMB: all DOFs not in CNA, CNB
            cma = sorted(set(range(6)) - set(cna))
            cmb = sorted(set(range(6)) - set(cnb))
        if len(cna) == 6 and not cnb and not cma and cmb:
            return RigidRBE2(eid, ga, cmb, [gb])
        if len(cnb) == 6 and not cna and not cmb and cma:
            return RigidRBE2(eid, gb, cma, [ga])
        raise self.err(f"RBAR {eid}: fields CNA/CNB/CMA/CMB: only one end with all six "
                       f"independent components is supported, got CNA={c.cna!r}, CNB={c.cnb!r}, "
                       f"CMA={c.cma!r}, CMB={c.cmb!r}")

    def _rbe1(self, c) -> RigidRBE1:
        """RBE1: independent GN_i/CN_i (six components in all), dependent GM_j/CM_j (MSC QRG
        RBE1); the thermal coefficient ALPHA changes nothing here."""
        eid = c.eid

        def pairs(grids, comps, g_field, c_field):
            out = []
            rows = self.rows(grids, "RBE1", eid, g_field)
            for row, comp in zip(rows, comps):
                out += [(row, k) for k in _comps(comp, self.f, f"RBE1 {eid}: field {c_field}")]
            return out

        independent = pairs(c.Gni, c.Cni, "GN", "CN")
        if len(independent) != 6:
            raise self.err(f"RBE1 {eid}: fields CN: expected six independent components in all, "
                           f"got {len(independent)}")
        dependent = pairs(c.Gmi, c.Cmi, "GM", "CM")
        both = sorted(set(independent) & set(dependent))
        if both:
            g, k = both[0]
            raise self.err(f"RBE1 {eid}: grid {int(self.ids[g])} component {k + 1} is both "
                           "independent (CN) and dependent (CM)")
        return RigidRBE1(eid, independent, dependent)

    def _mpcs(self, mesh: Mesh) -> None:
        """MPC/MPCADD of the case control's MPC set (or the only one)."""
        ids = sorted(set(self.m.mpcs) | set(self.m.mpcadds))
        sid = self._case_value("MPC")
        top = sorted(self.m.mpcadds) or ids  # without case control: the only MPCADD, or MPC
        if sid is None and len(top) > 1:
            raise self.err(f"several MPC sets {ids} and no MPC in the case control")
        if sid is None and top:
            sid = top[0]
        if sid is None:
            return
        if sid not in ids:
            if ids:
                raise self.err(f"case control MPC = {sid}: no MPC/MPCADD with that ID (the deck "
                               f"has {ids})")
            self.notes.append(f"case control MPC = {sid}: the deck has no MPC cards; none applied "
                              "(as Nastran, which warns)")
            return
        sets, stack = [], [sid]
        while stack:
            s = stack.pop()
            if s in sets:
                raise self.err(f"MPCADD {sid}: set {s} is referenced twice")
            sets.append(s)
            for add in self.m.mpcadds.get(s, []):
                for x in add.sets:
                    if x not in self.m.mpcs and x not in self.m.mpcadds:
                        raise self.err(f"MPCADD {s}: field S: MPC set {x} not found")
                    stack.append(x)
        for s in sets:
            for card in self.m.mpcs.get(s, []):
                terms = []
                for nid, comp, a in zip(card.nodes, card.components, card.coefficients):
                    (g,) = self.rows([nid], "MPC", s, "G")
                    cs = self.scalar_components(nid, comp, f"MPC {s}: field C")
                    if len(cs) != 1:
                        raise self.err(f"MPC {s}: grid {nid}: field C: expected one component, "
                                       f"got {comp!r}")
                    terms.append((float(a), g, cs[0]))
                if not terms or terms[0][0] == 0.0:
                    raise self.err(f"MPC {s}: field A1: the dependent term needs a non-zero "
                                   "coefficient")
                mesh.mpc.append(LinearMPC(s, terms))
