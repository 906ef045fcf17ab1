"""Which Nastran cards the FE reader uses, accepts with a note, or refuses — and why.

Tables (the card semantics are Nastran's, MSC Quick Reference Guide) and the GRDSET
defaults. Kept apart from :mod:`torchrom.fe.bdf_read` so that the card lists and their reasons
are in one place: the reader's error message, its notes and the README all come from here.

- ``NOTED_CARDS``: cards that change nothing in a normal-modes or flutter solution; they are
  accepted and each kind present is named in ``FEModel.notes`` with the reason.
- ``REFUSED_REASONS``: cards known to change the solution but not (yet) modelled, with the
  reason printed next to the card name and count in the unsupported-card message.
"""

from __future__ import annotations

NOTED_CARDS: dict[str, str] = {
    "MDLPRM": "model parameters (memory, solver and output options)",
    "MAT4": "thermal conductivity: used only by heat transfer and thermal loads",
    "MAT5": "anisotropic thermal conductivity: heat transfer only",
    "USET": "user DOF sets: output/partitioning labels only",
    "USET1": "user DOF sets: output/partitioning labels only",
    "DESVAR": "SOL 200 design variable: the analysis uses the deck's cards, which (SOL 200) "
    "must agree with the design relations at XINIT (torchrom.fe.design)",
    "DVPREL1": "SOL 200 property relation: checked against the card at XINIT (SOL 200)",
    "DVPREL2": "SOL 200 property relation (equation): not evaluated, noted per relation",
    "DVMREL1": "SOL 200 material relation: checked against the card at XINIT (SOL 200)",
    "DVGRID": "SOL 200 shape variable: the analysis uses the deck's current geometry",
    "DRESP1": "SOL 200 response: optimisation output only",
    "DRESP2": "SOL 200 response: optimisation output only",
    "DCONSTR": "SOL 200 constraint: optimisation only",
    "DCONADD": "SOL 200 constraint set: optimisation only",
    "DSCREEN": "SOL 200 screening: optimisation only",
    "DOPTPRM": "SOL 200 optimiser parameters: optimisation only",
    "DLINK": "SOL 200 design-variable link: optimisation only",
    "DEQATN": "equations for SOL 200 responses: optimisation only",
    "DTABLE": "SOL 200 constants: optimisation only",
    "SUPORT": "rigid-body modes are found by a shifted eigensolver and, for flutter, rebuilt "
    "as the rigid motions the constraints admit (the span SUPORT's r-set gives Nastran); "
    "flutter notes whether the r-set is statically determinate for them",
    "SUPORT1": "rigid-body modes are found by a shifted eigensolver and, for flutter, rebuilt "
    "as the rigid motions the constraints admit (the span SUPORT1's r-set gives Nastran); "
    "flutter notes whether the r-set is statically determinate for them",
    "DAREA": "dynamic load scale factor: frequency/transient response only",
    "DLOAD": "dynamic load combination: frequency/transient response only",
    "RLOAD1": "frequency-response load: frequency response only",
    "RLOAD2": "frequency-response load: frequency response only",
    "TLOAD1": "transient load: transient response only",
    "TLOAD2": "transient load: transient response only",
    "FREQ": "response frequencies: frequency response only",
    "FREQ1": "response frequencies: frequency response only",
    "FREQ2": "response frequencies: frequency response only",
    "LSEQ": "static load set for dynamic loads (DAREA/EXCITEID): dynamic response only",
    "SPCD": "enforced motion of constrained DOFs: a load of static/dynamic response (the DOFs "
    "stay constrained by the SPC set, so the real modes do not change); a load set with an "
    "SPCD is not available to torchrom's static solves",
    "TABLED1": "load table: dynamic response only",
    "TABLED2": "load table: dynamic response only",
    "TABRND1": "power spectral density table: random response only",
    "RANDPS": "power spectral density: random response only",
    "MONPNT3": "monitor point: output only",
    "MONPNT2": "monitor point: output only",
    "MONDSP1": "displacement monitor point: output only",
    "AECOMP": "aerodynamic component for monitor points: output only",
    "AECOMPL": "aerodynamic component list for monitor points: output only",
    "TEMPD": "default temperature: no thermal loads in modes/flutter",
    "TEMP": "temperatures: no thermal loads in modes/flutter",
    "EPOINT": "extra points: dynamic response and transfer functions only, not in the real "
    "eigenvalue problem",
    "TF": "transfer functions (case control TFL): dynamic response and complex modes only, not "
    "the real eigenvalue problem",
    "DMIG": "direct matrix input selected for the p-set (K2PP/M2PP/B2PP): dynamic response and "
    "flutter in Nastran, not the real modes (a g-set selection, K2GG/M2GG, is refused)",
    "PLOTEL": "plot-only element (no stiffness, no mass)",
    "CORD3G": "coordinate system not referenced by a structural card",
}

REFUSED_REASONS: dict[str, str] = {
    "CTRIA6": "quadratic shell not implemented",
    "CQUAD8": "quadratic shell not implemented",
    "PCOMPG": "composite laminate not implemented",
    "MAT2": "anisotropic shell material not implemented",
    "MAT9": "anisotropic solid material not implemented",
    "CELAS3": "scalar-point spring not implemented",
    "CELAS4": "scalar-point spring not implemented",
    "CDAMP1": "viscous damper not implemented (no effect on real modes; flutter would need it)",
    "CDAMP2": "viscous damper not implemented (no effect on real modes; flutter would need it)",
}


#: case-control entries that would add DMIG matrices to the structure's own K or M
GSET_MATRICES = ("K2GG", "M2GG", "B2GG", "K42GG")


def refuse_gset_matrices(model, fname: str) -> None:
    """DMIG is noted only while no case control adds it to the g-set (K2GG, M2GG, ...)."""
    from ..errors import InputError

    cc = model.case_control_deck
    if cc is None:
        return
    for isub in sorted(cc.subcases):
        for key in GSET_MATRICES:
            if key in cc.subcases[isub].params:
                raise InputError(f"{fname}: case control {key}: direct matrix input on the "
                                 "structure (g-set) is not supported")


def reason(card: str) -> str:
    """Why an unsupported card is refused (a generic reason for cards not in the table)."""
    return REFUSED_REASONS.get(card, "not read by the FE reader")


def apply_grdset(model) -> None:
    """Give GRIDs that leave CP, CD or PS blank the GRDSET defaults (in place).

    pyNastran reads a blank CP/CD as 0 and a blank PS as ''; as in its own cross-referencing, a
    0 is taken as blank (Nastran uses GRDSET only for blank fields: an explicit 0 cannot be told
    apart after parsing). Idempotent.
    """
    gs = getattr(model, "grdset", None)
    if gs is None:
        return
    cp, cd, ps = int(gs.cp or 0), int(gs.cd or 0), gs.ps or ""
    for node in model.nodes.values():
        if cp and not node.cp:
            node.cp = cp
        if cd and not node.cd:
            node.cd = cd
        if ps and not node.ps:
            node.ps = str(ps)
