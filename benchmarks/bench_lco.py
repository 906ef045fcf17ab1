"""Benchmark: CPU seconds per converged Goland LCO, by method, against an accurate reference.

    PYTHONPATH=. python benchmarks/bench_lco.py [--quick] [--model DIR] [--device cpu|cuda]
        [--out benchmarks/results]

Model: the heavy Goland wing 9L12D ROM with its RFA aerodynamics (Mach 0.70) from the paper
pipeline's model cache (``--model``). Cases: post-flutter altitudes × γ with the matched α
(``--quick``: 4000–10000 ft every 1500 ft × γ ∈ {0, 1e-3}). Methods (:data:`METHODS`, one
function each): ``newmark-reference`` (the paper's setting: dt = 1 ms, small start, 2 Newton
iterations), ``newmark`` (a 10 %-of-span start on the static manifold, error-controlled steps),
``newmark-fast``, ``hb`` and ``hb-unresolved`` (harmonic balance, with seeding of the LCOs not
accepted in H), ``shooting`` (the ``hb`` orbits finished to the discrete orbit, every one),
``newmark-neighbour``, ``newmark-hb``, ``hb-raised`` (``hb`` with the Fourier
certificate's refused rows re-solved at H → 2H + 1 up to :data:`RAISED_HARMONICS` first,
``[certificate] max_harmonics``) and ``hb-slow`` (``hb`` with ``[certificate] slow``, the
slow certificate before shooting; ``--methods``). Every method's LCOs
are certified as a sweep certifies them (:mod:`torchrom.periodic.certify`: harmonic-balance
rows first by the Fourier certificate, :mod:`torchrom.periodic.fourier_certificate`, a bound on
the distance to the continuous-time orbit without time integration; the others by one shooting
evaluation each at dt = 1 ms, a shooting finish where the certificate fails, Richardson's
dt_error), the certificate's CPU time counted in the method's; per case the ``certificate``
that certified it. Reference: the continuous-time
orbit, shooting at 1 ms and 2 ms with Richardson (:func:`shooting_reference`); ``--hb-check``
adds harmonic balance up to H = 25 against it (:func:`hb_reference`). Writes
``bench_lco.json``: per method ``cpu_s_per_lco`` and ``cpu_s_per_certified_lco`` (one torch
thread), ``certified``, the largest amplitude and frequency errors over the cases (a case
without an LCO counts as infinite), ``max_orbit_error_pct``, whether every certificate bounds
its measured error, the stability verdicts left unknown, ``certificate_cpu_s`` (the
certificate's share) and the per-case table, with the machine and load; and the certificate's
floor (:func:`certificate_floor`): the CPU per LCO of its evaluations alone, which bounds every
certified method's speed-up over ``newmark-reference``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent))

from results_io import machine_meta  # noqa: E402

from torchrom.periodic import HarmonicBalanceMethod, HBOptions, solve_orbits  # noqa: E402
from torchrom.periodic.certify import COLUMNS as CERT_COLUMNS  # noqa: E402
from torchrom.periodic.certify import (  # noqa: E402
    FINISH_TOL,
    Certificate,
    certify,
    fourier_rows,
)
from torchrom.periodic.seed import (  # noqa: E402
    SEED_HARMONICS,
    merge_seeded,
    seed_unresolved,
    seeded_orbits,
)
from torchrom.periodic.shooting import OrbitStart, ShootingOptions, shoot  # noqa: E402
from torchrom.periodic.solve import orbit_state  # noqa: E402
from torchrom.sim import LCOCriteria, Newmark, SimulationResult  # noqa: E402
from torchrom.study.cases import case_system, neighbour_chains  # noqa: E402
from torchrom.study.solvers import Shooting  # noqa: E402
from torchrom.study.starts import march  # noqa: E402

OUTPUT = "A_Tz"
#: the paper's LCO criteria (configs/paper_lco.toml)
PAPER_LCO = LCOCriteria(rtol=1e-3, cycles=4, max_amplitude=10.0)
#: the paper's start: mode 1 displaced by 0.1 (tip ≈ 0.06 % of span)
PAPER_START = {"q0": 0.1, "mode": 1}
T_END = 200.0


@dataclass
class Bench:
    """The benchmark's model, cases and device (what every method receives)."""

    model: object
    cases: list[dict]
    device: str = "cpu"
    dtype: torch.dtype = torch.float64

    @property
    def outputs(self) -> list[str]:
        """Every output of the ROM, the decision output :data:`OUTPUT` first."""
        return list(dict.fromkeys([OUTPUT, *self.model.rom.outputs]))

    @property
    def rows(self) -> np.ndarray:
        """(O, n) the rows of :attr:`outputs`."""
        return np.stack([np.asarray(self.model.rom.outputs[o]) for o in self.outputs])

    def system(self, cases=None):
        return case_system(self.model, self.cases if cases is None else cases,
                           torch.device(self.device), self.dtype)[0]


