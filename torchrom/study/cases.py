"""Case semantics of a sweep: case parameters -> per-case system, table columns, histories.

A *structural* case has the Eq. 54 parameters ``alpha`` (1/s), ``gamma`` (s), ``stiffness_nl``,
``damping_nl`` and ``q0`` (scale of the initial displacement). An *aeroelastic* case (a model
with aerodynamics, :class:`~torchrom.study.models.AeroelasticModel`) adds the flight condition:
the altitude (geometric, USSA-76) as ``altitude_ft`` or ``altitude_m`` — the key names its
unit, the model's altitude unit (:attr:`AeroelasticModel.altitude_column`; one per run) — and
optionally ``mach`` (must be the GAF Mach number), from which V = M a(h), ρ(h) and
q∞ = ½ρV² follow (paper Eqs. 49–50). There ``alpha = "matched"``
means the α that keeps the flutter altitude of the baseline damping for the case's γ (paper
Fig. 9, :meth:`AeroelasticModel.matched_alpha`); the table then holds the numeric α, and
``alpha_matched`` says where it came from.

A *wind-tunnel* case gives the airspeed instead: ``speed`` at the air density
``density`` or at that of the altitude (USSA-76), q∞ = ½ρV², at the GAF Mach
number (a tunnel test such as Pazy's: sea-level density, speed swept). A speed sweep is at
one density: sweeping the altitude as well is refused (sweep the altitude without
``speed`` for the matched point). Units: ``speed`` and ``density`` in the model's unit system
(:attr:`AeroelasticModel.units`, e.g. m/s and kg/m³ for an SI deck, ft/s and slug/ft³ for the
Goland wing); the altitude in the unit its key names, which the atmosphere takes as it is.

``[history]`` selects cases whose output time histories are kept: ``where`` is a table of
parameter values (a value or a list of values each; numbers compare to a relative 1e-9) and
``every`` the sampling in steps. Pandas for the tables.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
import torch

from ..checks import physical
from ..errors import InputError
from ..rom import NonlinearROM
from ..sim import CaseSystem, SimulationResult
from ..sim.aeroelastic import aeroelastic_system_at
from ..units import ALTITUDE_COLUMNS
from .models import AeroelasticModel

#: case parameters of a structural sweep (no aerodynamics)
STRUCTURAL_PARAMETERS = ("alpha", "gamma", "stiffness_nl", "damping_nl", "q0")
#: case parameters of an aeroelastic sweep
AEROELASTIC_PARAMETERS = ("altitude_ft", "altitude_m", "speed", "density", "mach", "alpha",
                          "gamma", "stiffness_nl", "damping_nl", "q0", "aoa_deg")
#: the α of a case that keeps the baseline flutter altitude (paper Fig. 9)
MATCHED = "matched"
#: units of a wind-tunnel case's speed and density (the model's system, known once it is built)
TUNNEL_UNITS = {"speed": "the model's speed unit, e.g. ft/s or m/s",
                "density": "the model's density unit, e.g. slug/ft^3 or kg/m^3"}


def case_parameters(aeroelastic: bool) -> tuple[str, ...]:
    return AEROELASTIC_PARAMETERS if aeroelastic else STRUCTURAL_PARAMETERS


def check_case_values(cases: Sequence[Mapping[str, Any]], aeroelastic: bool,
                      where: str = "[cases]") -> None:
    """InputError naming the parameter and case unless every value is a finite number or a
    bool in the parameter's physical range (:func:`torchrom.checks.physical`; ``alpha`` may also
    be "matched" in an aeroelastic sweep, which needs the altitude)."""
    for k, case in enumerate(cases):
        for name, value in case.items():
            if aeroelastic and name == "alpha" and value == MATCHED:
                continue
            ok = isinstance(value, (int, float)) and math.isfinite(float(value))
            if not ok:
                extra = " or 'matched'" if aeroelastic and name == "alpha" else ""
                raise InputError(f"{where} {name}: expected a number{extra} or true/false, got "
                                 f"{value!r} (case {k})")
            try:
                physical(name, float(value), where)
            except InputError as exc:
                raise InputError(f"{exc} (case {k})") from None
        if aeroelastic:
            _check_flight_condition(case, k, where)
        if not aeroelastic and case.get("alpha") == MATCHED:
            raise InputError(f"{where} alpha: 'matched' needs a model with aerodynamics "
                             f"([model] aero = 'aero.npz' or builtin = 'goland')")
    if aeroelastic:
        check_speed_sweep(cases, where)


def altitude_key(case: Mapping[str, Any]) -> str | None:
    """The altitude parameter a case gives (``altitude_ft`` or ``altitude_m``), None for none."""
    keys = [c for c in ALTITUDE_COLUMNS if c in case]
    return keys[0] if keys else None


def _check_flight_condition(case: Mapping[str, Any], k: int, where: str) -> None:
    """A matched-point case has its altitude (``altitude_ft`` or ``altitude_m``, not both); a
    wind-tunnel case ``speed`` > 0 and either ``density`` > 0 or the altitude (InputError
    naming the key otherwise)."""
    for key in ("speed", "density"):
        if key in case and not float(case[key]) > 0:
            raise InputError(f"{where} {key}: expected a positive number "
                             f"({TUNNEL_UNITS[key]}), got {case[key]!r} (case {k})")
    given = [c for c in ALTITUDE_COLUMNS if c in case]
    if len(given) > 1:
        raise InputError(f"{where} {given[1]}: given together with {given[0]} (case {k}); "
                         f"one altitude unit per run: give the altitude once")
    altitude = given[0] if given else None
    if "speed" not in case:
        if "density" in case:
            raise InputError(f"{where} density: given without speed (case {k}); a wind-tunnel "
                             f"case needs the speed, a matched-point case the altitude only")
        if altitude is None:
            raise InputError(f"{where} altitude_ft: missing (case {k}); an aeroelastic sweep "
                             f"needs the altitude of every case (matched point: altitude_ft "
                             f"or altitude_m), or a speed and density (wind tunnel)")
    elif ("density" in case) == (altitude is not None):
        key = "density" if "density" in case else "speed"
        raise InputError(f"{where} {key}: a wind-tunnel case takes its air density from "
                         f"exactly one of density or the altitude (altitude_ft or altitude_m) "
                         f"(case {k})")


def check_speed_sweep(cases: Sequence[Mapping[str, Any]], where: str = "[cases]") -> None:
    """InputError when the cases sweep both the speed and the altitude (or density): a speed
    sweep is a wind tunnel at one density; an altitude sweep is the matched point."""
    tunnel = [c for c in cases if "speed" in c]
    if len({float(c["speed"]) for c in tunnel}) < 2:
        return
    for key in (*ALTITUDE_COLUMNS, "density"):
        if len({float(c[key]) for c in tunnel if key in c}) > 1:
            raise InputError(f"{where} {key}: swept together with speed; a speed sweep (wind "
                             f"tunnel) is at one air density: give one {key}, or sweep "
                             f"the altitude without speed (matched point)")


def flight_conditions(model: AeroelasticModel, cases: Sequence[Mapping[str, Any]]
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(V, ρ, altitude) per case (the model's speed and density units, e.g. ft/s and
    slug/ft³; the altitude in the model's altitude unit): the matched point V = M a(h), ρ(h)
    at the GAF Mach M (paper Eqs. 49–50), or the wind tunnel's ``speed`` at ``density`` or at
    ρ(altitude) (altitude NaN when the density is given); the atmosphere in the model's units,
    the altitude with its unit (:func:`check_altitude_unit`)."""
    from ..aero.atmosphere import atmosphere, flight_condition

    check_altitude_unit(model, cases)
    units, column, unit = model.units.name, model.altitude_column, model.altitude_unit
    V, rho, alt = (np.full(len(cases), np.nan) for _ in range(3))
    for i, c in enumerate(cases):
        if column in c:
            alt[i] = float(c[column])
        if "speed" not in c:
            fc = flight_condition(model.mach, alt[i], units, unit)
            V[i], rho[i] = float(fc.velocity), float(fc.density)
        else:
            V[i] = float(c["speed"])
            rho[i] = (float(c["density"]) if "density" in c
                      else float(atmosphere(alt[i], units, unit).density))
    return V, rho, alt


