"""The ROM about a deformed state: its static aeroelastic equilibrium under the steady loads of
a root incidence, its tangent there, and the flutter roots of that tangent at each speed (the
ROM's form of "SOL 400, then SOL 145 on the deformed wing").

Equilibrium, on the aero file's m modes (sign F = −q∞ Q q, zero-padded to the ROM's n basis
functions; paper Eq. 54 without motion, Eq. 49 at k = 0):

    K1 q + K2(q,q) + K3(q,q,q) + q∞ Q(0) q = −q∞ Q_α α,

continued in speed from rest for every angle at once (one batched Newton; a step that fails
for any angle is halved). About q0 the motion x = q − q0 obeys, to first order,

    M ẍ + (α M + γ [D̄1 + D̄2(q0) + D̄3(q0,q0)]) ẋ + [K1 + 2 K2(q0,·) + 3 K3(q0,q0,·)] x = F_aero(x),

the tangent of :meth:`NonlinearROM.tangents` at zero velocity: the Kelvin–Voigt damping's
matrix at q0 and no damping force on the static state. Its roots at each speed come from a
:class:`RootFinder` (the RFA's state space, or p-k on the GAF table), and the onsets and
offsets from :func:`torchrom.trim.flutter.boundaries`.

Written here: no library holds this ROM or its aeroelastic equilibrium.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
import torch

from ..aero.flutter import (
    AeroTable,
    ModalStructure,
    in_vacuo_modes,
    oscillatory_roots,
    pk_sweep,
)
from ..aero.rfa import RFA
from ..errors import InputError
from ..rom.reference import reference_load, reference_of
from .flutter import Boundary, StabilityPoint, boundaries


@dataclass
class SteadyModalAero:
    """The k = 0 aerodynamics on the ROM's n basis functions: ``Q0`` (n, n) the aerodynamic
    stiffness per unit dynamic pressure and ``incidence`` (n,) the load of a 1 rad incidence,
    both zero beyond the aero file's m modes."""

    Q0: np.ndarray
    incidence: np.ndarray

    @classmethod
    def from_aero(cls, aero, n: int, where: str = "aero file") -> SteadyModalAero:
        return cls(aero.padded_steady_stiffness(n, where), aero.padded_incidence(n, where))


@dataclass
class RomEquilibria:
    """Equilibria on a grid of angles × speeds: ``aoa_deg`` (A,), ``velocity`` (S,), ``q`` (A,
    S, n) (NaN where not reached), ``converged`` (A, S), ``density``."""

    aoa_deg: np.ndarray
    velocity: np.ndarray
    density: float
    q: np.ndarray
    converged: np.ndarray
    notes: list[str] = field(default_factory=list)


#: Newton's relative residual tolerance (the load's scale) and its iteration limit per step
NEWTON_RTOL = 1e-10
NEWTON_MAX_ITER = 25
#: halvings of a speed step before an angle is given up at that speed
MAX_HALVINGS = 8


def _newton(rom, aero: SteadyModalAero, q: torch.Tensor, dyn: float, aoa: torch.Tensor):
    """Newton on every angle from ``q`` (A, n) at dynamic pressure ``dyn``: (q, converged (A,)).
    A ROM about a deformed state (:mod:`torchrom.rom.reference`) solves for x = q − q_ref:
    its reference adds −q∞ Q(0) q_ref − f_ref to the load."""
    Q0 = torch.as_tensor(aero.Q0)
    inc = -dyn * aoa[:, None] * torch.as_tensor(aero.incidence)[None]
    ref = reference_load(rom, aero.Q0, dyn)
    load = inc if ref is None else inc + torch.as_tensor(ref)
    # the reference's load cancels near its own condition: the scale is that of its parts
    scale = inc.norm(dim=1)
    if ref is not None:
        scale = torch.maximum(scale, torch.as_tensor(float(np.linalg.norm(rom.reference.force))))
    scale = scale.clamp_min(1e-300)
    zero = torch.zeros_like(q)
    done = torch.zeros(len(q), dtype=torch.bool)
    for _ in range(NEWTON_MAX_ITER):
        r = rom.stiffness_force(q) + dyn * q @ Q0.T - load
        done = torch.isfinite(r).all(dim=1) & (r.norm(dim=1) <= NEWTON_RTOL * scale)
        if bool(done.all()):
            break
        Kt, _ = rom.tangents(q, zero)
        dq, info = torch.linalg.solve_ex(Kt + dyn * Q0, r.unsqueeze(-1))
        # a singular tangent (a fold, the divergence) stops that angle, not the others
        step = torch.where((info == 0)[:, None] & ~done[:, None], dq.squeeze(-1), 0.0)
        q = q - step
    return q, done