@dataclass
class MethodRun:
    """Per-case results of a method (case order) and its CPU seconds."""

    amplitude: np.ndarray
    frequency_hz: np.ndarray
    status: np.ndarray
    steps: np.ndarray
    time_s: np.ndarray
    cpu_s: float
    q: np.ndarray
    v: np.ndarray
    xi: np.ndarray | None
    result: SimulationResult | None = None
    #: the certificate's columns (torchrom.periodic.certify), after :func:`certified`
    certificate: dict | None = None
    #: certify with ``always_finish`` (the shooting solver: every LCO finished)
    always_finish: bool = False
    #: the CPU seconds of the certificate (evaluations and finishes), part of ``cpu_s``
    certificate_cpu_s: float = 0.0
    #: (B, O) the amplitude of every output of :attr:`Bench.outputs` (``amplitude``: the first)
    amplitudes: np.ndarray | None = None
    #: the certificate's ``max_harmonics`` (0: refused Fourier rows go to shooting directly)
    max_harmonics: int = 0
    #: the certificate's ``slow`` (the slow certificate between the Fourier one and shooting)
    slow: bool = False


def _timed(fn: Callable[[], object]) -> tuple[object, float]:
    c0 = time.process_time()
    out = fn()
    return out, time.process_time() - c0


def _marched(bench: Bench, integ: Newmark, initial: dict, lco: LCOCriteria = PAPER_LCO
             ) -> MethodRun:
    """The cases through :func:`torchrom.study.starts.march` (the sweep's code path)."""
    rom = bench.model.rom

    def run(sub, q0, v0, xi0, _index):
        return integ.run(sub, q0, v0, xi0, t_end=T_END, outputs=bench.outputs, lco=lco)

    res, cpu = _timed(lambda: march(bench.system(), rom, bench.cases, initial, run))
    return MethodRun(res.amplitude[:, 0], res.frequency_hz, res.status, res.steps, res.time,
                     cpu, res.q, res.v, res.xi, res, amplitudes=res.amplitude)


# ----------------------------------------------------------------------------------------------
# methods
# ----------------------------------------------------------------------------------------------
def newmark_reference(bench: Bench) -> MethodRun:
    """The paper's setting: dt 1 ms, small start, Newton refreshed every step, 2 iterations."""
    integ = Newmark(dt=1e-3, iterations=2, refresh_every=1, tol=1e-3, threads=1)
    return _marched(bench, integ, {**PAPER_START, "start": "small", "static_manifold": False})


#: the new time marching: error-controlled steps from 2 ms. The γ = 0 LCOs' amplitude error is
#: the step's: their 5th/6th harmonics straddle lightly damped 10–11 Hz modes, whose period
#: error (ω dt)²/12 detunes the resonance (fixed steps from the converged orbit: +0.3 % at 2 ms,
#: +0.8 % at 3 ms at 4,000 ft; the damped γ = 1e-3 LCOs: < 0.02 % at 3 ms), so step_tol 2e-5
#: (2–3 ms at γ = 0, 3.5–4.5 ms at γ = 1e-3; 3e-5: 0.53 % at 4,000 ft). No amplitude jumps: the
#: scaled state overshoots the limit (+1.2 % at 8,500 ft γ = 1e-3), a damped LCO is then
#: accepted on the way back, and on this set they save no steps. 2 Newton iterations: at these
#: steps the same steps and amplitudes as 3, ~17 % less CPU. The first step 2 ms: the error
#: control reaches it after one check interval anyway.
ADAPTIVE = {"dt": 2e-3, "iterations": 2, "refresh_every": 1, "tol": 1e-3, "threads": 1,
            "adaptive": True, "step_tol": 2e-5, "check_every": 250, "extrapolate": 0}