def check_altitude_unit(model: AeroelasticModel, cases: Sequence[Mapping[str, Any]],
                        where: str = "[cases]") -> None:
    """InputError unless every case gives its altitude in the model's altitude unit
    (:attr:`AeroelasticModel.altitude_column`): one altitude unit per run, none converted."""
    for k, c in enumerate(cases):
        key = altitude_key(c)
        if key is not None and key != model.altitude_column:
            raise InputError(f"{where} {key}: the model's altitudes are in "
                             f"{model.altitude_unit} (case {k}); one altitude unit per run: "
                             f"give {model.altitude_column}, or build the model with "
                             f"altitude_unit = {ALTITUDE_COLUMNS[key]!r} ([aeroelastic] "
                             f"altitude_unit)")


#: the load-case keys of a ROM's reference state that a sweep's flutter line names
REFERENCE_KEYS = ("aoa_deg", "velocity", "density")
#: most distinct air densities whose flutter speed a sweep reports
MAX_FLUTTER_DENSITIES = 4


def flutter_speed_lines(model, cases: Sequence[Mapping[str, Any]]) -> list[str]:
    """One line per distinct air density of the wind-tunnel cases (the first
    :data:`MAX_FLUTTER_DENSITIES`): the flutter speed there with the baseline damping
    (:meth:`AeroelasticModel.flutter_speed`), where the speed sweep's LCOs begin; none for a
    structural model or matched-point cases."""
    tunnel = [c for c in cases if "speed" in c]
    if not isinstance(model, AeroelasticModel) or not tunnel:
        return []
    _, rho, _ = flight_conditions(model, tunnel)
    lines, u = [], model.units
    if model.rigid_body_support_hz is not None:
        lines.append(f"rigid-body modes on a soft support at {model.rigid_body_support_hz:g} Hz "
                     f"([model] rigid_body_support_hz; column rigid_body_support_hz): the "
                     f"aircraft is not free in plunge and pitch")
    # at a root angle of attack the reference tangent's flutter speed is not where LCOs begin:
    # the undeformed wing's, or for a ROM expanded about a state that state's
    reference = getattr(model.rom, "reference", None)
    tangent = "the undeformed wing"
    if reference is not None:
        held = ", ".join(f"{k} {reference.condition[k]:g}" for k in REFERENCE_KEYS
                         if isinstance(reference.condition.get(k), (int, float)))
        tangent = f"the ROM's reference state ({held})" if held else "the ROM's reference state"
    straight = (f" of {tangent} (about the deformed wing at each angle: torchrom flutter ROM "
                f"AERO --aoa DEG)") if any(float(c.get("aoa_deg", 0.0)) for c in tunnel) else ""
    for density in list(dict.fromkeys(float(r) for r in rho))[:MAX_FLUTTER_DENSITIES]:
        fs = model.flutter_speed(density)
        where = f"flutter speed{straight} at {density:.6g} {u.density} (baseline damping)"
        lines.append(f"{where}: {fs.velocity:.2f} {u.speed}, {fs.frequency_hz:.3f} Hz"
                     if fs.velocity is not None else f"{where}: none in the speed range")
    return lines