def _continued(rom, aero, q, alive, density, start, end):
    """From the equilibria ``q`` (A, n) at ``start`` = (speed, aoa (A,) rad) to ``end`` (at
    ``density``), both moved linearly along the way, the step halved where any live angle
    fails and doubled again after a step that converges (as Nastran's NLPARM increments grow
    back): (q at ``end``, the angles that got there, (angle index, speed reached) of each
    angle that still fails at a step of 2^-:data:`MAX_HALVINGS` of the way and stops there,
    e.g. at a fold)."""
    (v0, a0), (v1, a1) = start, end
    s, step, lost = 0.0, 1.0, []
    smallest = 2.0 ** -MAX_HALVINGS
    while s < 1.0 and bool(alive.any()):
        nxt = min(s + step, 1.0)
        v, a = (v1, a1) if nxt == 1.0 else (v0 + nxt * (v1 - v0), a0 + nxt * (a1 - a0))
        q_new, conv = _newton(rom, aero, q, 0.5 * density * v**2, a)
        if bool(conv[alive].all()):
            q, s = torch.where(alive[:, None], q_new, q), nxt
            # grown again: the angles left after one is lost would otherwise crawl on in steps
            # of 2^-MAX_HALVINGS (hundreds of Newton solves a speed)
            step = min(1.0, 2.0 * step)
        elif step > smallest:
            # a floor on the step, not a count of failures in a row: with the growth, a
            # count is never reached while the step closes in on a fold
            step *= 0.5
        else:  # the angles that fail are lost from here on; the others go on
            reached = v0 + s * (v1 - v0)
            lost += [(j, reached) for j in torch.nonzero(alive & ~conv).flatten().tolist()]
            alive = alive & conv
    return q, alive, lost


def rom_equilibria(rom, aero: SteadyModalAero, aoa_deg, velocities, density: float
                   ) -> RomEquilibria:
    """The ROM's equilibria at each of ``aoa_deg`` (deg) and ascending ``velocities`` at
    ``density`` (the files' units), continued in speed from rest (module docstring). An angle
    whose step fails after :data:`MAX_HALVINGS` halvings is NaN from there on (past a fold or
    the divergence: the next speeds are not reached from a lost branch)."""
    A = np.asarray(aoa_deg, dtype=float).reshape(-1)
    V = np.asarray(velocities, dtype=float).reshape(-1)
    if np.any(np.diff(V) <= 0) or np.any(V <= 0):
        raise InputError("velocities: expected positive, ascending speeds")
    if reference_of(rom) is not None:
        return _equilibria_from_reference(rom, aero, A, V, float(density))
    aoa = torch.as_tensor(np.radians(A))
    q = torch.zeros(len(A), rom.n, dtype=torch.float64)
    alive = torch.ones(len(A), dtype=torch.bool)
    out = np.full((len(A), len(V), rom.n), np.nan)
    ok = np.zeros((len(A), len(V)), dtype=bool)
    notes = []
    cur = 0.0
    for i, target in enumerate(map(float, V)):
        q, alive, lost = _continued(rom, aero, q, alive, density, (cur, aoa), (target, aoa))
        notes += [f"aoa {A[j]:g} deg: no equilibrium past {v:g} (the ROM's branch ends: a "
                  "fold or the static divergence)" for j, v in lost]
        cur = target
        out[alive.numpy(), i] = q[alive].numpy()
        ok[:, i] = alive.numpy()
    return RomEquilibria(A, V, float(density), out, ok, notes)


