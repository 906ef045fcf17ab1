"""Flutter crossings of a p-k sweep: labelled sustained or hump, solved between the sweep's
speeds, with the rigid-body roots, the divergences and the modes the aerodynamics do not load
apart.

A crossing counts only where the damping g changes sign by more than a tolerance ``tol``
(:data:`G_TOLERANCE`, 1e-3 by default; the commands' ``--g-tolerance``): from below -tol to
above +tol (:func:`torchrom.aero.flutter.zero_crossings`). A branch whose |g| stays within tol
at every speed is listed as *not loaded by the aerodynamics* (its g is noise about 0: an
in-plane or chordwise mode that flat boxes hardly load), never as flutter. A crossing whose
root is real (zero frequency, :func:`torchrom.aero.flutter.is_static_root`) at its onset is a
*divergence*, reported apart with its speed, never as flutter.

Each unstable excursion of a branch's damping g_j(V) (:func:`torchrom.aero.flutter.excursions`)
is one crossing: its onset, where g_j rises through 0, and, for a *hump*, the speed where it
falls back below 0 (re-stabilisation); a *sustained* crossing stays unstable to the last speed.
Both speeds are solved between the bracketing sweep speeds by Brent's method on Re s_j(V), the
tracked root p-k iterated to convergence at each trial speed from the root at the lower sample
(:func:`torchrom.aero.flutter._pk_mode`; sign Re s = sign g for an oscillatory and for a real
root), so they do not depend on the spacing of the deck's FLFACT speeds. Where a trial solve
leaves the branch (no sign change between the ends) the crossing keeps the linear
interpolation of the samples, as Nastran's summary, with ``refined=False``.

A hump that rises above 0 and falls back between two consecutive speeds changes no sign at the
samples. Every interior local maximum of a branch's sampled g between -:data:`HUMP_PROBE_G`
and +tol is therefore probed: the maximum of g_j(V) over the two neighbouring intervals is
found by bounded Brent minimisation of -g_j (at most :data:`HUMP_PROBE_EVALS` p-k solves); when
it is above +tol the onset and re-stabilisation are solved on either side of it.

Rigid-body roots (branches of modes below :data:`RIGID_FRACTION` of the lowest elastic
frequency: the 0 Hz modes of a free-free aircraft) are returned apart: a rigid aircraft's root
crossing zero (a slow real or phugoid-like root) is not flutter.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy

from .flutter import (  # noqa: F401 - the rigid-body rule is re-exported (public here)
    G_ROUNDOFF,
    G_TOLERANCE,
    HUMP,
    RIGID_FRACTION,
    SUSTAINED,
    AeroTable,
    FlutterPoint,
    ModalStructure,
    ModeSweep,
    _pk_mode,
    excursions,
    is_static_root,
    pk_damping,
    rigid_body_branches,
    rigid_body_modes,
)

#: an interior local maximum of a branch's sampled damping between -HUMP_PROBE_G and 0 is
#: probed for a hump between the samples (g = 0.05: 2.5 % of critical damping)
HUMP_PROBE_G = 0.05
#: p-k solves allowed to locate one probed maximum
HUMP_PROBE_EVALS = 16
#: steps in which a crossing's bracket is followed when solving its ends from the lower
#: sample's root does not bracket it (:meth:`_Branch.solve_crossing`)
MARCH_STEPS = 16


@dataclass
class Crossings:
    """The labelled crossings of one sweep: flutter points, and apart the rigid-body roots'
    crossings, the divergences (real roots) and the branches not loaded by the aerodynamics
    (0-based; |g| <= ``g_tolerance`` at every speed)."""

    flutter: list[FlutterPoint]
    rigid_body: list[FlutterPoint]
    divergence: list[FlutterPoint] = field(default_factory=list)
    not_loaded: list[int] = field(default_factory=list)
    g_tolerance: float = G_TOLERANCE


def split_rigid(points: list[FlutterPoint], rigid, sweep: ModeSweep | None = None,
                tol: float = G_TOLERANCE) -> Crossings:
    """Flutter points apart from the crossings of rigid-body branches (``rigid``: bool per
    branch) and from the divergences (``divergence``); with ``sweep``, the elastic branches it
    does not load (:meth:`ModeSweep.not_loaded` at ``tol``)."""
    rigid = np.asarray(rigid, dtype=bool)
    marked = [replace(p, rigid_body=bool(rigid[p.mode])) for p in points]
    elastic = [p for p in marked if not p.rigid_body]
    quiet = [] if sweep is None else [j for j in sweep.not_loaded(tol) if not rigid[j]]
    return Crossings([p for p in elastic if not p.divergence],
                     [p for p in marked if p.rigid_body],
                     [p for p in elastic if p.divergence], quiet, float(tol))


def pk_crossings(structure: ModalStructure, aero: AeroTable, sweep: ModeSweep, rigid=None,
                 eps: float = 1e-7, tol: float = G_TOLERANCE) -> Crossings:
    """Every crossing of a p-k sweep, labelled, refined and probed as the module docstring
    says, at the damping tolerance ``tol``. ``rigid``: bool per branch (default
    :func:`rigid_body_branches`). A sweep along a path of varying density (matched point,
    PKNL) keeps the linear interpolation."""
    rigid = rigid_body_branches(structure) if rigid is None else np.asarray(rigid, dtype=bool)
    V = np.asarray(sweep.velocity, dtype=float)
    if sweep.method != "PK" or V.ndim != 1 or np.ptp(sweep.density) != 0 or np.any(
            np.diff(V) < 0):
        return split_rigid(sweep.crossings(tol), rigid, sweep, tol)
    linear = sweep.crossings(tol)
    branch = _Branch(structure, aero, sweep, eps, tol)
    out = []
    for j in range(sweep.damping.shape[1]):
        if rigid[j]:  # not refined: round-off roots near 0 would only feed Brent noise
            out += [p for p in linear if p.mode == j]
            continue
        g = sweep.damping[:, j]
        for i, back in excursions(g, tol):
            onset = branch.solve_crossing(j, i, V[i], V[i + 1])
            stable = None if back is None else branch.solve_crossing(j, back, V[back],
                                                                     V[back + 1])
            out.append(branch.point(j, onset, stable, _linear(linear, sweep.velocity, j, i)))
        for i in _probe_indices(g, tol):
            found = branch.probe_hump(j, i)
            # a speed listed twice can put the same hump beside two samples
            if found is not None and not any(
                    p.mode == j and abs(p.velocity - found[0].velocity) <= 1e-6 * p.velocity
                    for p in out):
                out.append(branch.point(j, *found, None))
    out.sort(key=lambda p: p.velocity)
    return split_rigid(out, rigid, sweep, tol)


def _probe_indices(g, tol: float = G_TOLERANCE) -> list[int]:
    """Interior samples where g has a local maximum between -HUMP_PROBE_G and +tol (a sample
    on the hump's onset, g = 0 within tol, is one: no sign change counts there)."""
    g = np.asarray(g, dtype=float)
    with np.errstate(invalid="ignore"):
        inner = ((g[1:-1] <= tol) & (g[1:-1] > -HUMP_PROBE_G)
                 & (g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:]))
    return (np.flatnonzero(inner) + 1).tolist()