def _column(cases, name, default) -> list[float]:
    return [float(c.get(name, default)) for c in cases]


def structural_system(rom: NonlinearROM, cases: list[dict[str, Any]], device=None,
                      dtype=torch.float64) -> CaseSystem:
    """The per-case system of a structural sweep (Eq. 54 parameters only)."""
    return CaseSystem.build(rom, len(cases), alpha=_column(cases, "alpha", 0.0),
                            gamma=_column(cases, "gamma", 0.0),
                            stiffness_nl=_column(cases, "stiffness_nl", 1.0),
                            damping_nl=_column(cases, "damping_nl", 1.0), device=device,
                            dtype=dtype)


def matched_alphas(model: AeroelasticModel, cases: Sequence[Mapping[str, Any]]
                   ) -> tuple[list[float], list[bool]]:
    """(α per case, whether it was matched): ``alpha = "matched"`` resolved by the model."""
    matched = [c.get("alpha", 0.0) == MATCHED for c in cases]
    gammas = [float(c.get("gamma", 0.0)) for c, m in zip(cases, matched) if m]
    solved = iter(model.matched_alphas(gammas) if gammas else [])
    alpha = [next(solved) if m else float(c.get("alpha", 0.0)) for c, m in zip(cases, matched)]
    return alpha, matched