def _equilibria_from_reference(rom, aero, A, V, density) -> RomEquilibria:
    """:func:`rom_equilibria` of a ROM about a deformed state: x = 0 is the equilibrium of its
    reference condition (``rom.reference.condition``: aoa_deg, velocity, density), so every
    angle is continued from there, first to its own angle at the reference speed and density,
    then up in speed through the speeds above it and down through those below."""
    cond = rom.reference.condition
    try:
        v_ref, a_ref = float(cond["velocity"]), math.radians(float(cond["aoa_deg"]))
        rho_ref = float(cond["density"])
    except (KeyError, TypeError, ValueError):
        raise InputError("the ROM's reference state names no condition (aoa_deg, velocity, "
                         "density) to continue its equilibria from") from None
    n, nA = rom.n, len(A)
    aoa = torch.as_tensor(np.radians(A))
    out = np.full((nA, len(V), n), np.nan)
    ok = np.zeros((nA, len(V)), dtype=bool)
    alive = torch.ones(nA, dtype=torch.bool)
    q = torch.zeros(nA, n, dtype=torch.float64)
    # the reference condition at this density: its speed with the same dynamic pressure
    v_same = v_ref * math.sqrt(rho_ref / density)
    q, alive, _ = _continued(rom, aero, q, alive, density,
                             (v_same, torch.full_like(aoa, a_ref)), (v_same, aoa))
    notes = [f"aoa {A[j]:g} deg: not reached from the ROM's reference state"
             for j in torch.nonzero(~alive).flatten().tolist()]
    for order in (np.flatnonzero(V >= v_same), np.flatnonzero(V < v_same)[::-1]):
        qq, live, cur = q.clone(), alive.clone(), v_same
        for i in order:
            qq, live, _ = _continued(rom, aero, qq, live, density, (cur, aoa),
                                     (float(V[i]), aoa))
            cur = float(V[i])
            out[live.numpy(), i] = qq[live].numpy()
            ok[:, i] = live.numpy()
    return RomEquilibria(A, V, float(density), out, ok, notes)


def envelope_ratio(rom, q: np.ndarray) -> np.ndarray:
    """max_j |q_j| / a_j over the loaded modes j of a condensed ROM (a_j its largest load
    level's modal amplitude, ``metadata["identification"]``) for each state of ``q`` (..., n):
    above 1 the cubic terms are extrapolated beyond the solves they were fitted to. NaN for a
    ROM that records no envelope."""
    ident = rom.metadata.get("identification", {}) if isinstance(rom.metadata, dict) else {}
    a = ident.get("modal_amplitudes")
    q = np.asarray(q, dtype=float)
    if not a:
        return np.full(q.shape[:-1], np.nan)
    k = int(ident.get("nonlinear_modes") or len(a))
    a = np.asarray(a, dtype=float)[:k]
    return np.max(np.abs(q[..., :k]) / a, axis=-1)


def tangent_structure(rom, q0: np.ndarray, alpha: float = 0.0, gamma: float = 0.0
                      ) -> ModalStructure:
    """(M, K_T(q0), D_T(q0)) of the motion about ``q0`` (module docstring) with Rayleigh α
    (1/s) and Kelvin–Voigt γ (s)."""
    q = torch.as_tensor(np.asarray(q0, dtype=float))
    Kt, _ = rom.tangents(q, torch.zeros_like(q))
    return ModalStructure(M=rom.M.numpy(), K=Kt.numpy(), D1=rom.damping_matrix(q).numpy(),
                          alpha=alpha, gamma=gamma)


def padded_rfa(rfa: RFA, n: int) -> RFA:
    """``rfa`` on n ≥ m coordinates: the basis functions past the m modes carry no
    aerodynamic force (dual modes, DESIGN "Conventions")."""
    m, na = rfa.n_modes, rfa.n_states
    if n == m:
        return rfa

    def square(a):
        out = np.zeros((n, n))
        out[:m, :m] = a
        return out

    D, E = np.zeros((n, na)), np.zeros((na, n))
    D[:m], E[:, :m] = rfa.D, rfa.E
    return RFA(square(rfa.A0), square(rfa.A1), square(rfa.A2), D, rfa.R, E, rfa.lag_roots,
               rfa.kind, rfa.semichord, rfa.mach, rfa.fit_error)


