"""The Fig. 10 cases over admissible damping decompositions: an amplitude band per γ (issue 15).

The identified stiffness does not determine the damping tensors D̄2, D̄3 (:mod:`torchrom.identify.
damping`): every decomposition that reproduces the identified coefficients (Eqs. 16, 25–27),
keeps the Kelvin–Voigt structure and has a semidefinite extended matrix is admissible. The band
runs the damping check's Fig. 10 cases (:func:`torchrom.paper.study.damping_check_cases`) with
the members of :func:`torchrom.identify.damping_family.damping_family` between the study's
optimum decomposition (θ = 0) and the exact Kelvin–Voigt tensors of the FE material (θ = 1),
each member checked (:class:`~torchrom.identify.damping_family.DampingMember`: admissible
by the study's standard, and strictly), and reports per altitude and γ the smallest and largest
LCO amplitude, and per Fig. 10 finding whether it holds for every admissible member, for none,
or depends on the choice (and the same over the strict members). A further member, off the
segment, is the decomposition criterion's own optimum over the whole admissible set (the
semidefinite program of :func:`~torchrom.identify.damping_family.sdp_member`, passed in by the
study, which caches it per ROM). The ends are the main
study's and the exact damping check's tables when their tensors are the family's ends (to
1e-9); the members between are simulated here.

Over :mod:`torchrom.identify.damping_family` and :mod:`.findings`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import pandas as pd

from ..identify.damping_family import DampingMember, damping_family, restored_min_eigenvalue
from . import findings as fnd

#: θ of the family (0: the optimum decomposition, 1: the exact tensors), full and quick study
BAND_THETAS = {"full": (0.0, 0.25, 0.5, 0.75, 1.0), "quick": (0.0, 0.5, 1.0)}
#: the verdict of a finding over all members
HOLDS, FAILS, DEPENDS = "holds for every member", "fails for every member", "depends on the choice"
NOT_ASSESSABLE = "not assessable for some member"


def _same(a, b) -> bool:
    a, b = np.asarray(a), np.asarray(b)
    return float(np.abs(a - b).max()) <= 1e-9 * max(float(np.abs(b).max()), 1e-300)


def member_sweep(main, member: DampingMember) -> tuple[Any, str]:
    """(model, sweep name) of a damping member: the study's model with the member's damping
    tensors, and the folder its sweep of the check cases is cached in."""
    label = f"theta_{member.theta:g}" if np.isfinite(member.theta) else member.name
    return dataclasses.replace(main, rom=member.rom(main.rom)), f"lco_damping_{label}"


def decomposition_band(main, exact, thetas, end_tables: tuple[pd.DataFrame, pd.DataFrame],
                       run: Callable[[Any, str], pd.DataFrame],
                       extra: Sequence[DampingMember] = (),
                       family: Sequence[DampingMember] | None = None) -> dict[str, Any]:
    """The band (JSON-ready).

    ``main``, ``exact``: the study's model and the exact-damping model (same basis and
    stiffness); ``end_tables``: the damping check's cases simulated with each (reused when the
    family's end equals that model's tensors); ``run(model, name)``: simulates those cases with
    a model (the study's cached sweep); ``extra``: members off the family's segment (the SDP
    optimum), named uniquely; ``family``: the family's members at ``thetas`` where the caller
    has them already (:func:`~torchrom.identify.damping_family.damping_family` of the two
    models).
    """
    members = [*(family if family is not None
                 else damping_family(main.rom, main.rom, exact.rom, thetas)), *extra]
    ends = {0.0: (main.rom, end_tables[0]), 1.0: (exact.rom, end_tables[1])}
    tables, rows = [], []
    for m in members:
        end = ends.get(m.theta)
        if end is not None and all(_same(getattr(m, k), getattr(end[0], k).numpy())
                                   for k in ("D1", "D2", "D3")):
            table = end[1].copy()
        else:
            table = run(*member_sweep(main, m)).copy()
        table["member"], table["theta"] = m.name, m.theta
        tables.append(table)
        found = {f.key: f for f in fnd.fig10_acceptance(table)}
        rows.append({**m.summary(), "findings": {k: {"verdict": f.verdict, "ours": f.ours}
                                                 for k, f in found.items()}})
    all_t = pd.concat(tables, ignore_index=True)
    band = []
    for name, t in all_t.groupby("member", sort=False):
        C = fnd.curve_table(t, "amplitude_pct_span", lco_only=True)
        for h in C.index:
            for k in C.columns:
                band.append({"member": str(name), "altitude_ft": float(h), "curve": str(k),
                             "amplitude_pct_span": float(C.loc[h, k])})
    b = pd.DataFrame(band).dropna()
    spread = (b.groupby(["altitude_ft", "curve"], sort=False)["amplitude_pct_span"]
              .agg(["min", "max", "count"]).reset_index())
    return {"members": rows, "band": spread.to_dict(orient="records"),
            "findings": _over(rows, "admissible"), "findings_strict": _over(rows, "strict"),
            "admissible": all(r["admissible"] for r in rows),
            "decomposition_restored_min_eigenvalue": restored_min_eigenvalue(main.rom,
                                                                             main.rom)}


def _over(rows: list[dict[str, Any]], flag: str) -> dict[str, str]:
    """Each finding's verdict over the members with ``flag`` (admissible or strict)."""
    rows = [r for r in rows if r[flag]]
    out = {}
    for k in (rows[0]["findings"] if rows else []):
        verdicts = [r["findings"][k]["verdict"] for r in rows]
        out[k] = (HOLDS if all(v == fnd.AGREE for v in verdicts) else
                  FAILS if all(v == fnd.DIFFER for v in verdicts) else
                  NOT_ASSESSABLE if fnd.NA in verdicts else DEPENDS)
    return out