def case_system(model, cases: list[dict[str, Any]], device=None, dtype=torch.float64
                ) -> tuple[CaseSystem, list[dict[str, Any]] | None]:
    """(system, extra) for a chunk of cases: ``extra[i]`` holds derived table columns of case i
    (flight condition, numeric α) that do not enter its case_id; None for structural cases."""
    if isinstance(model, NonlinearROM):
        return structural_system(model, cases, device, dtype), None
    if not isinstance(model, AeroelasticModel):
        raise InputError(f"sweep model: expected a NonlinearROM or an AeroelasticModel, got "
                         f"{type(model).__name__}")
    for c in cases:
        if "mach" in c and abs(float(c["mach"]) - model.mach) > 1e-9:
            raise InputError(f"[cases] mach: {c['mach']} differs from the Mach number "
                             f"{model.mach:g} of the aerodynamic data")
    alpha, matched = matched_alphas(model, cases)
    gamma = _column(cases, "gamma", 0.0)
    s_nl = _column(cases, "stiffness_nl", 1.0)
    d_nl = _column(cases, "damping_nl", 1.0)
    aoa = _column(cases, "aoa_deg", 0.0)
    V, rho, alt = flight_conditions(model, cases)
    ae = aeroelastic_system_at(model.rom, model.aero, V, rho, altitude=alt, alpha=alpha,
                               gamma=gamma, stiffness_nl=s_nl, damping_nl=d_nl, aoa_deg=aoa,
                               device=device, dtype=dtype, check=False)
    # the values used (defaults included), so that no column has gaps where a case omits one
    extra = [{**cond, "alpha": a, "gamma": g, "stiffness_nl": s, "damping_nl": d,
              "alpha_matched": m, **({"aoa_deg": x} if any(aoa) else {})}
             for cond, a, g, s, d, m, x in zip(ae.conditions(), alpha, gamma, s_nl, d_nl,
                                               matched, aoa)]
    if model.free:  # a free aircraft: its rigid-body divergence rate, and any support
        for row, v, r, a, g in zip(extra, V, rho, alpha, gamma):
            row["rigid_body_growth"] = model.rigid_body_growth(float(v), float(r), a, g)
            if model.rigid_body_support_hz is not None:  # the table says it was not free
                row["rigid_body_support_hz"] = model.rigid_body_support_hz
    return ae.system, extra


# -- neighbour chains (harmonic balance warm starts) ----------------------------------------------
#: longest neighbour chain: chains advance in lockstep, so longer ones mean smaller batches
#: (32: a 500-case chunk of a sampling study advances 16 cases at a time, which keeps the
#: batched solves compute-bound, and starts cold once per 32 cases — a cold start costs about
#: as much as five to ten warm ones)
MAX_CHAIN = 32
#: ... and, where there are enough cases, at least this many chains side by side
MIN_CHAINS = 2
#: case keys that neither order nor separate neighbour chains
CHAIN_IGNORED = ("sample", "q0")