#: the start of ``newmark``: mode 1 with the tip at 10 % of span, dual coordinates on the
#: static manifold (the LCOs lie between 5 % and 25 % of span)
START_SPAN_FRACTION = 0.10


#: ``newmark-fast``: the former ``newmark`` steps (3–6.5 ms) and jumps
ADAPTIVE_FAST = {**ADAPTIVE, "dt": 1e-3, "step_tol": 5e-5, "extrapolate": 3}


def _large_start(bench: Bench) -> dict:
    q0 = START_SPAN_FRACTION * bench.model.span / bench.model.rom.outputs[OUTPUT][0]
    return {"q0": q0, "mode": 1, "start": "small", "static_manifold": True}


def newmark_default(bench: Bench) -> MethodRun:
    """Every case from a 10 %-of-span start on the static manifold, error-controlled steps;
    all cases in one batch."""
    return _marched(bench, Newmark(**ADAPTIVE), _large_start(bench))


def newmark_fast(bench: Bench) -> MethodRun:
    """The ``newmark`` start with the coarser :data:`ADAPTIVE_FAST` steps and jumps."""
    return _marched(bench, Newmark(**ADAPTIVE_FAST), _large_start(bench))


def newmark_neighbour(bench: Bench) -> MethodRun:
    """The same steps, warm starts along the altitude (waves of one case per γ)."""
    return _marched(bench, Newmark(**ADAPTIVE), {**_large_start(bench), "start": "neighbour",
                                                 "along": "altitude_ft"})


def newmark_hb(bench: Bench) -> MethodRun:
    """The same steps, every case started on its harmonic-balance orbit (``[initial] start =
    "hb"``, :func:`torchrom.study.starts.hb_start`); the orbits' solve counts in the CPU time."""
    return _marched(bench, Newmark(**ADAPTIVE), {**_large_start(bench), "start": "hb"})


# --- harmonic balance (issue 13) ----------------------------------------------------------------
def harmonic_balance(bench: Bench, seed: str = "unconverged",
                     method: HarmonicBalanceMethod | None = None) -> MethodRun:
    """Periodic orbits by harmonic balance (:class:`torchrom.periodic.HarmonicBalanceMethod`,
    the sweep's ``method = "hb"`` with its defaults: adaptive H 5..9, neighbour chains along
    the altitude, Floquet stability of every orbit, time-integration seeds for the
    unconverged cases): cold starts and stability included. ``seed = "unresolved"`` (method
    ``hb-unresolved``, the paper study's setting) also seeds the LCOs not accepted in H."""
    method = method or HarmonicBalanceMethod(seed=seed)

    def run():
        chains, positions = neighbour_chains(bench.cases)
        return method.run(bench.system(), outputs=bench.outputs, lco=PAPER_LCO, chains=chains,
                          positions=positions)

    res, cpu = _timed(run)
    nan = np.full(len(bench.cases), np.nan)
    return MethodRun(res.amplitude[:, 0], res.frequency_hz, res.status, res.steps, nan, cpu,
                     res.q, res.v, None, res, amplitudes=res.amplitude)


def shooting(bench: Bench) -> MethodRun:
    """The sweep's ``method = "shooting"`` (:class:`torchrom.study.solvers.Shooting`): the
    ``hb`` method's orbits without Floquet as the predictor, every LCO then finished to the
    discrete orbit by the certificate (``always_finish``; its CPU counted as for the others)."""
    run = harmonic_balance(bench, method=Shooting.predictor(HarmonicBalanceMethod()))
    return dataclasses.replace(run, always_finish=True)


#: the cap of ``hb-raised``'s re-solves (9 -> 19 -> 31; the issue suggested 25-31)
RAISED_HARMONICS = 31


def hb_raised(bench: Bench) -> MethodRun:
    """The ``hb`` method certified with ``[certificate] max_harmonics`` =
    :data:`RAISED_HARMONICS` (:mod:`torchrom.periodic.raise_harmonics`)."""
    return dataclasses.replace(harmonic_balance(bench), max_harmonics=RAISED_HARMONICS)


def hb_slow(bench: Bench) -> MethodRun:
    """The ``hb`` method certified with ``[certificate] slow = true``: the rows the Fourier
    certificate refuses offered to the slow certificate (:mod:`torchrom.periodic.
    slow_certificate`) before shooting."""
    return dataclasses.replace(harmonic_balance(bench), slow=True)


