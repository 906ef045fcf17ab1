"""Bifurcation character of limit cycles from a batched sweep over initial amplitudes.

Classification; the simulations go through any ``evaluate(cases) -> table``
(e.g. :func:`torchrom.study.sweep.case_evaluator`, in-process or on Dask workers).

At each *control* case (e.g. an altitude around flutter, or a value of α) the same initial
pattern is started at many amplitudes ``q0`` (the ``q0`` case parameter scales the ``[initial]``
displacement), all in one batch. Each run ends on an attractor:

- ``rest``: the motion decays (status ``decay``);
- ``lco``: a limit cycle (status ``lco``); LCO amplitudes within ``same_rtol`` of each other
  are one attractor;
- ``unbounded``: the motion grows without bound (status ``diverged``);
- ``undecided`` (``unconverged``/``failed``): no evidence either way.

Between neighbouring initial amplitudes that end on different attractors lies the boundary of
their basins; for a single mode it is the unstable LCO that separates them. Every such bracket
is refined in ``refine`` more batched rounds (``points`` new amplitudes per bracket and round,
log-spaced); the threshold is the geometric midpoint of the final bracket.

Per control the **local picture** is ``stable`` (every run decays), ``lco`` (every run reaches
the same LCO: from below and from above), ``unbounded``, ``bistable`` (a stable rest state
coexisting with an LCO or unbounded growth, separated by a threshold), ``multiple lco`` or
``undecided``. The **character** over all controls:

- ``subcritical`` when an attractor coexists with another anywhere (``bistable`` or ``multiple
  lco``): the amplitude jumps at onset and the system shows hysteresis — a large enough
  disturbance sustains (or blows up) the motion where a small one decays;
- ``supercritical`` when LCOs exist and at every control a single attractor is reached from
  every initial amplitude (each LCO grows continuously from the stable state);
- ``no lco`` when every run decays; ``undetermined`` otherwise.
The ``evidence`` sentence names the controls and amplitudes behind the verdict.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from ..errors import InputError
from .grid import case_label

Evaluate = Callable[[list[dict[str, Any]]], pd.DataFrame]
_OUTCOME = {"decay": "rest", "lco": "lco", "diverged": "unbounded"}


@dataclass
class BifurcationResult:
    """``runs``: every simulation (control index, q0, status, amplitude, attractor);
    ``summary``: one row per control; ``character`` and ``evidence``: the verdict."""

    runs: pd.DataFrame
    summary: pd.DataFrame
    character: str
    evidence: str


def label_attractors(status: Sequence[str], amplitude: Sequence[float],
                     same_rtol: float = 0.02) -> list[str]:
    """Attractor label per run: 'rest', 'unbounded', 'undecided' or 'lco<k>' where LCOs whose
    amplitudes differ by at most ``same_rtol`` (relative) share k (numbered by amplitude)."""
    status = list(status)
    amp = np.asarray(amplitude, dtype=float)
    labels = [_OUTCOME.get(s, "undecided") for s in status]
    lco = [i for i, s in enumerate(labels) if s == "lco"]
    order = sorted(lco, key=lambda i: amp[i])
    k, last = 0, None
    for i in order:
        if last is not None and amp[i] > last * (1 + same_rtol):
            k += 1
        labels[i] = f"lco{k}"
        last = amp[i]
    return labels


def _transitions(q0: np.ndarray, labels: list[str]) -> list[tuple[float, float, str, str]]:
    """(q0 low, q0 high, attractor below, attractor above) where neighbours differ (runs sorted
    by q0; undecided runs are skipped)."""
    decided = [(q, lab) for q, lab in zip(q0, labels) if lab != "undecided"]
    return [(a, b, la, lb) for (a, la), (b, lb) in zip(decided, decided[1:]) if la != lb]


def _local(labels: set[str]) -> str:
    lcos = {lab for lab in labels if lab.startswith("lco")}
    decided = labels - {"undecided"}
    if not decided:
        return "undecided"
    if decided == {"rest"}:
        return "stable"
    if decided == {"unbounded"}:
        return "unbounded"
    if len(lcos) > 1:
        return "multiple lco"
    if "rest" in decided:
        return "bistable"
    if decided == lcos:
        return "lco"
    return "lco + unbounded"


def _control_label(control: dict[str, Any], keys: Sequence[str]) -> str:
    return case_label(control, keys, empty="the case")


def bifurcation_sweep(evaluate: Evaluate, controls: Sequence[dict[str, Any]],
                      q0_values: Sequence[float], *, refine: int = 2, points: int = 8,
                      same_rtol: float = 0.02, initial_scale: float = 1.0,
                      log: Callable[[str], None] | None = None) -> BifurcationResult:
    """Classify the LCOs of ``controls`` (see the module docstring).

    Args:
        evaluate: cases -> table with ``status`` and ``amplitude`` per case, in order.
        controls: the control cases (their own ``q0`` is replaced).
        q0_values: initial amplitudes of the first batch (positive; log-spaced works best).
        refine, points: refinement rounds of every basin boundary, new amplitudes per round.
        same_rtol: LCO amplitudes closer than this (relative) are one attractor.
        initial_scale: the decision output's initial value per unit q0 (|C q0-pattern|), so
            that ``initial_amplitude`` (runs) and ``threshold_amplitude`` (summary) are in the
            units of the LCO amplitudes (1 for a single mode observed directly).
    """
    q0_values = sorted(float(q) for q in q0_values)
    if len(q0_values) < 2 or q0_values[0] <= 0:
        raise InputError(f"q0 values: expected at least two positive initial amplitudes, got "
                         f"{q0_values}")
    log = log or (lambda _m: None)
    controls = [{k: v for k, v in c.items() if k != "q0"} for c in controls]
    frames: list[pd.DataFrame] = []

    def run(requests: list[tuple[int, float]], round_no: int) -> None:
        cases = [{**controls[c], "q0": q} for c, q in requests]
        table = evaluate(cases).reset_index(drop=True)
        table["control"] = [c for c, _ in requests]
        table["q0"] = [q for _, q in requests]
        table["initial_amplitude"] = table["q0"] * initial_scale
        table["round"] = round_no
        frames.append(table)

    def labelled(c: int) -> pd.DataFrame:
        allr = pd.concat(frames, ignore_index=True)
        mine = allr[allr["control"] == c].sort_values("q0").drop_duplicates("q0")
        return mine.assign(attractor=label_attractors(mine["status"], mine["amplitude"],
                                                      same_rtol))

    log(f"bifurcation: {len(controls)} control case(s) x {len(q0_values)} initial amplitudes")
    run([(c, q) for c in range(len(controls)) for q in q0_values], 0)
    for r in range(1, refine + 1):
        requests = []
        for c in range(len(controls)):
            mine = labelled(c)
            for lo, hi, _, _ in _transitions(mine["q0"].to_numpy(), list(mine["attractor"])):
                requests += [(c, float(q)) for q in np.geomspace(lo, hi, points + 2)[1:-1]]
        if not requests:
            break
        log(f"bifurcation: round {r}: {len(requests)} runs at basin boundaries")
        run(requests, r)

    keys = [k for k in dict.fromkeys(k for c in controls for k in c)
            if len({repr(c.get(k)) for c in controls}) > 1]
    rows, runs = [], []
    for c, control in enumerate(controls):
        mine = labelled(c)
        runs.append(mine)
        labels = list(mine["attractor"])
        trans = _transitions(mine["q0"].to_numpy(), labels)
        lco_amp = mine.loc[mine["status"] == "lco", "amplitude"]
        rest_first = [t for t in trans if t[2] == "rest"]
        lo, hi = (rest_first[0][0], rest_first[0][1]) if rest_first else (math.nan, math.nan)
        attractors = []
        for lab in dict.fromkeys(labels):
            sel = mine[mine["attractor"] == lab]
            text = lab if not lab.startswith("lco") else f"lco {sel['amplitude'].mean():.4g}"
            attractors.append(f"{text} (q0 {sel['q0'].min():.3g}..{sel['q0'].max():.3g})")
        rows.append({**control, "local": _local(set(labels)), "attractors": "; ".join(attractors),
                     "runs": len(mine), "decay": int((mine["status"] == "decay").sum()),
                     "lco": int((mine["status"] == "lco").sum()),
                     "diverged": int((mine["status"] == "diverged").sum()),
                     "undecided": int((mine["attractor"] == "undecided").sum()),
                     "lco_amplitude_min": lco_amp.min() if len(lco_amp) else math.nan,
                     "lco_amplitude_max": lco_amp.max() if len(lco_amp) else math.nan,
                     "threshold_q0": math.sqrt(lo * hi) if rest_first else math.nan,
                     "threshold_low": lo, "threshold_high": hi,
                     "threshold_amplitude": math.sqrt(lo * hi) * initial_scale
                     if rest_first else math.nan,
                     "q0_min": mine["q0"].min(), "q0_max": mine["q0"].max()})
    summary = pd.DataFrame(rows)
    character, evidence = _verdict(summary, controls, keys)
    return BifurcationResult(pd.concat(runs, ignore_index=True), summary, character, evidence)


def _verdict(summary: pd.DataFrame, controls, keys) -> tuple[str, str]:
    local = summary["local"].tolist()
    where = {kind: [_control_label(controls[i], keys) for i, k in enumerate(local) if k == kind]
             for kind in set(local)}
    coexisting = [i for i, k in enumerate(local) if k in ("bistable", "multiple lco")]
    if coexisting:
        parts = []
        for i in coexisting:
            row = summary.iloc[i]
            extra = (f", threshold q0 = {row['threshold_q0']:.4g} "
                     f"({row['threshold_low']:.4g}..{row['threshold_high']:.4g})"
                     if math.isfinite(row["threshold_q0"]) else "")
            parts.append(f"[{_control_label(controls[i], keys)}] {row['attractors']}{extra}")
        return "subcritical", ("coexisting attractors (hysteresis): " + " | ".join(parts))
    if "lco" in where:
        lco_rows = summary[summary["local"] == "lco"]
        spread = (lco_rows["lco_amplitude_max"] / lco_rows["lco_amplitude_min"] - 1).max()
        text = (f"one LCO from every initial amplitude at {len(lco_rows)} control(s) "
                f"({'; '.join(where['lco'])}; largest spread over initial amplitudes "
                f"{100 * spread:.2g} %, q0 {summary['q0_min'].min():.3g}.."
                f"{summary['q0_max'].max():.3g})")
        if "stable" in where:
            text += f"; every run decays at {'; '.join(where['stable'])}"
        others = sorted(set(where) - {"lco", "stable"})
        if others:
            text += f"; also {', '.join(others)}"
            return "undetermined", text
        return "supercritical", text
    if set(where) == {"stable"}:
        return "no lco", "every run decays at every control"
    return "undetermined", "; ".join(f"{k}: {', '.join(v)}" for k, v in sorted(where.items()))
