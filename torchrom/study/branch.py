"""Branch studies: LCO branches in one case parameter from the Hopf (flutter) point.

Each distinct case of a configuration, with the branch parameter removed, is one branch (e.g.
``gamma = [0.0, 1e-3]`` with the parameter ``altitude_ft``: two branches). The branches are
followed together by :func:`torchrom.periodic.follow_branches` over the model's per-case systems
(:func:`torchrom.study.cases.case_system`: the atmosphere, a matched α, … are recomputed at every
parameter value), and every point becomes a row of the *branch table*:

``branch`` (0-based), ``point`` (0 = the Hopf point), ``kind`` (hopf, regular, fold,
branch_point, end), the branch's case parameters with the parameter's value, ``status``
("lco"; "hopf" for the zero-amplitude point), ``amplitude`` (half peak-to-peak of the decision
output), ``amplitude_pct_span``, ``frequency_hz``, ``amplitude_<output>`` and the ratios
``ratio_q1_q2`` / ``ratio_q1_q4`` (when tracked), ``harmonic_distortion``, ``stable``,
``floquet_multiplier`` (modulus of the critical multiplier), ``harmonics`` (H),
``hb_residual``, ``iterations``, ``method`` ("hb"), and for fold rows the refined limit
point ``fold_parameter`` / ``fold_amplitude`` (output units, half peak-to-peak). Every orbit
point carries the LCO certificate (:mod:`torchrom.periodic.certify`, the configuration's
``[certificate]``): its columns, ``stable`` from the shooting monodromy (the stability of
record; ``floquet_multiplier`` stays the harmonic balance's), and where the certificate
finished the orbit by shooting, the discrete orbit's amplitude and frequency (status
``lco_uncertified`` where that failed).
Glue; pandas for the table.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
import torch

from .._version import __version__
from ..checks import physical
from ..errors import InputError
from ..periodic import BranchOptions, follow_branches
from ..periodic.certify import COLUMNS as CERTIFICATE_COLUMNS
from ..periodic.certify import UNCERTIFIED, certify
from ..periodic.shooting import start_from_fourier
from ..periodic.solve import orbit_amplitude
from ..sim.metrics import amplitude_ratio
from ..sim.newmark import output_matrix
from ..sim.result import SimulationResult
from .cases import case_system
from .config import SweepConfig
from .grid import distinct_cases
from .models import model_rom

#: units of the parameters a branch may follow (axis labels, table metadata)
PARAMETER_UNITS = {"altitude_ft": "ft", "altitude_m": "m", "gamma": "s", "alpha": "1/s",
                   "stiffness_nl": "", "damping_nl": ""}
#: [branch] keys (BranchOptions fields and the parameter)
BRANCH_KEYS = ("parameter", "bounds", "harmonics", "amplitude_scale", "first_amplitude", "step",
               "min_step", "max_step", "max_points", "stability")


@dataclass
class BranchStudy:
    """The branch table and the Hopf points (one row per branch)."""

    table: pd.DataFrame
    hopf: pd.DataFrame
    parameter: str


def branch_options(cfg: SweepConfig, parameter: str | None = None,
                   bounds: tuple[float, float] | None = None, **overrides) -> tuple[str,
                                                                                    BranchOptions]:
    """(parameter, options) from the configuration's ``[branch]`` table, overridden by the
    arguments (the command line); every key checked."""
    table = dict(cfg.raw.get("branch", {}) or {})
    unknown = sorted(set(table) - set(BRANCH_KEYS))
    if unknown:
        raise InputError(f"{cfg.source}: [branch]: unknown key {unknown[0]!r}; expected one of "
                         f"{sorted(BRANCH_KEYS)}")
    parameter = parameter or table.pop("parameter", None)
    table.pop("parameter", None)
    if parameter not in PARAMETER_UNITS:
        raise InputError(f"branch parameter: expected one of {sorted(PARAMETER_UNITS)}, got "
                         f"{parameter!r}")
    b = bounds if bounds is not None else table.pop("bounds", None)
    table.pop("bounds", None)
    if b is None or len(b) != 2:
        raise InputError("branch bounds: give --range LO HI or [branch] bounds = [LO, HI]")
    for end in b:  # both ends in the parameter's physical range (the same table as the cases)
        physical(parameter, end, "branch bounds")
    kw = {**table, **{k: v for k, v in overrides.items() if v is not None}}
    if "amplitude_scale" not in kw and math.isfinite(cfg.lco.max_amplitude):
        kw["amplitude_scale"] = cfg.lco.max_amplitude / 10
    if math.isfinite(cfg.lco.max_amplitude):
        kw.setdefault("max_amplitude", cfg.lco.max_amplitude)
    try:
        return parameter, BranchOptions(bounds=(float(b[0]), float(b[1])), **kw)
    except TypeError as exc:
        raise InputError(f"[branch]: bad value ({exc})") from None


def _verdict(stable) -> bool | None:
    """A Floquet stability verdict as True, False or None (unknown: None or NaN)."""
    return None if stable is None or (isinstance(stable, float) and math.isnan(stable)) \
        else bool(stable)


def _floquet_extra(br, harmonics: int) -> dict[str, np.ndarray]:
    """The continuation's own Floquet results per orbit point (branch by branch, in order) as
    a harmonic-balance result's ``extra`` (what the Fourier certificate reads,
    :func:`torchrom.periodic.certify.fourier_rows`); empty without them (no stability)."""
    if not br.stable:
        return {}
    stable = np.array([_verdict(s) for st in br.stable for s in st], dtype=object)
    mult = np.concatenate([np.asarray(m, dtype=float) for m in br.critical_multiplier])
    err = np.concatenate([np.asarray(e, dtype=float) for e in br.floquet_error])
    return {"harmonics": np.full(len(mult), harmonics, dtype=np.int64), "stable": stable,
            "floquet_multiplier": mult, "floquet_error": err}


def certify_points(builder, br, names: list[str], C: np.ndarray, cfg: SweepConfig
                   ) -> list[dict] | None:
    """Per orbit point of ``br`` (branch by branch, in order), the certificate's columns and
    what they change (status, amplitudes, frequency, the stability of record); None when the
    configuration's certificate is disabled or there is no orbit point."""
    pts = [(b, pt) for b, pts in enumerate(br.points) for pt in pts if pt.kind != "hopf"]
    if not cfg.certificate.enabled or not pts:
        return None
    system = builder(np.array([pt.parameter for _, pt in pts]), np.array([b for b, _ in pts]))
    X = torch.stack([pt.X for _, pt in pts])
    omega = np.array([pt.omega for _, pt in pts])
    rows_t = torch.as_tensor(C, dtype=X.dtype)
    status = np.full(len(pts), "lco", dtype=object)
    amp = orbit_amplitude(X @ rows_t.T, status)
    nan = np.full(len(pts), np.nan)
    # each orbit's state where the decision output peaks (a retry's start from a neighbour)
    at = start_from_fourier(system, X, torch.as_tensor(omega), C[cfg.lco.decision_outputs[0]])
    res = SimulationResult(names, status, np.zeros(len(pts), dtype=np.int64), nan, amp,
                           omega / (2 * math.pi), nan, nan, at.q.numpy(), at.v.numpy(),
                           xi=at.xi.numpy(), orbits=(X.cpu().numpy(), omega),
                           extra=_floquet_extra(br, len(X[0]) // 2))
    res = certify(system, res, C, cfg.lco.decision_outputs[0], cfg.certificate,
                  cfg.integrator.dt)
    res = _finish_from_neighbours(system, res, [b for b, _ in pts], C, cfg)
    out = []
    for i in range(len(pts)):
        row = {k: res.extra[k][i] for k in CERTIFICATE_COLUMNS}
        row["status"] = str(res.status[i])
        if res.extra["finished"][i]:
            row.update({"amplitude": float(res.amplitude[i, 0]),
                        "frequency_hz": float(res.frequency_hz[i]),
                        **{f"amplitude_{n}": float(res.amplitude[i, j])
                           for j, n in enumerate(names)}})
        out.append(row)
    return out


def _finish_from_neighbours(system, res: SimulationResult, branch: list[int], C: np.ndarray,
                            cfg: SweepConfig) -> SimulationResult:
    """``res`` with the points whose finish from their harmonic-balance orbit failed finished
    again from the nearest certified point of the same branch: its discrete orbit carries the
    small coordinates' high harmonics that a low-H orbit lacks (on the Goland γ = 0 branch the
    H = 5 orbits of the largest LCOs are too far for Newton to reach from). Where that fails
    too, from the nearest certified point on the other side: near a resonance of a lightly
    damped mode the map has more than one discrete orbit (at 4,388 ft on that branch the orbit
    of the point above led to an unstable one the step does not resolve, the one below to the
    branch's own)."""
    status = np.asarray(res.status)
    if not cfg.certificate.finish or not (status == UNCERTIFIED).any():
        return res
    branch_a = np.asarray(branch)
    good = np.flatnonzero(status == "lco")
    sources: dict[int, list[int]] = {}  # per failed point: its neighbours, nearest first
    for i in np.flatnonzero(status == UNCERTIFIED):
        same = good[branch_a[good] == branch_a[i]]
        below, above = same[same < i], same[same > i]
        sides = ([int(below.max())] if below.size else []) + (
            [int(above.min())] if above.size else [])
        sources[int(i)] = sorted(sides, key=lambda j: (abs(j - i), j))
    for attempt in range(2):
        status = np.asarray(res.status)
        bad = np.array([i for i, src in sources.items()
                        if status[i] == UNCERTIFIED and len(src) > attempt], dtype=np.int64)
        if bad.size:
            src = np.array([sources[int(i)][attempt] for i in bad], dtype=np.int64)
            res = _finish_from(system, res, bad, src, C, cfg)
    return res


def _finish_from(system, res: SimulationResult, bad: np.ndarray, src: np.ndarray,
                 C: np.ndarray, cfg: SweepConfig) -> SimulationResult:
    """``res`` with the points ``bad`` certified again from the discrete orbits of ``src``
    (their rows updated where the finish converged)."""
    t = torch.as_tensor(bad)
    nan = np.full(bad.size, np.nan)
    retry = SimulationResult(res.output_names, np.full(bad.size, "lco", dtype=object),
                             np.zeros(bad.size, dtype=np.int64), nan, res.amplitude[src],
                             res.frequency_hz[src], nan, nan, res.q[src], res.v[src],
                             xi=res.xi[src])
    again = certify(system.select(t), retry, C, cfg.lco.decision_outputs[0], cfg.certificate,
                    cfg.integrator.dt)
    ok = np.flatnonzero(np.asarray(again.extra["finished"], dtype=object) == True)  # noqa: E712
    if not ok.size:
        return res
    rows = bad[ok]
    status = np.asarray(res.status).copy()
    status[rows] = again.status[ok]
    amp, freq = res.amplitude.copy(), res.frequency_hz.copy()
    amp[rows], freq[rows] = again.amplitude[ok], again.frequency_hz[ok]
    extra = {k: np.array(v, copy=True) for k, v in res.extra.items()}
    for k in CERTIFICATE_COLUMNS:
        extra[k][rows] = np.asarray(again.extra[k])[ok]
    return dataclasses.replace(res, status=status, amplitude=amp, frequency_hz=freq,
                               extra=extra)


class _Reach:
    """The share of the range ``bounds`` the branches have covered, from the parameters the
    continuation builds systems at (for :func:`run_branches`' ``progress``). The first call
    is the Hopf scan over the whole range (skipped); the Hopf points set the start (the bound
    nearest the first points built after the scan); then the furthest point from that bound."""

    def __init__(self, bounds: tuple[float, float], progress: Callable[[float], None] | None):
        self.lo, self.hi = (float(b) for b in bounds)
        self.progress = progress
        self.calls = 0
        self.start: float | None = None
        self.done = 0.0

    def see(self, p: np.ndarray) -> None:
        self.calls += 1
        if self.progress is None or self.calls == 1 or not len(p):
            return
        p = np.asarray(p, dtype=float)
        if self.start is None:
            mid = 0.5 * (self.lo + self.hi)
            self.start = self.hi if float(np.mean(p)) >= mid else self.lo
        far = float(np.max(np.abs(p - self.start)))
        fraction = min(1.0, far / max(self.hi - self.lo, 1e-300))
        if fraction > self.done:
            self.done = fraction
            self.progress(fraction)

    def close(self) -> None:
        """The continuation is over (the certificate's systems that follow are not steps)."""
        self.progress = None


def run_branches(cfg: SweepConfig, parameter: str, options: BranchOptions, model=None,
                 device=None, progress: Callable[[float], None] | None = None,
                 log: Callable[[str], None] | None = None) -> BranchStudy:
    """Follow one branch per distinct case (without ``parameter``) of ``cfg``.

    ``progress(fraction)``: how far the branches have come, the share of the parameter range
    ``options.bounds`` between the bound the Hopf points lie nearest and the furthest point
    corrected so far (monotone; what a bar shows — the continuation has no count of its own);
    ``log``: a line before the points' certificate (the part no bar counts)."""
    from .. import bounds

    model = model if model is not None else cfg.build_model()
    rom = model_rom(model)
    base = distinct_cases(cfg.cases, (parameter, "q0", "sample"))
    if not base:
        raise InputError(f"{cfg.source}: [cases]: no case to follow")
    bounds.check_harmonic_balance(f"{cfg.source}: branch harmonics", rom.n, options.harmonics,
                                  len(base), device=device, override=cfg.allow_large)
    device = torch.device(device or "cpu")

    reach = _Reach(options.bounds, progress)

    def builder(p: np.ndarray, branches: np.ndarray):
        reach.see(p)
        cases = [{**base[int(b)], parameter: float(x)} for x, b in zip(p, branches)]
        return case_system(model, cases, device, torch.float64)[0]

    names, C = output_matrix(rom, cfg.outputs)
    decide = C[cfg.lco.decision_outputs[0]]
    br = follow_branches(builder, len(base), decide, options)
    reach.close()
    span = getattr(model, "span", None) or rom.metadata.get("span")
    rows_t = torch.as_tensor(C, dtype=torch.float64)
    if log is not None and cfg.certificate.enabled:
        n = sum(pt.kind != "hopf" for pts in br.points for pt in pts)
        log(f"  certifying the {n} orbit points (the Fourier certificate; shooting where it "
            "refuses)")
    certificate = certify_points(builder, br, names, C, cfg)
    certified_rows = iter(certificate or ())
    records = []
    for b, pts in enumerate(br.points):
        lco = [pt for pt in pts if pt.kind != "hopf"]
        stable = br.stable[b] if br.stable else np.full(len(lco), np.nan)
        mult = br.critical_multiplier[b] if br.critical_multiplier else np.full(len(lco), np.nan)
        if lco:
            X = torch.stack([pt.X for pt in lco])
            amp = orbit_amplitude(X @ rows_t.T, np.full(len(lco), "lco", dtype=object))
            Y = (X @ rows_t.T)[:, :, 0]
            mags = torch.sqrt(Y[:, 1::2] ** 2 + Y[:, 2::2] ** 2)
            dist = (mags[:, 1:].norm(dim=1) / mags[:, 0]).numpy()
        k = 0
        for pt in pts:
            row: dict[str, Any] = {"branch": b, "point": pt.index, "kind": pt.kind,
                                   **base[b], parameter: pt.parameter}
            if pt.kind == "hopf":
                row.update({"status": "hopf", "amplitude": 0.0,
                            "frequency_hz": pt.omega / (2 * math.pi), "stable": None,
                            "floquet_multiplier": math.nan, "harmonic_distortion": math.nan,
                            **{f"amplitude_{n}": 0.0 for n in names}})
            else:
                row.update({"status": "lco", "amplitude": float(amp[k, 0]),
                            "frequency_hz": pt.omega / (2 * math.pi),
                            "stable": _verdict(stable[k]),
                            "floquet_multiplier": float(mult[k]),
                            "harmonic_distortion": float(dist[k]),
                            **{f"amplitude_{n}": float(amp[k, j]) for j, n in enumerate(names)}})
                k += 1
                row.update(next(certified_rows, {}))
            fold_amp = math.nan
            if pt.fold:  # the refined limit point's amplitude, measured like the others
                fold_amp = float(orbit_amplitude((pt.fold[2] @ rows_t.T)[None],
                                                 np.array(["lco"], dtype=object))[0, 0])
            row.update({"harmonics": options.harmonics if pt.kind != "hopf" else 0,
                        "hb_residual": pt.residual, "iterations": pt.iterations,
                        "fold_parameter": pt.fold[0] if pt.fold else math.nan,
                        "fold_amplitude": fold_amp,
                        "method": "hb", "version": __version__})
            records.append(row)
    table = pd.DataFrame(records)
    if len(table):
        if span:
            table.insert(table.columns.get_loc("amplitude") + 1, "amplitude_pct_span",
                         100.0 * table["amplitude"] / float(span))
            table["fold_amplitude_pct_span"] = 100.0 * table["fold_amplitude"] / float(span)
        for a, bname in (("q1", "q2"), ("q1", "q4")):
            if a in names and bname in names:
                table[f"ratio_{a}_{bname}"] = amplitude_ratio(table[f"amplitude_{a}"],
                                                              table[f"amplitude_{bname}"])
        table["stable"] = pd.array(table["stable"].tolist(), dtype="boolean")
    hopf = pd.DataFrame([{**base[h["branch"]], **h} for h in br.hopf])
    from .sweep import flight_units, model_length_unit
    from .units import sweep_units

    # the amplitudes in their outputs' units (the model's length unit for a physical output,
    # "-" for a generalized coordinate), as a sweep's table has them
    table.attrs["units"] = {**sweep_units(list(table.columns), names, model_length_unit(model),
                                          flight_units(model)),
                            parameter: PARAMETER_UNITS[parameter], "frequency_hz": "Hz",
                            "amplitude_pct_span": "% of span"}
    table.attrs["decision_output"] = names[0] if names else None
    return BranchStudy(table, hopf, parameter)