#: the reference's harmonic ladder: adaptive up to H = 13 (amplitude change 1e-4), then every
#: LCO seeded by time integration and raised up to H = 25 (torchrom.periodic.seed: the updated
#: wing's γ = 0 LCOs need H ≈ 17–25), the highest converged H kept (:func:`_raised_to_top`)
REFERENCE_HARMONICS = 13
#: longest time integration (s) of the reference check from the HB orbits
REFERENCE_CHECK_T_END = 20.0


def _raised_to_top(system, r: torch.Tensor, orb, opts: HBOptions):
    """``orb`` with every LCO below the top of the seed ladder (H = 25) also solved up that
    ladder (:func:`torchrom.periodic.seed.seeded_orbits`), its orbit taken where that converged
    at a higher H. Convergence in H is not monotone near a structural resonance: at 7,000 ft,
    γ = 0 the H = 11 → 13 amplitude change fell below 1e-4 by chance on an orbit 0.65 % from
    the H = 25 one (and from Newmark at dt 0.25 ms), which a reference must not accept."""
    low = np.flatnonzero((orb.status == "lco") & (orb.harmonics < SEED_HARMONICS[-1]))
    if low.size == 0:
        return orb
    t = torch.as_tensor(low)
    s = seeded_orbits(system.select(t), r, orb.X[t], orb.omega[t], np.ones(low.size, bool),
                      opts)
    take = (s.status == "lco") & (s.harmonics > orb.harmonics[low])
    return merge_seeded(orb, low, s, take)


def hb_reference(bench: Bench) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """(amplitude, frequency, check): HB at :data:`REFERENCE_HARMONICS` with tight tolerances,
    checked against fixed-step Newmark at dt = 0.25 ms started on the HB orbits and run until
    its amplitude holds (``check`` holds the per-case differences)."""
    opts = HBOptions(start_harmonics=5, harmonics=5, max_harmonics=REFERENCE_HARMONICS,
                     amplitude_rtol=1e-4)
    system = bench.system()
    chains, positions = neighbour_chains(bench.cases)
    r = torch.as_tensor(np.asarray(system.rom.outputs[OUTPUT]))
    orb = solve_orbits(system, r.numpy(), opts, chains=chains, positions=positions)
    # the orbits not converged in H by then: from a short time integration, up to H = 25
    orb, _ = seed_unresolved(system, r, orb, opts)
    orb = _raised_to_top(system, r, orb, opts)
    row = r[None]
    amp = orb.amplitude(row)[:, 0]
    freq = orb.frequency_hz
    ok = orb.status == "lco"
    q0, v0, xi0 = orbit_state(system, orb.X, orb.omega)
    # until the amplitude holds to 1e-4 per cycle: the large γ = 0 orbits take 3–10 s of
    # simulated time to settle on the integrator's own LCO (a window of a few periods ends
    # them "unconverged", which the table reports as NaN)
    integ = Newmark(dt=2.5e-4, iterations=3, refresh_every=1, tol=1e-3, threads=1,
                    check_every=2000)
    res = integ.run(system, q0, v0, xi0, t_end=REFERENCE_CHECK_T_END, outputs=[OUTPUT],
                    lco=LCOCriteria(rtol=1e-4, cycles=4, max_amplitude=10.0))
    check = [{"altitude_ft": c["altitude_ft"], "gamma": c["gamma"],
              "hb_harmonics": int(orb.harmonics[i]),
              "hb_amplitude": float(amp[i]), "newmark_025ms_amplitude":
              float(res.amplitude[i, 0]), "amplitude_diff_pct":
              float(100 * (res.amplitude[i, 0] / amp[i] - 1)), "frequency_diff_pct":
              float(100 * (res.frequency_hz[i] / freq[i] - 1))}
             for i, c in enumerate(bench.cases) if ok[i]]
    return (np.where(ok, amp, np.nan), np.where(ok, freq, np.nan), check)


METHODS: dict[str, Callable[[Bench], MethodRun]] = {
    "newmark-reference": newmark_reference,
    "newmark": newmark_default,
    "newmark-neighbour": newmark_neighbour,
    "newmark-hb": newmark_hb,
    "newmark-fast": newmark_fast,
    "hb": harmonic_balance,
    "hb-unresolved": lambda bench: harmonic_balance(bench, seed="unresolved"),
    "shooting": shooting,
    "hb-raised": hb_raised,
    "hb-slow": hb_slow,
}
#: run by default (``--methods`` adds others)
DEFAULT_METHODS = ("newmark-reference", "newmark", "hb", "hb-unresolved", "shooting")