def neighbour_chains(cases: Sequence[Mapping[str, Any]], max_length: int = MAX_CHAIN
                     ) -> tuple[list[list[int]], np.ndarray | None]:
    """(chains, positions): the cases grouped by every parameter but the one with the most
    distinct numeric values (the chain parameter, e.g. the altitude of a curve or the γ of
    uncertainty samples), each group ordered by it from its largest value down (usually the
    most damped end, where the orbit is smallest and a cold start cheapest) and cut into
    chains of at most ``max_length``; positions are the chain parameter of every case (None
    when nothing varies). For :func:`torchrom.periodic.solve_orbits`."""
    B = len(cases)
    # a sample number and an initial amplitude say nothing about how close two cases are
    keys = [k for k in dict.fromkeys(k for c in cases for k in c) if k not in CHAIN_IGNORED]
    numeric = [k for k in keys if all(isinstance(c.get(k), (int, float))
                                      and not isinstance(c.get(k), bool) for c in cases)]
    counts = {k: len({float(c[k]) for c in cases}) for k in numeric}
    varying = [k for k in numeric if counts[k] > 1]
    if not varying:
        return [[i] for i in range(B)], None
    key = max(varying, key=lambda k: counts[k])
    groups: dict[str, list[int]] = {}
    for i, c in enumerate(cases):
        groups.setdefault(repr(sorted((k, repr(v)) for k, v in c.items()
                                      if k != key and k not in CHAIN_IGNORED)), []).append(i)
    pos = np.array([float(c[key]) for c in cases])
    # chains advance in lockstep: keep at least MIN_CHAINS of them (batch width) when the
    # cases allow, at the price of more cold starts (one per chain)
    max_length = max(2, min(max_length, math.ceil(B / MIN_CHAINS)))
    chains = []
    for members in groups.values():
        members = sorted(members, key=lambda i: -pos[i])
        chains += [members[j: j + max_length] for j in range(0, len(members), max_length)]
    return chains, pos


def chain_order(cases: Sequence[Mapping[str, Any]]) -> list[int]:
    """The case indices in the order of :func:`neighbour_chains` (each group ordered by its
    chain parameter from its largest value down): contiguous chunks cut from this order hold
    close neighbours. Why: sampled cases come in random order, so chunks of the case list
    each spanned the whole distribution; 4,096 of the 10,000 Goland UQ samples (γ lognormal)
    in chunks of 512 took 21.4 CPU ms per case of harmonic balance in case order and 13.6 ms
    in chain order (3.9 → 3.0 Newton iterations per case)."""
    chains, _ = neighbour_chains(cases, max_length=max(len(cases), 2))
    return [i for chain in chains for i in chain]


# -- time histories --------------------------------------------------------------------------------
@dataclass
class HistorySpec:
    """Which cases keep output time histories (``where``: parameter -> allowed values) and the
    sampling interval ``every`` (steps)."""

    where: dict[str, list[Any]] = field(default_factory=dict)
    every: int = 10

    @classmethod
    def from_table(cls, table: Mapping[str, Any], allowed: Sequence[str],
                   where: str = "[history]") -> HistorySpec | None:
        if not table:
            return None
        unknown = sorted(set(table) - {"where", "every"})
        if unknown:
            raise InputError(f"{where}: unknown key {unknown[0]!r}; expected 'where' and 'every'")
        every = table.get("every", 10)
        if isinstance(every, bool) or not isinstance(every, int) or every < 1:
            raise InputError(f"{where} every: expected a positive number of steps, got {every!r}")
        sel = table.get("where", {})
        if not isinstance(sel, dict):
            raise InputError(f"{where} where: expected a table of parameter values, got {sel!r}")
        for name in sel:
            if name not in allowed:
                raise InputError(f"{where} where: unknown case parameter {name!r}; expected one "
                                 f"of {sorted(allowed)}")
        values = {k: v if isinstance(v, list) else [v] for k, v in sel.items()}
        return cls(values, int(every))

    def selects(self, case: Mapping[str, Any]) -> bool:
        return all(any(_same(case.get(k), v) for v in vals) for k, vals in self.where.items())

    def indices(self, cases: Sequence[Mapping[str, Any]]) -> list[int]:
        return [i for i, c in enumerate(cases) if self.selects(c)]


def _same(a, b) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(float(a), float(b), rel_tol=1e-9, abs_tol=1e-300)
    return a == b


def history_table(result: SimulationResult, case_ids: Sequence[str]) -> pd.DataFrame:
    """Long table of the kept histories: case_id, t (s) and one column per output."""
    frames = []
    for i, h in sorted(result.histories.items()):
        df = pd.DataFrame(np.asarray(h.y), columns=list(h.names))
        df.insert(0, "t", np.asarray(h.t))
        df.insert(0, "case_id", case_ids[i])
        frames.append(df)
    if not frames:
        return pd.DataFrame(columns=["case_id", "t", *result.output_names])
    return pd.concat(frames, ignore_index=True)