def _linear(points: list[FlutterPoint], V, j: int, i: int) -> FlutterPoint:
    """The linear crossing of branch j between samples i and i+1 (the fallback of a failed
    refinement)."""
    return next(p for p in points if p.mode == j and V[i] <= p.velocity <= V[i + 1])


@dataclass
class _Solved:
    velocity: float
    s: complex
    k: float
    refined: bool


class _Branch:
    """p-k solves of one tracked branch at speeds between the sweep's samples."""

    def __init__(self, structure, aero, sweep, eps, tol: float = G_TOLERANCE):
        self.structure, self.aero, self.sweep, self.eps = structure, aero, sweep, eps
        self.tol = float(tol)
        self.rho = float(sweep.density[0])

    def seed(self, j: int, sample: int):
        """The branch's root and shape at one of the sweep's samples."""
        return self.sweep.eigenvalues[sample, j], self.sweep.vectors[sample, :, j]

    def root(self, seed, v: float):
        """(s, shape, k) of the branch at speed v, iterated from ``seed`` (s, shape)."""
        s, vec, k, _ = _pk_mode(self.structure, self.aero, v, self.rho, seed[0], seed[1],
                                self.eps, 200)
        return s, vec, k

    def damping(self, seed, v: float) -> float:
        s = self.root(seed, v)[0]
        return float(pk_damping(np.array([[s]]), [v], self.aero.semichord)[0, 0])

    def solve_crossing(self, j: int, start: int, lo: float, hi: float) -> _Solved | None:
        """The speed in [lo, hi] where Re s_j = 0: Brent's method with each trial solve
        iterated from the root at sample ``start``; where that leaves the branch (no sign
        change between the ends: the root at ``hi`` iterated from ``lo``'s is another root),
        the branch is first followed from ``lo`` in :data:`MARCH_STEPS` steps, each seeded
        with the previous root, and Brent's method works in the step where Re s changes sign.
        None where neither brackets it."""
        if not hi > lo:
            return None
        seed = self.seed(j, start)
        found = self._brent(seed, lo, hi)
        if found is not None:
            return found
        v_prev, s_prev = lo, self.root(seed, lo)
        for v in np.linspace(lo, hi, MARCH_STEPS + 1)[1:]:
            s_next = self.root(s_prev[:2], v)
            if np.sign(s_next[0].real) != np.sign(s_prev[0].real):
                return self._brent(s_prev[:2], v_prev, v)
            v_prev, s_prev = v, s_next
        return None

    def _brent(self, seed, lo: float, hi: float) -> _Solved | None:
        try:
            v = scipy.optimize.brentq(lambda x: self.root(seed, x)[0].real, lo, hi,
                                      xtol=1e-9 * hi, rtol=1e-12)
        except ValueError:
            return None
        s, _, k = self.root(seed, v)
        return _Solved(float(v), s, float(k), True)

    def probe_hump(self, j: int, i: int):
        """(onset, re-stabilisation) of a hump of branch j between the speeds next to sample
        i's (a speed listed twice counts once), None where the damping stays below 0 there."""
        V = self.sweep.velocity
        below, above = V[V < V[i]], V[V > V[i]]  # the neighbouring distinct speeds
        if not (below.size and above.size):
            return None
        lo, hi = float(below.max()), float(above.min())
        res = scipy.optimize.minimize_scalar(
            lambda v: -self.damping(self.seed(j, i), v), bounds=(lo, hi), method="bounded",
            options={"maxiter": HUMP_PROBE_EVALS, "xatol": 1e-6 * hi})
        if not -res.fun > self.tol:
            return None
        onset = self.solve_crossing(j, i, lo, float(res.x))
        stable = self.solve_crossing(j, i, float(res.x), hi)
        if onset is None or stable is None:
            return None
        return onset, stable

    def point(self, j, onset, stable, fallback) -> FlutterPoint:
        """A labelled FlutterPoint; ``fallback`` (linear) where a speed was not refined."""
        sw = self.sweep
        hump = stable is not None or (fallback is not None and fallback.kind == HUMP)
        if onset is None or (hump and stable is None):
            return replace(fallback, refined=False)
        return FlutterPoint(
            velocity=onset.velocity,
            frequency_hz=abs(onset.s.imag) / (2 * np.pi),
            density=self.rho,
            mode=j,
            method=sw.method,
            k=onset.k,
            mach=sw.mach,
            kind=HUMP if hump else SUSTAINED,
            stable_velocity=stable.velocity if hump else None,
            stable_frequency_hz=abs(stable.s.imag) / (2 * np.pi) if hump else None,
            refined=True,
            divergence=is_static_root(onset.s, onset.velocity, self.aero.semichord),
        )