#: every method's LCOs are certified as a sweep certifies them (the certificate's step: the
#: paper's 1 ms), the certification's CPU time counted in the method's
CERTIFICATE = Certificate()
CERTIFICATE_DT = 1e-3


def certified(bench: Bench, run: MethodRun) -> MethodRun:
    """``run`` with every LCO certified (finished by shooting where its certificate fails,
    ``lco_uncertified`` where that fails too), the CPU time of the certificate added."""
    rows = bench.rows
    cert = dataclasses.replace(CERTIFICATE, always_finish=run.always_finish,
                               max_harmonics=run.max_harmonics, slow=run.slow)
    res, cpu = _timed(lambda: certify(bench.system(), run.result, rows, 0, cert,
                                      CERTIFICATE_DT))
    return dataclasses.replace(run, amplitude=res.amplitude[:, 0], amplitudes=res.amplitude,
                               frequency_hz=res.frequency_hz,
                               status=res.status, cpu_s=run.cpu_s + cpu, result=res,
                               certificate={k: res.extra[k] for k in CERT_COLUMNS},
                               certificate_cpu_s=cpu)


def certificate_floor(bench: Bench, run: MethodRun) -> dict:
    """The CPU seconds per LCO of the certificate's evaluations alone on ``run``'s orbits (one
    shooting evaluation at h and one at 2h, no finish; the batch of all cases): what any
    certified LCO costs at least, whatever method found it — and so the largest speed-up over
    ``newmark-reference`` a method can reach even if it found its orbits for free and none
    needed a finish."""
    rows = bench.rows
    lco = int(np.sum(run.result.status == "lco"))
    out = {}
    for name, cert in (("evaluations_h_2h", dataclasses.replace(CERTIFICATE, finish=False,
                                                                fourier=False)),
                       ("evaluation_h", dataclasses.replace(CERTIFICATE, finish=False,
                                                            richardson=False, fourier=False))):
        _, cpu = _timed(lambda c=cert: certify(bench.system(), run.result, rows, 0, c,
                                               CERTIFICATE_DT))
        out[f"{name}_cpu_s_per_lco"] = cpu / max(lco, 1)
    if run.result.orbits is not None:
        # the Fourier certificate alone (torchrom.periodic.fourier_certificate), every LCO
        idx = np.flatnonzero(run.result.status == "lco")
        cols = {k: np.full(len(run.result.status), np.nan if k not in (
            "certified", "certificate", "stable", "finished") else None, dtype=object)
            for k in CERT_COLUMNS}
        ok, cpu = _timed(lambda: fourier_rows(bench.system(), run.result, idx, rows, 0,
                                              CERTIFICATE.tol, cols))
        out["fourier_cpu_s_per_lco"] = cpu / max(lco, 1)
        out["fourier_certified"] = int(np.sum(ok))
    return out


def shooting_reference(bench: Bench, start: MethodRun) -> tuple[np.ndarray, np.ndarray, dict]:
    """(amplitude (B, O), frequency, meta): the continuous-time orbit of every case (every output
    of :attr:`Bench.outputs`) by shooting on the
    discrete Newmark map at h = 1 ms and 2 ms from ``start``'s certified orbits and Richardson
    extrapolation (Newmark is second order): A = A(h) + (A(h) − A(2h))/3 — the steps of the
    certificate. (At 0.5 ms the 7,000 ft, γ = 0 case converged to an orbit 0.3 % below the
    1 ms one with another critical multiplier, 0.970 against 0.989: the near-resonant γ = 0
    orbits are not in Newmark's asymptotic range at every step; see the closing note.)"""
    system = bench.system()
    rows = bench.rows[0]
    res = start.result
    ok = np.flatnonzero(np.isin(res.status, ("lco", "lco_uncertified")))
    t = torch.as_tensor(ok)
    sub = system.select(t)
    f = np.asarray(res.frequency_hz)[ok]
    x = OrbitStart(torch.as_tensor(res.q[ok]), torch.as_tensor(res.v[ok]),
                   torch.as_tensor(np.zeros((ok.size, system.n_lag)) if res.xi is None
                                   else res.xi[ok]), torch.as_tensor(1 / f))
    if res.orbits is not None:
        from torchrom.periodic.shooting import start_from_fourier

        X, w = res.orbits
        x = start_from_fourier(sub, torch.as_tensor(X[ok]), torch.as_tensor(w[ok]), rows)
    out = {}
    for h in (1e-3, 2e-3):
        r = shoot(sub, x, rows, rows=bench.rows,
                  options=ShootingOptions(dt=h, max_iterations=30))
        out[h] = r
        x = r.start()
    a1, a2 = out[1e-3].amplitude, out[2e-3].amplitude  # (m, O)
    f1, f2 = out[1e-3].frequency_hz, out[2e-3].frequency_hz
    conv = out[1e-3].converged & out[2e-3].converged
    amp = np.full((len(bench.cases), a1.shape[1]), np.nan)
    freq = np.full(len(bench.cases), np.nan)
    amp[ok] = np.where(conv[:, None], a1 + (a1 - a2) / 3, np.nan)
    freq[ok] = np.where(conv, f1 + (f1 - f2) / 3, np.nan)
    meta = {"richardson_amplitude_change_pct": [float(v) for v in 100 * (a1[:, 0] / a2[:, 0]
                                                                         - 1)],
            "stable": [None if s is None else bool(s) for s in out[1e-3].stable],
            "critical_multiplier": [float(v) for v in out[1e-3].critical_multiplier]}
    return amp, freq, meta