def orbit_table(result: SimulationResult, case_ids: Sequence[str]) -> pd.DataFrame | None:
    """Long table of the LCO orbits of a harmonic balance result (:attr:`SimulationResult.orbits`;
    None for time marching): case_id, omega (rad/s), k (row of the Fourier coefficients: 0 the
    mean, 2h − 1 and 2h the cosine and sine of harmonic h, up to the case's own H) and one
    column per modal coordinate (q1..qn)."""
    if result.orbits is None:
        return None
    X, omega = result.orbits
    H = result.extra.get("harmonics", np.full(len(case_ids), (X.shape[1] - 1) // 2))
    names = [f"q{j + 1}" for j in range(X.shape[2])]
    lco = np.flatnonzero(result.status == "lco")
    rows = 2 * np.asarray(H, dtype=int)[lco] + 1
    case = np.repeat(lco, rows)  # one row per (case, coefficient)
    k = np.concatenate([np.arange(m) for m in rows]) if lco.size else np.zeros(0, dtype=int)
    df = pd.DataFrame(X[case, k], columns=names)
    df.insert(0, "k", k)
    df.insert(0, "omega", np.asarray(omega, dtype=float)[case])
    df.insert(0, "case_id", np.asarray(list(case_ids), dtype=object)[case])
    return df


def orbits_of(table: pd.DataFrame, case_ids: Sequence[str], n: int
              ) -> tuple[np.ndarray, np.ndarray]:
    """(X (B, 2H+1, n), ω (B,)) of ``case_ids`` from an :func:`orbit_table` (H the largest among
    them; zeros and NaN for a case without an orbit)."""
    mine = table[table["case_id"].isin(list(case_ids))]
    rows = int(mine["k"].max()) + 1 if len(mine) else 1
    X = np.zeros((len(case_ids), rows, n))
    omega = np.full(len(case_ids), np.nan)
    names = [f"q{j + 1}" for j in range(n)]
    for i, cid in enumerate(case_ids):
        own = mine[mine["case_id"] == cid]
        if len(own):
            X[i, own["k"].to_numpy(int)] = own[names].to_numpy(float)
            omega[i] = float(own["omega"].iloc[0])
    return X, omega


def initial_displacement(rom: NonlinearROM, initial: dict[str, Any],
                         cases: list[dict[str, Any]], where: str = "[initial]") -> np.ndarray:
    """(B, n) initial displacements: the ``[initial]`` pattern, scaled by each case's ``q0``."""
    n = rom.n
    q0 = initial.get("q0", 1e-3)
    mode = initial.get("mode", 1)
    if isinstance(mode, bool) or not isinstance(mode, int) or not 1 <= mode <= n:
        raise InputError(f"{where} mode: expected a basis function number 1..{n}, got {mode!r}")
    if isinstance(q0, list):
        base = np.asarray(q0, dtype=float)
        if base.shape != (n,):
            raise InputError(f"{where} q0: expected {n} values, got {len(q0)}")
        amp = 1.0
    elif isinstance(q0, (int, float)) and not isinstance(q0, bool):
        base = np.zeros(n)
        base[mode - 1] = 1.0
        amp = float(q0)
    else:
        raise InputError(f"{where} q0: expected a number or a list of {n} numbers, got {q0!r}")
    scale = np.array([float(c.get("q0", amp)) for c in cases])
    return scale[:, None] * base[None, :]


def initial_velocity(rom: NonlinearROM, initial: dict[str, Any], batch: int,
                     where: str = "[initial]") -> np.ndarray:
    v0 = initial.get("v0", 0.0)
    arr = np.asarray(v0, dtype=float)
    if arr.ndim == 0:
        arr = np.full(rom.n, float(arr))
    if arr.shape != (rom.n,):
        raise InputError(f"{where} v0: expected a number or {rom.n} values, got {v0!r}")
    return np.broadcast_to(arr, (batch, rom.n)).copy()
