"""The paper study by harmonic balance (``torchrom paper --method hb``): what it adds.

- :func:`newmark_confirmation`: a subset of the HB table (the Fig. 11 cases and the largest
  LCO of every curve) run by the time integrator at the paper's step, *started on the HB
  orbit* (the sweep's own, :func:`torchrom.study.cases.orbit_table`), for a few periods: the
  amplitude and frequency it keeps beside HB's, and how much its amplitude still changes per
  cycle (an orbit that is not a periodic solution of the time-discrete equations drifts). Its
  histories are Fig. 11 in this mode.
- :func:`goland_branches`: the LCO branches in altitude from the flutter (Hopf) point down to
  4,000 ft for γ = 0 and 1e-3 s (matched α), with Floquet stability, folds flagged.
Orchestration over :mod:`torchrom.periodic` and :mod:`torchrom.study`.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np
import pandas as pd
import torch

from ..periodic import BranchOptions
from ..periodic.solve import orbit_state
from ..sim import HistoryRequest
from ..study.branch import run_branches
from ..study.cases import case_system, history_table, orbits_of

#: periods of the confirming time integration (LCO metrics from its last cycles)
CONFIRMATION_PERIODS = 12
#: the branches of the report: γ (s) with the matched α, altitude bounds (ft)
BRANCH_GAMMAS = (0.0, 1e-3)
BRANCH_BOUNDS_FT = (4000.0, 12000.0)


def confirmation_cases(cfg, table: pd.DataFrame) -> list[int]:
    """Rows of the HB table to confirm: the ``[history]`` cases and, per curve (γ and
    nonlinearity switches), the LCO at the lowest altitude (the largest orbit)."""
    rows = set(cfg.history.indices(cfg.cases)) if cfg.history is not None else set()
    lco = table[table["status"] == "lco"]
    for _, grp in lco.groupby(["gamma", "stiffness_nl", "damping_nl"], dropna=False):
        rows.add(int(grp["altitude_ft"].idxmin()))
    return sorted(rows)


def newmark_confirmation(cfg, model, table: pd.DataFrame, orbits: pd.DataFrame, device="cpu"
                         ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(comparison, histories) for :func:`confirmation_cases` (module docstring), each started
    on its orbit in ``orbits`` (the sweep's, :func:`torchrom.study.cases.orbit_table`; a case
    without one starts at rest); histories carry the HB table's case ids (Fig. 11)."""
    idx = confirmation_cases(cfg, table)
    if not idx:
        return pd.DataFrame(), pd.DataFrame()
    cases = [cfg.cases[i] for i in idx]
    system, _ = case_system(model, cases, torch.device(device), torch.float64)
    X, omega = orbits_of(orbits, [table["case_id"][i] for i in idx], system.n)
    # at rest where there is no orbit (ω NaN would make the lag states NaN)
    has = np.isfinite(omega)
    X[~has] = 0.0
    q0, v0, xi0 = orbit_state(system, torch.as_tensor(X, dtype=system.dtype),
                              torch.as_tensor(np.where(has, omega, 1.0), dtype=system.dtype))
    periods = 2 * np.pi / np.nanmax(omega)
    t_end = CONFIRMATION_PERIODS * float(periods)
    integ = cfg.integrator
    res = integ.run(system, q0, v0, xi0, t_end=t_end, outputs=cfg.outputs,
                    lco=dataclasses.replace(cfg.lco, stop=False, cycles=4),
                    history=HistoryRequest(tuple(range(len(idx))), 5))
    ids = [table["case_id"][i] for i in idx]
    rows = []
    for k, i in enumerate(idx):
        a_hb = float(table["amplitude"][i])
        f_hb = float(table["frequency_hz"][i])
        a_nm = float(res.amplitude[k, 0])
        f_nm = float(res.frequency_hz[k])
        rows.append({"case_id": ids[k], **{p: table[p][i] for p in
                                            ("altitude_ft", "gamma", "stiffness_nl",
                                             "damping_nl")},
                     "hb_status": table["status"][i], "hb_amplitude": a_hb,
                     "hb_frequency_hz": f_hb, "harmonics": int(table["harmonics"][i]),
                     "newmark_status": str(res.status[k]), "newmark_amplitude": a_nm,
                     "newmark_frequency_hz": f_nm,
                     "amplitude_diff_pct": 100 * (a_nm / a_hb - 1) if a_hb else np.nan,
                     "frequency_diff_pct": 100 * (f_nm / f_hb - 1) if f_hb else np.nan,
                     "newmark_amplitude_change": float(res.amplitude_change[k]),
                     "dt": integ.dt, "t_end": t_end})
    return pd.DataFrame(rows), history_table(res, ids)