# ----------------------------------------------------------------------------------------------
def case_set(quick: bool) -> list[dict]:
    alts = np.arange(4000.0, 10001.0, 1500.0 if quick else 1000.0)
    gammas = (0.0, 1e-3) if quick else (0.0, 1e-4, 1e-3)
    return [{"altitude_ft": float(a), "gamma": g, "alpha": "matched"} for g in gammas
            for a in alts]


def summarize(name: str, run: MethodRun, cases: list[dict], ref_amp: np.ndarray,
              ref_freq: np.ndarray, outputs: list[str]) -> dict:
    """The method's row: CPU, certification and errors against the reference; ``ref_amp``
    (B, O) for every output of ``outputs``, the decision output first (a Fourier-certified
    row's ``output_error`` must bound every one of them)."""
    lco = run.status == "lco"
    amps = run.amplitudes if run.amplitudes is not None else run.amplitude[:, None]
    out_err = np.where(lco[:, None], 100 * np.abs(amps / ref_amp[:, : amps.shape[1]] - 1),
                       np.inf)  # (B, O): every output's
    amp_err = out_err[:, 0]
    freq_err = np.where(lco, 100 * np.abs(run.frequency_hz / ref_freq - 1), np.inf)
    cert = run.certificate or {}
    nan = np.full(len(cases), np.nan)
    orbit_err = 100 * np.asarray(cert.get("orbit_error", nan), dtype=float)
    dt_err = 100 * np.asarray(cert.get("dt_error", nan), dtype=float)
    certified = np.array([c is True for c in cert.get("certified", [None] * len(cases))])
    stable = list(cert.get("stable", [None] * len(cases)))
    kind = list(cert.get("certificate", [None] * len(cases)))
    # certified by a bound on the distance to the continuous-time orbit (no time step)
    fourier = np.array([k in ("fourier", "slow") for k in kind])
    # the certificate must bound the measured error: its estimates are first order (one Newton
    # evaluation at h and one at 2h; 5 % slack) and it resolves nothing below a finish's own
    # stopping point, FINISH_TOL × tol in relative amplitude (1e-5: a finished orbit is placed
    # no closer). Measured on the newmark rows: the one-evaluation estimates are within 5–25 %
    # of the converged distances, which at corrections of ~1e-5 is ~1e-6 — below that floor
    resolution = 100 * FINISH_TOL * CERTIFICATE.tol
    # a Fourier certificate bounds the distance to the continuous-time orbit itself (no 5 %
    # slack, no finish): the reference's own error (Richardson on the discrete orbits, below
    # 1e-5 relative on the damped orbits it certifies) is the only allowance
    output_bound = 100 * np.asarray(cert.get("output_error", nan), dtype=float)
    freq_bound = 100 * np.asarray(cert.get("frequency_error", nan), dtype=float)
    fourier_ok = (amp_err <= orbit_err + resolution) & (
        out_err <= output_bound[:, None] + resolution).all(axis=1) & (
        freq_err <= freq_bound + resolution)
    # a shooting row's every output and its frequency by the same first-order estimates
    shooting_ok = (amp_err <= 1.05 * (orbit_err + dt_err) + resolution) & (
        out_err <= 1.05 * output_bound[:, None] + resolution).all(axis=1) & (
        freq_err <= 1.05 * freq_bound + resolution)
    bounded = np.where(certified, np.where(fourier, fourier_ok, shooting_ok), True)
    rows = [{**{k: v for k, v in c.items() if k != "alpha"}, "status": str(run.status[i]),
             "amplitude": float(run.amplitude[i]), "frequency_hz": float(run.frequency_hz[i]),
             "reference_amplitude": float(ref_amp[i, 0]), "reference_frequency_hz":
             float(ref_freq[i]), "amplitude_error_pct": float(amp_err[i]),
             "frequency_error_pct": float(freq_err[i]), "steps": int(run.steps[i]),
             "simulated_s": float(run.time_s[i]), "certified": bool(certified[i]),
             "orbit_error_pct": float(orbit_err[i]), "dt_error_pct": float(dt_err[i]),
             "certificate_bounds_error": bool(bounded[i]),
             "stable": None if stable[i] is None else bool(stable[i]),
             "critical_multiplier": float(np.asarray(cert.get("critical_multiplier", nan))[i]),
             "finished_by_shooting": bool(cert.get("finished", [False] * len(cases))[i]
                                          is True),
             "certificate": kind[i],
             "output_errors_pct": {o: float(out_err[i, j]) for j, o in enumerate(outputs)},
             "output_error_bound_pct": float(output_bound[i]),
             "frequency_error_bound_pct": float(100 * np.asarray(
                 cert.get("frequency_error", nan), dtype=float)[i]),
             "stability_margin": float(np.asarray(cert.get("stability_margin", nan),
                                                  dtype=float)[i])}
            for i, c in enumerate(cases)]
    n_lco = int(lco.sum())
    n_cert = int(certified.sum())
    return {"method": name, "cpu_s": run.cpu_s, "certificate_cpu_s": run.certificate_cpu_s,
            "lco_cases": n_lco, "certified": n_cert,
            "cpu_s_per_lco": run.cpu_s / n_lco if n_lco else float("inf"),
            "cpu_s_per_certified_lco": run.cpu_s / n_cert if n_cert else float("inf"),
            "steps_per_lco": float(run.steps.sum() / n_lco) if n_lco else float("inf"),
            "max_amplitude_error_pct": float(np.nanmax(amp_err)),
            "max_frequency_error_pct": float(np.nanmax(freq_err)),
            "max_output_error_pct": {o: float(np.nanmax(out_err[:, j]))
                                     for j, o in enumerate(outputs)},
            "max_orbit_error_pct": float(np.nanmax(np.where(certified, orbit_err, np.nan)))
            if n_cert else float("nan"),
            "certificates_bound_errors": bool(bounded.all()),
            "fourier_certified": int((fourier & certified).sum()),
            "stability_unknown": int(sum(1 for i in range(len(cases))
                                         if lco[i] and stable[i] is None)),
            "cases": rows}


