"""The aerodynamic cards a Nastran user writes for a wing, from its planform: an include file.

:func:`panel_model` builds them with pyNastran (its card classes check the fields; its writer
formats them): a CORD2R for the aerodynamic system (x along the flow, z up: Nastran's ACSID
convention), AERO (reference chord, sea-level density in the deck's units), one CAERO1 +
PAERO1 per straight segment of the :class:`~torchrom.aero.outline.Planform`, one SPLINE1
(infinite-plate) per CAERO1 onto a SET1 of structural grids, MKAERO1 reduced frequencies and
a PK FLUTTER with its FLFACTs. Ids start above the deck's own so that the file can be
INCLUDEd in it unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .outline import Planform

#: MKAERO1 reduced frequencies (b = REFC/2): from quasi-steady to a fast torsion mode
DEFAULT_K = (0.001, 0.01, 0.03, 0.06, 0.1, 0.15, 0.2, 0.3, 0.45, 0.6, 0.8, 1.0, 1.5, 2.0)


@dataclass(frozen=True)
class PanelOptions:
    """Box counts and flight cards: ``n_chord`` boxes chordwise; spanwise boxes per segment
    in proportion to its length, ``n_span`` in all (at least one per segment); MKAERO1 at
    ``machs`` and ``k``; FLUTTER PK at ``velocities`` (deck units), density ratio 1 of
    ``rho_ref``; ``lmodes``: a PARAM LMODES (the modes of the flutter solution) for a deck
    without EIGRL/LMODES; ``symxz``: AERO SYMXZ (1: the root's plane, the aerodynamic
    system's x-z plane, is a plane of symmetry: a half aircraft or a wall-mounted wing)."""

    n_chord: int = 8
    n_span: int = 24
    machs: tuple[float, ...] = (0.0,)
    k: tuple[float, ...] = DEFAULT_K
    velocities: tuple[float, ...] = ()
    rho_ref: float = 1.0
    first_id: int = 1
    lmodes: int | None = None
    symxz: int = 1
    comment: list[str] = field(default_factory=list)


def _spanwise_boxes(lengths: np.ndarray, n_span: int) -> list[int]:
    share = lengths / lengths.sum() * n_span
    return [max(1, int(round(x))) for x in share]


def panel_model(plan: Planform, origin, flow, up, span, grid_ids, opts: PanelOptions):
    """A pyNastran BDF holding the cards (module docstring). ``origin``, ``flow``, ``up``:
    the aerodynamic system's origin and x, z axes in basic; ``span``: the planform's span
    direction (root to tip, basic: ±y of that system); ``grid_ids``: the SET1 of the
    splines (structural grids, one per planform position)."""
    from pyNastran.bdf.bdf import BDF

    flow, up = np.asarray(flow, float), np.asarray(up, float)
    o = np.asarray(origin, float)
    y_axis = np.cross(up, flow)
    m = BDF(debug=None)
    base = int(opts.first_id)
    acsid = base
    m.add_cord2r(acsid, o, o + up, o + flow, rid=0, comment="aerodynamic system: x = flow, "
                                                             "z = up")
    m.add_aero(velocity=1.0, cref=plan.mean_chord, rho_ref=opts.rho_ref, acsid=acsid,
               sym_xz=int(opts.symxz),
               comment="reference chord: planform area / span; RHOREF: sea-level density")
    pid = base
    m.add_paero1(pid)
    sid = base
    m.add_set1(sid, [int(g) for g in grid_ids], comment="structural grids of the splines")
    spans = np.diff(plan.s)
    n_boxes = _spanwise_boxes(np.abs(spans), opts.n_span)
    sign = 1.0 if np.dot(np.asarray(span, float), y_axis) > 0 else -1.0  # a left wing: -y
    eid = base
    scale = max(float(np.ptp(plan.s)), 1e-300)

    def snap(x):  # 8-character fields: rounding below 1e-7 of the span written as 0
        return np.where(np.abs(x) < 1e-7 * scale, 0.0, x)

    for i, nspan in enumerate(n_boxes):
        a, b = i, i + 1
        # Nastran numbers boxes from P1 (inboard for a right wing): the end with smaller y
        p_a = snap(np.array([plan.le[a], sign * plan.s[a], plan.n[a]]))
        p_b = snap(np.array([plan.le[b], sign * plan.s[b], plan.n[b]]))
        (p1, c1), (p4, c4) = sorted([(p_a, plan.chord[a]), (p_b, plan.chord[b])],
                                    key=lambda pc: pc[0][1])
        m.add_caero1(eid, pid, igroup=1, p1=p1, x12=float(c1), p4=p4, x43=float(c4),
                     cp=acsid, nspan=int(nspan), nchord=int(opts.n_chord),
                     comment=f"segment {i + 1}: span {plan.s[a]:.6g} .. {plan.s[b]:.6g}")
        n = int(nspan) * int(opts.n_chord)
        m.add_spline1(eid, eid, eid, eid + n - 1, sid)
        eid = (eid + n) // 1000 * 1000 + 1000  # the next CAERO1 starts at a round id
    ks = list(opts.k)
    for j in range(0, len(ks), 8):
        m.add_mkaero1(list(opts.machs), ks[j:j + 8])
    if opts.velocities:
        m.add_flfact(base, [1.0], comment="density ratio (of AERO RHOREF)")
        m.add_flfact(base + 1, [float(opts.machs[0])], comment="Mach number")
        m.add_flfact(base + 2, [float(v) for v in opts.velocities], comment="velocities")
        m.add_flutter(base, "PK", base, base + 1, base + 2, imethod="L", nvalue=None)
    if opts.lmodes:
        m.add_param("LMODES", [int(opts.lmodes)], comment="modes of the flutter solution")
    return m


def write_panel_cards(path, model, header: list[str]) -> None:
    """The cards of ``model`` as an include file (bulk data only, no BEGIN BULK/ENDDATA),
    ``header`` lines as comments first."""
    import io

    buf = io.StringIO()
    model.write_bdf(buf, write_header=False, enddata=False, close=False)
    text = buf.getvalue()
    lines = [f"$ {h}" for h in header] + [ln for ln in text.splitlines()
                                          if ln.strip().upper() not in ("BEGIN BULK",)]
    from ..io import write_text_atomic

    write_text_atomic(path, "\n".join(lines) + "\n")
