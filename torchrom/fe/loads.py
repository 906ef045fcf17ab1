"""Static load sets from FORCE, MOMENT, PLOAD2, PLOAD4, GRAV and LOAD cards.

Every load set becomes a vector on the all-grid DOFs (basic axes); the FE model
projects it on the free DOFs with Tᵀ (so a load on an RBE-dependent grid is distributed to the
independent ones, and a load on a constrained DOF is dropped). Pressures give consistent nodal
forces along the element normal (G1-G2-G3 right-hand rule) or along the PLOAD4 direction vector.
GRAV (MSC QRG GRAV: acceleration a = A N, N not normalised, in system CID) loads the mass matrix
of the model (:func:`torchrom.fe.model.assemble_mass`: elements, CONM1/CONM2/CMASS, WTMASS
applied) with the rigid translation a of every grid, f = M ā (ā: a on each grid's
translations, none on its rotations or on SPOINTs), so that offset masses also get their
moments. All loads are dead loads (not following the deformation).
"""

from __future__ import annotations

import numpy as np

from .coords import axes_at
from .elements.quad4 import pressure_forces
from .mesh import Mesh


class _Enforced(Exception):
    """A load set with an SPCD (enforced motion), which torchrom does not model."""


class LoadBuilder:
    def __init__(self, reader, mesh: Mesh):
        self.r = reader
        self.m = reader.m
        self.mesh = mesh
        self.n_all = mesh.n_grid * 6
        self._mass = None  # all-DOF mass matrix, assembled for the first GRAV
        self.surface = {}  # eid -> grid rows of CQUAD4/CSHEAR
        for nodes_set in (mesh.quads, mesh.shears):
            for eid, nodes in zip(nodes_set.eids, nodes_set.nodes):
                self.surface[int(eid)] = nodes

    def all(self) -> dict[int, np.ndarray]:
        """Every load set; a set with an SPCD (enforced motion: noted, not modelled) is left
        out, so that a static solve of it is refused as a set not found."""
        out = {}
        for sid in sorted(set(self.m.loads) | set(self.m.load_combinations)):
            try:
                out[sid] = self.vector(sid, set())
            except _Enforced:
                continue
        return out

    def vector(self, sid: int, seen: set) -> np.ndarray:
        if sid in seen:
            raise self.r.err(f"LOAD {sid}: refers to itself")
        seen = seen | {sid}
        f = np.zeros(self.n_all)
        for card in self.m.loads.get(sid, []):
            if card.type == "SPCD":
                raise _Enforced(sid)
            self._card(card, sid, f)
        for combo in self.m.load_combinations.get(sid, []):
            if combo.type == "LSEQ":  # pyNastran files LSEQ here: dynamic loads only (noted)
                continue
            for scale, lid in zip(combo.scale_factors, combo.load_ids):
                if lid not in self.m.loads and lid not in self.m.load_combinations:
                    raise self.r.err(f"LOAD {sid}: field L: load set {lid} not found")
                f += combo.scale * scale * self.vector(lid, seen)
        return f

    def _direction(self, cid: int, vec, point, card: str, sid: int) -> np.ndarray:
        if cid in (0, None):
            return np.asarray(vec, dtype=float)
        coord = self.m.coords.get(cid)
        if coord is None:
            raise self.r.err(f"{card} {sid}: field CID: coordinate system {cid} not found")
        return axes_at(coord, point) @ np.asarray(vec, dtype=float)

    def _card(self, card, sid: int, f: np.ndarray) -> None:
        kind = card.type
        if kind in ("FORCE", "MOMENT"):
            (g,) = self.r.rows([card.node], kind, sid, "G")
            vec = card.mag * self._direction(card.cid, card.xyz, self.mesh.xyz[g], kind, sid)
            base = g * 6 + (0 if kind == "FORCE" else 3)
            f[base : base + 3] += vec
        elif kind in ("PLOAD2", "PLOAD4"):
            eids = list(card.eids)
            for eid in eids:
                if eid not in self.surface:
                    raise self.r.err(f"{kind} {sid}: field EID: element {eid} is not a CQUAD4 "
                                     "or CSHEAR of the model")
            nodes = np.array([self.surface[e] for e in eids], dtype=int).reshape(-1, 4)
            corner = direction = None
            p = 0.0
            if kind == "PLOAD2":
                p = float(card.pressure)
            else:
                if card.g1 not in (None, 0) or card.g34 not in (None, 0):
                    raise self.r.err(f"PLOAD4 {sid}: fields G1/G3: solid faces are not supported")
                if str(card.surf_or_line).upper() != "SURF":
                    raise self.r.err(f"PLOAD4 {sid}: field SORL: only SURF is supported")
                pr = np.array([np.nan if x is None else x for x in card.pressures], float)
                pr = np.where(np.isnan(pr), pr[0], pr)
                corner = np.tile(pr, (len(eids), 1))
                nvec = np.asarray(card.nvector, dtype=float)
                if np.linalg.norm(nvec) > 0:
                    centre = self.mesh.xyz[nodes].mean(axis=1)
                    direction = np.array(
                        [self._direction(card.cid, nvec, c, kind, sid) for c in centre]
                    )
                    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
            dofs, F = pressure_forces(self.mesh.xyz, nodes, p, corner, direction)
            np.add.at(f, dofs.reshape(-1), F.reshape(-1))
        elif kind == "GRAV":
            f += self._gravity(card, sid)
        else:
            raise self.r.err(f"{kind} {sid}: static load card not supported")

    def _gravity(self, card, sid: int) -> np.ndarray:
        """f = M ā of a GRAV card (module docstring)."""
        if self._mass is None:
            from .model import assemble_mass

            self._mass = assemble_mass(self.mesh)
        a = float(card.scale) * self._direction(card.cid, card.N, np.zeros(3), "GRAV", sid)
        field = np.zeros((self.mesh.n_grid, 6))
        n_grids = self.mesh.n_grid - len(getattr(self.r, "spoints", []))
        field[:n_grids, :3] = a
        return self._mass @ field.reshape(-1)