def load_model(folder: Path | None):
    from torchrom.paper.pipeline import goland_pipeline
    from torchrom.paper.study import FULL_PIPELINE

    if folder is None:
        env = os.environ.get("TORCHROM_CACHE")
        folder = Path(env) if env else Path.home() / ".cache" / "torchrom" / "goland"
    return goland_pipeline(FULL_PIPELINE, folder, log=lambda m: print(f"  {m}")).model


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="10 cases instead of 21 (< 5 min)")
    ap.add_argument("--model", type=Path, default=None, help="the Goland pipeline's cache")
    ap.add_argument("--methods", nargs="*", default=list(DEFAULT_METHODS),
                    choices=list(METHODS))
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--hb-check", action="store_true",
                    help="also HB up to H = 25 against the reference (cross-check; minutes)")
    ap.add_argument("--out", type=Path, default=HERE / "results")
    args = ap.parse_args(argv)
    torch.set_num_threads(1)
    t0 = time.perf_counter()
    bench = Bench(load_model(args.model), case_set(args.quick), args.device)
    runs = {}
    for name in dict.fromkeys(["newmark-reference", *args.methods]):
        runs[name] = certified(bench, METHODS[name](bench))
        print(f"{name}: {runs[name].cpu_s:.1f} CPU s, statuses "
              f"{dict(zip(*np.unique(runs[name].status, return_counts=True)))}", flush=True)
    # the reference: the continuous-time orbit (shooting at 1 and 0.5 ms, Richardson) from the
    # orbits of the most accurate method run
    best = next(m for m in ("hb-unresolved", "hb", "newmark", "newmark-reference") if m in runs)
    ref_amp, ref_freq, ref_meta = shooting_reference(bench, runs[best])
    methods = [summarize(name, runs[name], bench.cases, ref_amp, ref_freq, bench.outputs)
               for name in runs]
    floor = certificate_floor(bench, runs[best])
    check = None
    if args.hb_check:
        _, _, check = hb_reference(bench)
        for c in check:
            i = next(j for j, k in enumerate(bench.cases) if k["altitude_ft"] ==
                     c["altitude_ft"] and k["gamma"] == c["gamma"])
            c["shooting_reference_amplitude"] = float(ref_amp[i, 0])
            c["hb_vs_shooting_reference_pct"] = float(100 * (c["hb_amplitude"] / ref_amp[i, 0]
                                                             - 1))
    base = methods[0]["cpu_s_per_certified_lco"]
    for m in methods:
        m["cpu_ratio_vs_reference_method"] = base / m["cpu_s_per_certified_lco"]
        print(f"{m['method']:20s} {m['cpu_s_per_certified_lco']:8.4f} CPU s per certified "
              f"LCO ({m['certified']}/{len(bench.cases)} certified)  "
              f"x{m['cpu_ratio_vs_reference_method']:.1f}  max errors vs the continuous "
              f"orbit: amplitude {m['max_amplitude_error_pct']:.3f} %, frequency "
              f"{m['max_frequency_error_pct']:.3f} %; max orbit_error "
              f"{m['max_orbit_error_pct']:.3f} %; certificates bound the errors: "
              f"{m['certificates_bound_errors']}; stability unknown: {m['stability_unknown']}; "
              f"Fourier-certified {m['fourier_certified']}, certificate CPU "
              f"{m['certificate_cpu_s']:.2f} s of {m['cpu_s']:.2f} s")
    floor["largest_ratio_vs_reference_method"] = base / floor[
        "evaluations_h_2h_cpu_s_per_lco"]
    print(f"certificate floor: {floor['evaluations_h_2h_cpu_s_per_lco']:.4f} CPU s per LCO "
          f"(one evaluation at h and at 2h, no finish; at h alone "
          f"{floor['evaluation_h_cpu_s_per_lco']:.4f}): no certified method can be more than "
          f"x{floor['largest_ratio_vs_reference_method']:.1f} faster than newmark-reference "
          f"with the shooting certificate; the Fourier certificate alone: "
          f"{floor.get('fourier_cpu_s_per_lco', float('nan')):.4f} CPU s per LCO, "
          f"{floor.get('fourier_certified', 0)} certified")
    meta = machine_meta(quick=args.quick, device=args.device, threads=1, output=OUTPUT,
                        cases=len(bench.cases),
                        reference="the continuous-time orbit: shooting on the discrete Newmark "
                        f"map at h = 1 ms and 2 ms from the certified orbits of {best!r}, "
                        "Richardson-extrapolated (A(h) + (A(h) - A(2h))/3)",
                        reference_detail=ref_meta,
                        certificate=dataclasses.asdict(CERTIFICATE)
                        | {"dt": CERTIFICATE_DT},
                        hb_reference_check=check, wall_s=time.perf_counter() - t0,
                        certificate_floor=floor,
                        bound_check="for a shooting-certified row the decision output's "
                        "error <= 1.05 (orbit_error + dt_error), every output's <= 1.05 "
                        "output_error and the frequency's <= 1.05 frequency_error, each + "
                        f"{100 * FINISH_TOL * CERTIFICATE.tol:g} % (the certificate's "
                        "resolution, FINISH_TOL x tol); for a Fourier- or slow-certified row "
                        "every output's amplitude error <= output_error and the frequency "
                        "error <= frequency_error, each + "
                        f"{100 * FINISH_TOL * CERTIFICATE.tol:g} % (the reference's own "
                        "resolution)")
    args.out.mkdir(parents=True, exist_ok=True)
    path = args.out / "bench_lco.json"
    path.write_text(json.dumps({"meta": meta, "methods": methods}, indent=1, default=float)
                    + "\n")
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