def padded_table(table: AeroTable, n: int, m: int) -> AeroTable:
    """A GAF table of m modes on n ≥ m coordinates (zeros past the m modes)."""
    if n == m:
        return table

    def q_of_k(k):
        out = np.zeros((n, n), dtype=complex)
        out[:m, :m] = table(k)
        return out

    padded = AeroTable(q_of_k, table.semichord, table.k_max, table.k_min)
    padded.k_damp = table.k_damp
    return padded


class RootFinder(Protocol):
    """The contract of a flutter method about a state: ``(structure, velocity, density) ->``
    :class:`StabilityPoint` (damping g and frequency of each root; ``name`` for reports)."""

    name: str

    def __call__(self, structure: ModalStructure, velocity: float, density: float
                 ) -> StabilityPoint: ...


class StateSpaceRoots:
    """The oscillatory roots s of the RFA's first-order system (Eqs. 49–50): g = 2 Re s / Im s,
    f = Im s / 2π (one dense eigenproblem per speed: the method of the onset/offset maps)."""

    name = "state-space"

    def __init__(self, rfa: RFA):
        self.rfa = rfa

    def __call__(self, structure, velocity, density):
        s = oscillatory_roots(structure, self.rfa, velocity, density).elastic
        return StabilityPoint(float(velocity), 2 * s.real / s.imag, s.imag / (2 * math.pi),
                              in_vacuo_modes(structure)[0])


class PkRoots:
    """The p-k roots on the GAF table (Nastran's PK), entered at each speed from the tangent's
    in-vacuo modes by a density ramp."""

    name = "p-k"

    def __init__(self, table: AeroTable, mach: float):
        self.table, self.mach = table, mach

    def __call__(self, structure, velocity, density):
        sweep = pk_sweep(structure, self.table, [velocity], density, mach=self.mach, eps=1e-6)
        return StabilityPoint(float(velocity), np.asarray(sweep.damping[0]),
                              np.asarray(sweep.frequency_hz[0]), in_vacuo_modes(structure)[0])


def root_finder(method: str, rom, aero) -> RootFinder:
    """The :class:`RootFinder` named ``method`` ("state-space" or "p-k") on ``aero``'s data
    padded to the ROM's n coordinates."""
    if method == StateSpaceRoots.name:
        return StateSpaceRoots(padded_rfa(aero.rfa, rom.n))
    if method == PkRoots.name:
        return PkRoots(padded_table(AeroTable.from_gaf(aero.gaf), rom.n, aero.n_modes),
                       aero.mach)
    raise InputError(f"method: expected 'state-space' or 'p-k', got {method!r}")


@dataclass
class DeformedFlutter:
    """Per angle: the :class:`StabilityPoint` of each solved speed (None where the equilibrium
    was not reached) and the onsets/offsets along them, by ``method``."""

    method: str
    equilibria: RomEquilibria
    points: list[list[StabilityPoint | None]]
    boundaries: list[list[Boundary]]

    def state_at(self, a: int, b: Boundary) -> np.ndarray:
        """q0 at boundary ``b`` of angle index ``a``, interpolated as its speed."""
        eq = self.equilibria
        pts = [p for p in self.points[a] if p is not None]
        v0, v1 = pts[b.index].velocity, pts[b.index + 1].velocity
        i0, i1 = (int(np.flatnonzero(eq.velocity == v)[0]) for v in (v0, v1))
        t = (b.velocity - v0) / (v1 - v0)
        return (1 - t) * eq.q[a, i0] + t * eq.q[a, i1]


def deformed_flutter(rom, eq: RomEquilibria, finder: RootFinder, alpha: float = 0.0,
                     gamma: float = 0.0) -> DeformedFlutter:
    """The roots of the tangent about every equilibrium of ``eq`` and their onsets/offsets."""
    points, found = [], []
    for a in range(len(eq.aoa_deg)):
        row = []
        for i, v in enumerate(eq.velocity):
            if not eq.converged[a, i]:
                row.append(None)
                continue
            st = tangent_structure(rom, eq.q[a, i], alpha, gamma)
            row.append(finder(st, float(v), eq.density))
        points.append(row)
        found.append(boundaries([p for p in row if p is not None]))
    return DeformedFlutter(finder.name, eq, points, found)
