"""A certificate for every LCO, whatever method found it: one shooting evaluation from its orbit.

A harmonic-balance row is first offered to the Fourier certificate (:func:`fourier_rows`,
:mod:`.fourier_certificate`: a bound on its distance to the continuous-time orbit, no time
integration; ``certificate`` "fourier"); the rows it refuses and every time-marching row
carry the shooting certificate below (``certificate`` "shooting"). With
``Certificate.max_harmonics`` a refused row is first re-solved at H → 2H + 1 harmonics up to
that cap and offered again (:mod:`.raise_harmonics`); with ``Certificate.slow`` it is then
offered to the slow certificate (:func:`slow_rows`, :mod:`.slow_certificate`: ``certificate``
"slow", the row reporting that certificate's corrected orbit).

For each LCO row of a :class:`~torchrom.sim.SimulationResult` (harmonic balance orbits, or the
final state of a time integration) the discrete periodic orbit of the Newmark map at the
certificate's step h (:mod:`.shooting`) is evaluated once from the method's orbit:

- ``orbit_error``: the relative change of the decision output's amplitude that the Newton
  correction makes — how far the reported orbit is from the exact discrete orbit; for a
  continuous-time orbit (harmonic balance) from the Richardson extrapolation of the discrete
  orbits at h and 2h, the continuous orbit to third order in h;
- ``dt_error``: the discretisation error of the discrete orbit's amplitude by Richardson on
  three steps (:func:`richardson_error`): |A(2h) − A(h)| / (3 A(h)) (Newmark is second order)
  where every output and the frequency of the row show Newmark's h² law from h, 2h and 4h
  (:data:`ASYMPTOTIC_RATIO`), else the spread of the three discrete orbits; A(2h), A(4h) from
  one shooting evaluation each (half and a quarter of the steps of one at h);
- ``stable``, ``critical_multiplier``, ``trivial_multiplier_error``: from the monodromy
  (the stability of record);
- ``certified``: ``orbit_error`` ≤ ``tol`` (a time integration's row is taken as it is only
  within :data:`MARCHED_ACCEPT` × ``tol``: its estimate is one Newton step's). Otherwise the
  orbit is finished by shooting
  (``finish``; the row then reports the discrete orbit, its state in ``q``, ``v``, ``xi``,
  ``finished`` True) or its status
  becomes ``lco_uncertified`` with its numbers kept. An orbit whose start leaves the
  stability unknown (trivial multiplier not resolved) is finished too. A row whose
  ``dt_error`` exceeds ``dt_tol`` is ``lco_uncertified`` as well: the step does not resolve
  the orbit (near a resonance of a lightly damped mode with a harmonic of the LCO the map at h
  can have an orbit the map at 2h has not — on the Goland γ = 0 branch at 4,388 ft a finish
  from a neighbour reached an unstable discrete orbit, |μ| = 1.13, whose 2h evaluation moved
  the state by 217 times its size and gave a dt_error of 41 %), and Richardson's estimate is
  outside its asymptotic range.

The evaluation at h and the finish are one shooting pass (the finish's first Newton iteration
is the certificate's evaluation; a Fourier orbit's coarse amplitude at 2h is evaluated first,
so that the pass can judge it against the extrapolation); a finished orbit's dt_error comes
from one more evaluation at 2h from the discrete orbit.

The true amplitude lies within (orbit_error + dt_error) × amplitude of the reported one, to
first order. Every other output and the frequency are estimated alike, from the same passes
(the outputs' sensitivities to the start ride along the monodromy): ``output_error`` is the
largest over the outputs of each one's distance to the discrete orbit (the first Newton
correction's, or the finish's last) plus its Richardson term, ``frequency_error`` the same for
the frequency (for a finished row mostly Newmark's own period error at h).

Written here: the certificate composes this project's own solvers.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import torch

from ..checks import integer, real
from ..errors import InputError
from ..sim.result import SimulationResult
from ..sim.system import CaseSystem
from .floquet import condensed_multiplier
from .fourier_certificate import fourier_bound
from .raise_harmonics import raise_rows
from .shooting import OrbitStart, ShootingOptions, shoot, start_from_fourier
from .slow_certificate import applies, slow_certificate

#: status of an LCO whose certificate failed and that shooting could not finish
UNCERTIFIED = "lco_uncertified"
#: a finish's scaled-correction tolerance as a fraction of the certificate's ``tol`` (Newton
#: converges quadratically there: one more iteration would move the orbit by ~1e-10)
FINISH_TOL = 1e-2
#: a time-marching row's distance to the discrete orbit (``orbit_error``) is its first Newton
#: step's estimate, exact to first order in that distance: on bench_lco's 8,500 ft, γ = 0 row
#: the estimate fell 13 % short at 3.4e-4 (0.0336 % against 0.0387 % from the finished discrete
#: orbit), and the row's bound with it. Such a row is accepted on the estimate only below this
#: fraction of ``tol`` (the shortfall, quadratic in the distance, then ~1 % of it), else
#: finished to the discrete orbit. A Fourier orbit's estimate is against the Richardson
#: extrapolation, whose own error its ``dt_error`` states: accepted up to ``tol``
MARCHED_ACCEPT = 0.1
#: the certificate's columns (every row of a certified table has them)
COLUMNS = ("certified", "certificate", "orbit_error", "dt_error", "output_error",
           "frequency_error", "stable", "critical_multiplier", "stability_margin",
           "trivial_multiplier_error", "finished", "shooting_iterations")


@dataclass(frozen=True)
class Certificate:
    """How LCO rows are certified (module docstring).

    Attributes:
        enabled: certify at all (False: the columns are NaN, statuses unchanged).
        tol: largest ``orbit_error`` (relative amplitude) of a certified LCO.
        finish: finish an uncertified orbit by shooting (else ``lco_uncertified``).
        richardson: compute ``dt_error`` (one more evaluation at 2h, half the steps).
        dt: the step of the discrete orbit (s); None: the run's integrator step.
        max_iterations: Newton iterations of a finish (the Goland γ = 0 orbits of harmonic
            balance at H ≤ 9, 1.5–3.5 % off, need more than 12).
        always_finish: finish every LCO to the discrete orbit, also those within ``tol`` (the
            shooting solver's rows are discrete orbits, not its predictor's).
        dt_tol: largest ``dt_error`` (relative amplitude) of a certified LCO (with
            ``richardson``): the discrete orbit's own estimate of its distance from the
            continuous one; above it the step does not resolve the orbit and the O(h⁴) terms
            Richardson drops are not small (module docstring). Near a Hopf point, where the
            amplitude goes to zero and the discrete map's Hopf point is O(h²) away, the
            relative dt_error of the smallest orbits grows past a few per cent (7.8 % at 1 %
            of the amplitude scale on the subcritical oscillator of ``torchrom branch``).
        fourier: certify a harmonic-balance row by the Fourier certificate first
            (:mod:`.fourier_certificate`: a bound on its distance to the continuous-time
            orbit, no time integration); the shooting certificate takes the rows it fails.
        max_harmonics: re-solve a harmonic-balance row the Fourier certificate refuses at
            H → 2H + 1 harmonics, up to this many, and certify it again before shooting
            (:mod:`.raise_harmonics`); 0: never. Off by default: on the Goland γ = 0 rows the
            re-solve at H = 29 was 0.7 CPU s per orbit and its certificate 0.43 s, more than
            the shooting finish (~0.5–1 s), and the certificate still refused every one.
        slow: offer the harmonic-balance rows the Fourier certificate refuses to the slow
            certificate (:mod:`.slow_certificate`: the slow motion certified with the stiff
            dual coordinates eliminated, the neglected fast dynamics bounded; certificate
            "slow"; the row then reports the certificate's corrected orbit) before shooting.
            Off by default: on ``bench_lco --quick`` it certifies the γ = 1e-3 rows (which the
            Fourier certificate takes first) and the 10,000 ft, γ = 0 one (also Fourier's),
            and refuses the 4,000–8,500 ft, γ = 0 rows (κ = 0.19–0.80, or A_Tz's bound
            3.1e-3 above ``tol``), at ~0.1 CPU s per row: no row moves off shooting.
    """

    enabled: bool = True
    tol: float = 1e-3
    finish: bool = True
    richardson: bool = True
    dt: float | None = None
    max_iterations: int = 20
    always_finish: bool = False
    dt_tol: float = 0.1
    fourier: bool = True
    max_harmonics: int = 0
    slow: bool = False

    def __post_init__(self):
        for name in ("enabled", "finish", "richardson", "always_finish", "fourier", "slow"):
            if not isinstance(getattr(self, name), bool):
                raise InputError(f"certificate.{name}: expected true or false, got "
                                 f"{getattr(self, name)!r}")
        real("certificate.tol", self.tol, positive=True)
        real("certificate.dt_tol", self.dt_tol, positive=True)
        if self.dt is not None:
            real("certificate.dt", self.dt, positive=True)
        integer("certificate.max_iterations", self.max_iterations, minimum=1)
        integer("certificate.max_harmonics", self.max_harmonics, minimum=0)

    def options(self, dt: float, iterations: int, marched: bool = False) -> ShootingOptions:
        """The shooting options of the certificate's pass: a finish stops when the scaled
        Newton correction is below :data:`FINISH_TOL` × ``tol`` (every state component within
        that fraction of its largest value on the orbit: its amplitude then moves far less
        than ``tol``, and the row's ``orbit_error`` is that last correction's amplitude
        change). A row is accepted without a finish within ``tol`` of its estimated discrete
        orbit, a time integration's (``marched``) within :data:`MARCHED_ACCEPT` × ``tol``."""
        accept = self.tol * (MARCHED_ACCEPT if marched else 1.0)
        return ShootingOptions(dt=dt, max_iterations=iterations, tol=FINISH_TOL * self.tol,
                               accept=None if self.always_finish else accept)


def _starts(system: CaseSystem, result: SimulationResult, idx: np.ndarray, row
            ) -> OrbitStart:
    """The method's orbits of the cases ``idx`` of ``result`` as shooting starts (``system``:
    those cases alone)."""
    if result.orbits is not None:
        X, w = result.orbits
        return start_from_fourier(system, torch.as_tensor(X[idx]), torch.as_tensor(w[idx]), row)
    na = system.n_lag
    xi = (np.zeros((len(idx), na)) if result.xi is None else result.xi[idx])
    f = np.asarray(result.frequency_hz, dtype=float)[idx]
    return OrbitStart(torch.as_tensor(result.q[idx], dtype=torch.float64),
                      torch.as_tensor(result.v[idx], dtype=torch.float64),
                      torch.as_tensor(xi, dtype=torch.float64).reshape(len(idx), na),
                      torch.as_tensor(1.0 / f, dtype=torch.float64))


def _state(start: OrbitStart) -> tuple:
    return start.q, start.v, start.xi, start.period


@dataclass(frozen=True)
class _Discrete:
    """The discrete orbit at some step near a start, to second order in the start's distance
    (one shooting evaluation): every output's amplitude (b, O) and the frequency (b,) Hz."""

    amplitudes: np.ndarray
    frequency_hz: np.ndarray

    @classmethod
    def of(cls, r, start_period) -> _Discrete:
        """From the first pass of shooting result ``r`` (starts of period ``start_period``)."""
        period = r.first_order_period(np.asarray(start_period.cpu(), dtype=float))
        return cls(r.first_order_amplitudes(), 1.0 / period)

    def select(self, rows: np.ndarray) -> _Discrete:
        return _Discrete(self.amplitudes[rows], self.frequency_hz[rows])


def _coarse(system: CaseSystem, state: tuple, c, C: np.ndarray, h: float) -> _Discrete:
    """The discrete orbit at 2h near ``state`` (one evaluation: half the steps of one at h;
    called with 2h for 4h)."""
    r = shoot(system, OrbitStart(*state), c, rows=C,
              options=ShootingOptions(dt=2 * h, max_iterations=0))
    return _Discrete.of(r, state[3])


def _continuous_columns(cols: dict, g: np.ndarray, kind: str, rel: np.ndarray, decision: int,
                        frequency_error: np.ndarray, stable: np.ndarray,
                        critical: np.ndarray, trivial_error: np.ndarray) -> None:
    """Fill the columns of rows ``g`` certified by a bound on their distance to the
    continuous-time orbit (certificate ``kind``): ``rel`` (len(g), O) each output's relative
    amplitude bound, then the frequency bound and the Floquet verdict."""
    cols["certified"][g] = True
    cols["certificate"][g] = kind
    cols["orbit_error"][g] = rel[:, decision]
    cols["dt_error"][g] = 0.0  # a distance to the continuous-time orbit itself
    cols["output_error"][g] = np.nanmax(rel, axis=1)
    cols["frequency_error"][g] = frequency_error
    cols["stable"][g] = stable
    cols["critical_multiplier"][g] = critical
    cols["stability_margin"][g] = 1.0 - critical
    cols["trivial_multiplier_error"][g] = trivial_error
    cols["finished"][g] = False


def fourier_rows(system: CaseSystem, result: SimulationResult, idx: np.ndarray,
                  C: np.ndarray, decision: int, tol: float, cols: dict) -> np.ndarray:
    """Which of the harmonic-balance rows ``idx`` the Fourier certificate certifies
    (:mod:`.fourier_certificate`; their columns filled in ``cols``): the chord steps contract
    (κ ≤ 1/4), the decision output's amplitude (the smaller of the sup-distance bound and the
    corrected orbit's, :meth:`~.fourier_certificate.FourierBound.amplitude_error`) and the
    frequency are within ``tol`` of the continuous-time orbit's, and the method's Floquet
    verdict (the continuous-time monodromy of :mod:`.floquet`) is known with its margin
    |1 − |μ|| above the monodromy's own accuracy (its trivial multiplier's error). The row's
    critical multiplier and margin include the dual coordinates the monodromy condensed
    (:func:`~.floquet.condensed_multiplier`)."""
    ok = np.zeros(idx.size, dtype=bool)
    extra = result.extra
    if not all(k in extra for k in ("harmonics", "stable", "floquet_multiplier",
                                    "floquet_error")):
        return ok
    X, w = result.orbits
    H = np.asarray(extra["harmonics"], dtype=int)[idx]
    mult = np.asarray(extra["floquet_multiplier"], dtype=float)[idx]
    ferr = np.asarray(extra["floquet_error"], dtype=float)[idx]
    stable = np.asarray(extra["stable"], dtype=object)[idx]
    known = np.array([isinstance(v, (bool, np.bool_)) for v in stable])
    with np.errstate(invalid="ignore"):
        resolved = known & (np.abs(1.0 - mult) > ferr)
    for h in np.unique(H[resolved & (H > 0)]):
        j = np.flatnonzero(resolved & (H == h))
        rows = idx[j]
        bound = fourier_bound(system.select(torch.as_tensor(rows)),
                              torch.as_tensor(X[rows, : 2 * h + 1]), torch.as_tensor(w[rows]),
                              C[decision], C)
        a = np.abs(np.asarray(result.amplitude, dtype=float)[rows])
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(a > 0, bound.amplitude_error(a) / a, np.nan)
        good = bound.converged & (rel[:, decision] <= tol) & (bound.frequency_error <= tol)
        ok[j] = good
        g = rows[good]
        if g.size == 0:
            continue
        # the continuous-time system's critical multiplier: the slow state's (the method's
        # monodromy) or that of the dual coordinates it condensed, whichever is larger
        crit = np.maximum(mult[j][good], condensed_multiplier(
            system.select(torch.as_tensor(g)).to(dtype=torch.float64),
            torch.as_tensor(X[g, : 2 * h + 1]), torch.as_tensor(w[g])))
        _continuous_columns(cols, g, "fourier", rel[good], decision,
                            bound.frequency_error[good], stable[j][good], crit, ferr[j][good])
    return ok


def _raised_fourier_rows(system: CaseSystem, result: SimulationResult, refused: np.ndarray,
                         C: np.ndarray, decision: int, certificate: Certificate, cols: dict
                         ) -> tuple[SimulationResult, np.ndarray]:
    """(result, refused): the harmonic-balance rows ``refused`` by the Fourier certificate
    re-solved at H → 2H + 1 harmonics up to ``certificate.max_harmonics`` and certified again
    (:mod:`.raise_harmonics`), until each is certified, its re-solve fails or H is at the cap;
    the rows still refused (a kept re-solve stays in the result: a start nearer the
    continuous-time orbit for the shooting certificate)."""
    if "harmonics" not in result.extra:
        return result, refused
    todo = refused
    while todo.size and certificate.max_harmonics:
        result, kept = raise_rows(system, result, todo, C, decision, certificate.max_harmonics)
        if kept.size == 0:
            break
        now = kept[fourier_rows(system, result, kept, C, decision, certificate.tol, cols)]
        refused = np.setdiff1d(refused, now)
        todo = np.setdiff1d(kept, now)
    return result, refused


def slow_rows(system: CaseSystem, result: SimulationResult, idx: np.ndarray, C: np.ndarray,
              decision: int, tol: float, cols: dict) -> tuple[SimulationResult, np.ndarray]:
    """(result, refused): the harmonic-balance rows ``idx`` offered to the slow certificate
    (:mod:`.slow_certificate`); a certified row (κ ≤ 1/4, the duals' fast series contracting,
    the decision output's amplitude and the frequency within ``tol`` of the continuous-time
    orbit's, its Floquet verdict known with a margin above the monodromy's accuracy) reports
    the certificate's corrected orbit: every output's amplitude, the frequency and the state
    at τ = 0 (``finished`` False: not a discrete orbit), its columns filled in ``cols``. The
    rows it refuses are returned for shooting."""
    if idx.size == 0 or result.orbits is None:
        return result, idx
    X, w = result.orbits
    sub = system.select(torch.as_tensor(idx)).to(dtype=torch.float64)
    w_t = torch.as_tensor(w[idx], dtype=torch.float64)
    if not applies(sub, w_t):
        return result, idx
    out = slow_certificate(sub, torch.as_tensor(X[idx]), w_t, C[decision], C)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.where(out.amplitude > 0, out.amplitude_error / out.amplitude, np.nan)
        margin = np.abs(1.0 - out.critical) > out.trivial_error
    good = out.certified & (rel[:, decision] <= tol) & (out.frequency_error <= tol) & margin
    g = idx[good]
    if g.size == 0:
        return result, idx
    amp = np.array(result.amplitude, dtype=float, copy=True)
    freq = np.array(result.frequency_hz, dtype=float, copy=True)
    amp[g], freq[g] = out.amplitude[good], out.frequency_hz[good]
    q, v = np.array(result.q, dtype=float, copy=True), np.array(result.v, dtype=float, copy=True)
    xi = None if result.xi is None else np.array(result.xi, dtype=float, copy=True)
    q[g], v[g] = out.state[0][good], out.state[1][good]
    if xi is not None:
        xi[g] = out.state[2][good]
    _continuous_columns(cols, g, "slow", rel[good], decision, out.frequency_error[good],
                        out.stable[good], out.critical[good], out.trivial_error[good])
    result = dataclasses.replace(result, amplitude=amp, frequency_hz=freq, q=q, v=v, xi=xi)
    return result, idx[~good]


#: the ratio of successive differences (A(4h) − A(2h)) / (A(2h) − A(h)) inside which discrete
#: orbits are in Newmark's asymptotic range: 4 (second order) within 10 %, where the h⁴ term is
#: below ~0.7 % of the h² one and Richardson's estimate within ~3 % of the step's error. The
#: Goland γ = 0 rows show why no wider window: their errors against an RK4 ODE orbit at h =
#: 0.25, 0.5, 1, 2, 4 ms are not monotone in h (7,000 ft, A_Tz: +2.3e-4, −2.2e-3, +9.8e-4,
#: +2.0e-3, +6.7e-3; the stiff dual modes' discrete frequencies move through harmonics of the
#: LCO as h changes), with ratios 2.2–5.9 (3.30 and 4.59 among them), and Richardson fell
#: short by up to 3.4×; the damped rows' ratios are 4.04–4.32. The coarse orbits are one
#: evaluation each, exact to first order in their start's distance: where the square of it
#: hides the h² law (the oscillators of tests/test_periodic_certify.py) the row takes the
#: spread as well — valid, and looser
ASYMPTOTIC_RATIO = (3.6, 4.4)


def asymptotic(a_h: np.ndarray, a_2h: np.ndarray, a_4h: np.ndarray,
               resolution: float) -> np.ndarray:
    """Whether discrete orbits' quantities A(h), A(2h), A(4h) are in Newmark's asymptotic
    range (:func:`richardson_error`): (b,) for arrays (b,) or (b, K), a row's K together."""
    d1 = a_2h - a_h
    lo, hi = ASYMPTOTIC_RATIO
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = (a_4h - a_2h) / d1
        ok = (np.abs(d1) <= resolution * np.abs(a_h)) | ((ratio >= lo) & (ratio <= hi))
    return ok.all(axis=1) if ok.ndim > 1 else ok


def richardson_error(a_h: np.ndarray, a_2h: np.ndarray, a_4h: np.ndarray,
                     resolution: float) -> np.ndarray:
    """The relative discretisation error of the discrete orbits' quantities A(h) (amplitudes,
    frequencies) from those at 2h and 4h: Richardson's |A(2h) − A(h)| / (3 A(h)) (second order)
    where the discrete orbits are in Newmark's asymptotic range — the observed ratio
    (A(4h) − A(2h)) / (A(2h) − A(h)) within :data:`ASYMPTOTIC_RATIO`, or the difference below
    ``resolution`` (relative) — else the spread of the three, max(|A(2h) − A(h)|,
    |A(4h) − A(h)|) / A(h); NaN where an evaluation failed (on the Goland γ = 0 orbits at
    h = 2 ms the one at 8 ms does, and the difference to 4 ms alone fell short of the
    frequency's error: 2.9e-5 against 5.4e-5). With arrays (b, K), the K quantities of a row
    (its outputs' amplitudes and its frequency) are in that range together or not at all:
    one erratic quantity says the step does not resolve the orbit."""
    d1 = a_2h - a_h
    ok = asymptotic(a_h, a_2h, a_4h, resolution)
    if d1.ndim > 1:
        ok = ok[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        spread = np.maximum(np.abs(d1), np.abs(a_4h - a_h)) / np.abs(a_h)
        return np.where(ok, np.abs(d1 / a_h) / 3.0, spread)


def certify(system: CaseSystem, result: SimulationResult, rows, decision: int,
            certificate: Certificate, dt: float) -> SimulationResult:
    """``result`` with the certificate's columns (:data:`COLUMNS`) and, where an orbit was
    finished by shooting or failed its certificate, the new amplitudes, frequencies and
    statuses. ``rows`` (O, n): the result's output rows; ``decision``: the index among them
    of the output whose amplitude certifies (the LCO criteria's decision output); ``dt``: the
    run's step (used unless the certificate names its own)."""
    B = result.batch_size
    C = np.asarray(rows, dtype=float).reshape(-1, system.n)
    c = C[int(decision)]
    cols = {"certified": np.full(B, None, dtype=object),
            "certificate": np.full(B, None, dtype=object), "orbit_error": np.full(B, np.nan),
            "dt_error": np.full(B, np.nan), "output_error": np.full(B, np.nan),
            "frequency_error": np.full(B, np.nan), "stable": np.full(B, None, dtype=object),
            "critical_multiplier": np.full(B, np.nan), "stability_margin": np.full(B, np.nan),
            "trivial_multiplier_error": np.full(B, np.nan),
            "finished": np.full(B, None, dtype=object),
            "shooting_iterations": np.zeros(B, dtype=np.int64)}
    previous = result.extra.get("stable")
    if previous is not None:  # a method's own verdict (decays: the linear root's)
        cols["stable"] = np.asarray(previous, dtype=object).copy()
    status = np.asarray(result.status, dtype=object).copy()
    idx = np.flatnonzero(status == "lco")
    if not certificate.enabled or idx.size == 0:
        return dataclasses.replace(result, extra={**result.extra, **cols})
    h = float(certificate.dt if certificate.dt is not None else dt)
    if not (h > 0 and math.isfinite(h)):
        raise InputError(f"certificate.dt: expected a positive step, got {h}")
    continuous = result.orbits is not None
    if continuous and not certificate.always_finish and (certificate.fourier
                                                         or certificate.slow):
        # a Fourier orbit's own certificates first (Fourier, then the slow one); the shooting
        # one takes the rest
        if certificate.fourier:
            idx = idx[~fourier_rows(system, result, idx, C, int(decision), certificate.tol,
                                    cols)]
            result, idx = _raised_fourier_rows(system, result, idx, C, int(decision),
                                               certificate, cols)
        if certificate.slow and idx.size:
            result, idx = slow_rows(system, result, idx, C, int(decision), certificate.tol,
                                    cols)
        if idx.size == 0:
            return dataclasses.replace(result, extra={**result.extra, **cols})
    amp = np.array(result.amplitude, dtype=float, copy=True)
    freq = np.array(result.frequency_hz, dtype=float, copy=True)
    cols["certificate"][idx] = "shooting"
    sub = system.select(torch.as_tensor(idx)).to(dtype=torch.float64)
    start = _starts(sub, result, idx, c)
    start.amplitude = torch.as_tensor(amp[idx, decision])
    resolution = FINISH_TOL * certificate.tol
    # a time integration's orbit is one of the discrete map at h; a Fourier orbit is the
    # continuous one, compared with the Richardson extrapolation of the discrete orbits at h
    # and 2h (otherwise an exact continuous orbit would "fail" by the step's own error): the
    # coarse amplitude first, so that the pass at h can accept against it. Every output's
    # amplitude and the frequency are extrapolated alike (the row's output_error and
    # frequency_error)
    O = C.shape[0]
    dt_outputs = np.full((idx.size, O), np.nan)
    dt_frequency = np.full(idx.size, np.nan)

    def discretisation(ref: _Discrete, c2: _Discrete, c4: _Discrete) -> tuple:
        """(every output (b, O), frequency): each one's discretisation error from the discrete
        orbits at h, 2h, 4h (:func:`richardson_error`, a row's quantities together)."""
        e = richardson_error(*(np.column_stack([d.amplitudes, d.frequency_hz])
                               for d in (ref, c2, c4)), resolution)
        return e[:, :O], e[:, O]
    if continuous and certificate.richardson:
        d2 = _coarse(sub, _state(start), c, C, h)
        d4 = _coarse(sub, _state(start), c, C, 2 * h)
        start.coarse_amplitude = torch.as_tensor(d2.amplitudes[:, decision])
    # one evaluation for every orbit (its certificate); with ``finish``, in the same pass,
    # those that fail it or whose stability the start's monodromy leaves unknown (a start off
    # a weakly attracting orbit moves the trivial multiplier) are iterated on to the discrete
    # orbit (the finish: its first iteration is the certificate's evaluation)
    r = shoot(sub, start, c, rows=C, options=certificate.options(
        h, certificate.max_iterations if certificate.finish else 0, marched=not continuous))
    # the discrete orbit's amplitudes and frequency to second order in the start's distance,
    # against those the method reported (a transient's last cycle is not the cycle that
    # follows)
    d1 = _Discrete.of(r, start.period)
    targets, f_target = d1.amplitudes, d1.frequency_hz
    if start.coarse_amplitude is not None:
        targets = d1.amplitudes + (d1.amplitudes - d2.amplitudes) / 3.0
        f_target = d1.frequency_hz + (d1.frequency_hz - d2.frequency_hz) / 3.0
    with np.errstate(divide="ignore", invalid="ignore"):
        orbit_outputs = np.abs(amp[idx] / targets - 1.0)
        orbit_frequency = np.abs(freq[idx] / f_target - 1.0)
    orbit_error = orbit_outputs[:, decision]  # a view: the decision output's
    stable, critical, trivial = r.stable.copy(), r.critical_multiplier.copy(), \
        r.trivial_error.copy()
    state = _state(start)
    iterations = r.iterations.copy()
    # finished: iterated to the discrete orbit (or already on it and failing the certificate)
    finished = certificate.finish & r.converged & ~r.accepted & (
        (r.iterations > 0) | (orbit_error > certificate.tol))
    # a finish only for the stability that failed leaves the start's verdict unknown
    stable[~finished & (r.iterations > 0)] = None
    direct = (orbit_error <= certificate.tol) & ~finished
    if start.coarse_amplitude is not None:
        # the rows that keep the start's orbit: its discretisation error from this pass and
        # the coarse ones (a finished row's from its discrete orbit, below)
        k = np.flatnonzero(~finished)
        dt_outputs[k], dt_frequency[k] = discretisation(d1.select(k), d2.select(k),
                                                        d4.select(k))
    g = np.flatnonzero(finished)
    if g.size:
        tg = torch.as_tensor(g)
        orbit_outputs[g] = np.abs(r.amplitude_corrections[g])
        orbit_frequency[g] = np.abs(r.period_correction[g])
        amp[idx[g]] = r.amplitude[g]
        freq[idx[g]] = r.frequency_hz[g]
        state = tuple(x.clone() for x in state)
        for dst, src in zip(state, (r.q, r.v, r.xi, r.period)):
            dst[tg] = src[tg]
    certified = direct | finished
    # Richardson: the certified discrete orbits (a time integration's, or those finished to)
    # evaluated once at 2h (half the steps of one evaluation at h)
    coarse = np.flatnonzero(certified & np.isnan(dt_outputs[:, decision]))
    if certificate.richardson and coarse.size:
        tc = torch.as_tensor(coarse)
        # the discrete orbit at h: the finished one's, else the start's estimate
        on = finished[coarse]
        ref = _Discrete(np.where(on[:, None], amp[idx[coarse]], d1.amplitudes[coarse]),
                        np.where(on, freq[idx[coarse]], d1.frequency_hz[coarse]))
        coarse_state = tuple(x[tc] for x in state)
        c2 = _coarse(sub.select(tc), coarse_state, c, C, h)
        c4 = _coarse(sub.select(tc), coarse_state, c, C, 2 * h)
        dt_outputs[coarse], dt_frequency[coarse] = discretisation(ref, c2, c4)
    dt_error = dt_outputs[:, decision].copy()
    # a discretisation error beyond dt_tol, or none where one was asked for (the coarse
    # evaluations failed): the step does not resolve the orbit
    with np.errstate(invalid="ignore"):
        certified &= ~(dt_error > certificate.dt_tol)
    if certificate.richardson:
        certified &= np.isfinite(dt_error)
    cols["certified"][idx] = certified
    cols["orbit_error"][idx] = orbit_error
    cols["dt_error"][idx] = dt_error
    # every output's and the frequency's distance to the discrete orbit plus, where estimated,
    # its discretisation error (the decision output's is orbit_error + dt_error)
    # (without ``richardson`` the distance to the discrete orbit alone; with it NaN where the
    # coarse evaluations failed)
    if not certificate.richardson:
        dt_outputs, dt_frequency = np.zeros_like(dt_outputs), np.zeros_like(dt_frequency)
    # (an output without an amplitude, e.g. one that stays at zero, does not count)
    largest = np.where(np.isnan(orbit_outputs), -np.inf, orbit_outputs + dt_outputs).max(axis=1)
    cols["output_error"][idx] = np.where(largest == -np.inf, np.nan, largest)
    cols["frequency_error"][idx] = orbit_frequency + dt_frequency
    cols["stable"][idx] = stable
    cols["critical_multiplier"][idx] = critical
    cols["stability_margin"][idx] = 1.0 - np.abs(critical)
    cols["trivial_multiplier_error"][idx] = trivial
    cols["finished"][idx] = finished
    cols["shooting_iterations"][idx] = iterations
    status[idx[~certified]] = UNCERTIFIED
    # a finished row's state is its discrete orbit's (at the section through the start)
    q, v = np.array(result.q, dtype=float, copy=True), np.array(result.v, dtype=float, copy=True)
    xi = (np.zeros((B, system.n_lag)) if result.xi is None
          else np.array(result.xi, dtype=float, copy=True))
    for dst, src in zip((q, v, xi), state[:3]):
        dst[idx[g]] = src[torch.as_tensor(g)].cpu().numpy()
    return dataclasses.replace(result, status=status, amplitude=amp, frequency_hz=freq,
                               q=q, v=v, xi=xi if (result.xi is not None or g.size) else None,
                               extra={**result.extra, **cols})