def goland_branches(cfg, model, device="cpu", progress=None, log=None) -> pd.DataFrame:
    """The branch table of :data:`BRANCH_GAMMAS` in altitude over :data:`BRANCH_BOUNDS_FT`;
    ``progress(fraction)``: the share of the altitude range covered so far, ``log``: a line
    before the certificate (:func:`torchrom.study.branch.run_branches`)."""
    cases = [{"altitude_ft": BRANCH_BOUNDS_FT[1], "alpha": "matched", "gamma": g}
             for g in BRANCH_GAMMAS]
    bcfg = dataclasses.replace(cfg, cases=cases, history=None)
    # first step 0.05 (the default is 0.1): on the updated wing's quick ROM the γ = 0 branch
    # passes, at ~16 % of span, close to a singular point of the H = 5 equations (a branch point
    # of H = 5's near 5:1 resonance with the in-plane mode, where HB is not converged in H); from
    # 0.1 the step controller reached that point and its step fell below min_step (the branch
    # ended at 8,267 ft), or with a smaller min_step turned onto the crossing branch; from 0.05
    # the predictor steps over it and the branch reaches 4,000 ft without an event
    study = run_branches(bcfg, "altitude_ft", BranchOptions(bounds=BRANCH_BOUNDS_FT,
                                                            amplitude_scale=1.0, step=0.05,
                                                            max_amplitude=cfg.lco.max_amplitude),
                         model=model, device=device, progress=progress, log=log)
    return study.table


def branch_summary(branches: pd.DataFrame) -> list[dict[str, Any]]:
    """Per branch: γ, Hopf altitude and frequency, whether stable from the Hopf point, folds,
    unstable stretches, the amplitude at the lowest altitude."""
    out = []
    for b, grp in branches.groupby("branch"):
        grp = grp.sort_values("point")
        hopf = grp[grp["kind"] == "hopf"].iloc[0]
        lco = grp[grp["kind"] != "hopf"]
        low = lco.loc[lco["altitude_ft"].idxmin()] if len(lco) else None
        unstable = lco[lco["stable"] == False]  # noqa: E712 - nullable boolean column
        uncertified = lco[lco["status"] != "lco"]
        out.append({"branch": int(b), "gamma": float(hopf["gamma"]),
                    "hopf_altitude_ft": float(hopf["altitude_ft"]),
                    "hopf_frequency_hz": float(hopf["frequency_hz"]),
                    "stable_from_hopf": (None if not len(lco) or pd.isna(lco["stable"].iloc[0])
                                         else bool(lco["stable"].iloc[0])),
                    "folds_ft": [float(x) for x in grp.loc[grp["kind"] == "fold",
                                                           "fold_parameter"]],
                    "unstable_altitudes_ft": [float(x) for x in unstable["altitude_ft"]],
                    "uncertified_altitudes_ft": [float(x) for x in uncertified["altitude_ft"]],
                    "lowest_altitude_ft": float(low["altitude_ft"]) if low is not None else None,
                    "amplitude_pct_span_there": float(low["amplitude_pct_span"])
                    if low is not None and "amplitude_pct_span" in low else None,
                    "points": int(len(lco))})
    return out


__all__ = ["newmark_confirmation", "goland_branches", "branch_summary"]
