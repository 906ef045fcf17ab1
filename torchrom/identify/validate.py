"""Validation of an identified ROM against its FE model (paper Sec. III.E, Figs. 3–8; issue 4).

- **Static**: for a load shape F (uniform pressure, "step uniform" pressure: positive ahead of
  the wing's mid-chord line, negative behind — for the Goland wing x = 3 ft of the 6 ft chord,
  i.e. a lift plus a nose-up torque on the 4 ft box, see
  :func:`torchrom.identify.fe_backend.step_midline`), load levels from the linear range up to a
  tip deflection of ≈ 25 % of the span: FE Newton (the backend's static solver, continuation in
  the level) vs ROM Newton on K1 q + K2(q,q) + K3(q,q,q) = Φᵀ F (Eqs. 12, 14); outputs at
  point A (A_Tx, A_Ty, A_Tz).
- **Dynamic**: free decay from the static deflection under a pressure (released at t = 0) with
  Kelvin–Voigt damping D = γC (Eq. 52): FE nonlinear transient vs ROM transient (both Newmark
  average acceleration, same time step); amplitude envelope and frequency of A_Tz over the first
  cycles.
- **Damping methods**: ``decomposition`` vs ``exact`` tensors, and the dissipated power
  q̇ᵀ D_T(q) q̇ (Eq. 33) along a sampled motion.

Written here (Newton, Newmark, peak detection); the FE solves are the backend's.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
import torch

from ..errors import ConvergenceError, InputError
from .backend import newmark_newton

OUTPUTS = ("A_Tx", "A_Ty", "A_Tz")


# ------------------------------------------------------------------------------------------------
# ROM solvers
# ------------------------------------------------------------------------------------------------
def rom_static_solve(rom, f: np.ndarray, q0: np.ndarray | None = None, *, tol: float = 1e-11,
                     max_iter: int = 50) -> np.ndarray:
    """Newton–Raphson with load halving for K1 q + K2(q,q) + K3(q,q,q) = f (generalized)."""
    f = np.asarray(f, float)
    q = np.zeros(rom.n) if q0 is None else np.array(q0, float)
    lam, inc = 0.0, 1.0
    scale = max(np.linalg.norm(f), 1e-300)
    zeros = torch.zeros(rom.n, dtype=torch.float64)
    while lam < 1.0:
        target = min(1.0, lam + inc)
        v, ok = q.copy(), False
        for _ in range(max_iter):
            qt = torch.as_tensor(v)
            r = target * f - rom.stiffness_force(qt).numpy()
            if np.linalg.norm(r) <= tol * scale:
                ok = True
                break
            Kt, _ = rom.tangents(qt, zeros)
            v = v + scipy.linalg.solve(Kt.numpy(), r)
            if not np.all(np.isfinite(v)):
                break
        if ok:
            q, lam = v, target
        else:
            inc *= 0.5
            if inc < 1e-4:
                raise ConvergenceError(f"ROM static Newton did not converge (load factor {lam})")
    return q


def rom_free_decay(rom, q0: np.ndarray, *, t_end: float, dt: float, gamma: float,
                   alpha: float = 0.0, tol: float = 1e-10) -> tuple[np.ndarray, np.ndarray,
                                                                    np.ndarray]:
    """Newmark (β = ¼, γ_N = ½) with full Newton for M q̈ + f(q, q̇) = 0 (Eq. 54) from rest.

    Returns (t (k,), q (k, n), q̇ (k, n)).
    """
    M = rom.M.numpy()
    n, steps = rom.n, int(round(t_end / dt))
    Q, V = np.zeros((steps + 1, n)), np.zeros((steps + 1, n))

    def force(q, v):
        return rom.force(torch.as_tensor(q), torch.as_tensor(v), alpha, gamma).numpy()

    def tangents(q, v):
        Kt, Ct = rom.tangents(torch.as_tensor(q), torch.as_tensor(v), alpha, gamma)
        return Kt.numpy(), Ct.numpy()

    def keep(k, q, v):
        Q[k], V[k] = q, v

    # general solves: the damping tangent of a decomposition ROM need not be symmetric
    newmark_newton(M, force, tangents, q0, dt=dt, steps=steps, tol=tol, max_iter=30,
                   record=keep, solve=np.linalg.solve, rounding_stop=True, what="ROM transient")
    return np.arange(steps + 1) * dt, Q, V


# ------------------------------------------------------------------------------------------------
# static validation
# ------------------------------------------------------------------------------------------------
@dataclass
class StaticCurve:
    """FE and ROM responses at point A along increasing load levels of one load shape."""

    shape: str
    levels: np.ndarray
    tip_pct_span: np.ndarray
    fe: dict[str, np.ndarray]
    rom: dict[str, np.ndarray]
    errors: dict[str, float] = field(default_factory=dict)

    def error_table(self, min_tip_pct: float = 1.0, max_tip_pct: float = np.inf
                    ) -> dict[str, float]:
        """Largest |ROM − FE| / |FE| per output over the levels with min_tip_pct ≤ tip ≤
        max_tip_pct (% of span). Values of an output below 1e-6 of the largest transverse one
        (e.g. Tx of a symmetric FE response, ~1e-13) are not divided by: NaN if none is left."""
        sel = (self.tip_pct_span >= min_tip_pct) & (self.tip_pct_span <= max_tip_pct)
        ref = max(np.abs(self.fe["A_Tz"]).max(), 1e-300)
        out = {}
        for k in self.fe:
            fe, ro = self.fe[k][sel], self.rom[k][sel]
            big = np.abs(fe) > 1e-6 * ref
            out[k] = float(np.max(np.abs(ro[big] - fe[big]) / np.abs(fe[big]))) if big.any() \
                else float("nan")
        return out


def static_validation(backend, rom, Phi: np.ndarray, shape: str, unit_load: np.ndarray, *,
                      max_tip_fraction: float = 0.25, n_levels: int = 10) -> StaticCurve:
    """FE vs ROM static responses at point A for ``level × unit_load``, up to a tip deflection
    of ``max_tip_fraction`` of the span (levels chosen from the linear response, then extended
    while the FE's tip deflection is below the target)."""
    missing = [k for k in OUTPUTS if k not in backend.outputs or k not in rom.outputs]
    if missing:
        raise InputError(f"static validation needs the outputs {missing} on the FE and the ROM")
    from .backend import solve_linear

    span = backend.reference_length
    u_lin = solve_linear(backend.stiffness_matrix(), unit_load)
    tip_lin = np.abs(u_lin[backend.transverse_dofs]).max()
    p_target = max_tip_fraction * span / tip_lin
    levels = list(np.linspace(p_target / n_levels, p_target, n_levels))
    dofs = {k: backend.outputs[k] for k in OUTPUTS}
    fe_out = {k: [] for k in OUTPUTS}
    rom_out = {k: [] for k in OUTPUTS}
    tips, done = [], []
    u_prev, q_prev, p_prev = None, None, None
    i = 0
    while i < len(levels):
        p = levels[i]
        u0 = None if u_prev is None else u_prev * (p / p_prev)
        try:
            u = backend.static_solve(p * unit_load, u0=u0).u
        except ConvergenceError:
            break
        q = rom_static_solve(rom, Phi.T @ (p * unit_load), q_prev)
        tip = 100 * np.abs(u[backend.transverse_dofs]).max() / span
        for k in OUTPUTS:
            fe_out[k].append(u[dofs[k]])
            rom_out[k].append(float(rom.outputs[k] @ q))
        tips.append(tip)
        done.append(p)
        u_prev, q_prev, p_prev = u, q, p
        i += 1
        # stiffening: keep going until the FE tip really reaches the target (within 0.5 %)
        if (i == len(levels) and tip < 100 * max_tip_fraction * (1 - 5e-3)
                and len(levels) < 3 * n_levels):
            levels.append(p * min(1.5, 100 * max_tip_fraction / tip))
    curve = StaticCurve(shape, np.array(done), np.array(tips),
                        {k: np.array(v) for k, v in fe_out.items()},
                        {k: np.array(v) for k, v in rom_out.items()})
    curve.errors = curve.error_table()
    return curve


# ------------------------------------------------------------------------------------------------
# dynamic validation
# ------------------------------------------------------------------------------------------------
@dataclass
class FreeDecay:
    """FE and ROM free decay of A_Tz; envelope and frequency comparison over ``cycles``."""

    t: np.ndarray
    fe: np.ndarray
    rom: np.ndarray
    gamma: float
    cycles: int
    metrics: dict = field(default_factory=dict)
    #: the ROM's initial state (its nonlinear static deflection under the release load)
    q0: np.ndarray | None = None


def _peaks(t: np.ndarray, y: np.ndarray, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Times and |values| of the first ``count`` extrema of y (parabolic refinement)."""
    d = np.diff(y)
    idx = np.flatnonzero(d[:-1] * d[1:] < 0) + 1
    ts, vs = [], []
    for i in idx[:count]:
        y0, y1, y2 = y[i - 1], y[i], y[i + 1]
        den = y0 - 2 * y1 + y2
        s = 0.5 * (y0 - y2) / den if den != 0 else 0.0
        ts.append(t[i] + s * (t[1] - t[0]))
        vs.append(abs(y1 - 0.25 * (y0 - y2) * s))
    return np.array(ts), np.array(vs)


def compare_decay(t, y_fe, y_rom, cycles: int) -> dict:
    """Envelope error (largest |A_rom/A_fe − 1| over the extrema of the first ``cycles`` cycles,
    oscillation about the final mean) and frequency error (from the extremum times)."""
    m_fe, m_rom = y_fe[-len(y_fe) // 10:].mean(), y_rom[-len(y_rom) // 10:].mean()
    tf, af = _peaks(t, y_fe - m_fe, 2 * cycles)
    tr, ar = _peaks(t, y_rom - m_rom, 2 * cycles)
    k = min(len(af), len(ar))
    if k < 3:
        return {"envelope_error": float("nan"), "frequency_error": float("nan"), "extrema": k}
    f_fe = (k - 1) / (2 * (tf[k - 1] - tf[0]))
    f_rom = (k - 1) / (2 * (tr[k - 1] - tr[0]))
    return {"envelope_error": float(np.max(np.abs(ar[:k] / af[:k] - 1))),
            "frequency_error": float(abs(f_rom / f_fe - 1)), "frequency_fe_hz": float(f_fe),
            "frequency_rom_hz": float(f_rom), "extrema": int(k),
            "initial_amplitude": float(af[0])}


def free_decay_validation(backend, rom, Phi: np.ndarray, unit_load: np.ndarray, *,
                          tip_fraction: float = 0.15,
                          gamma: float = 1e-3, cycles: int = 10, dt: float | None = None,
                          ) -> FreeDecay:
    """Release from the static deflection under ``p·unit_load`` (FE tip ≈ ``tip_fraction`` of
    span) and compare A_Tz of the FE and ROM transients over ``cycles`` periods of mode 1."""
    from .backend import solve_linear

    span = backend.reference_length
    u_lin = solve_linear(backend.stiffness_matrix(), unit_load)
    p = tip_fraction * span / np.abs(u_lin[backend.transverse_dofs]).max()
    u0 = backend.static_solve(p * unit_load).u
    q0 = rom_static_solve(rom, Phi.T @ (p * unit_load))
    f1 = float(np.nanmin(rom.frequencies_hz[np.isfinite(rom.frequencies_hz)]))
    dt = dt or 1.0 / (f1 * 200)
    t_end = (cycles + 0.75) / f1
    dof = backend.outputs["A_Tz"]
    t, y_fe = backend.free_decay(u0, t_end=t_end, dt=dt, gamma=gamma, record=[dof])
    tr, Q, _ = rom_free_decay(rom, q0, t_end=t_end, dt=dt, gamma=gamma)
    y_rom = Q @ rom.outputs["A_Tz"]
    k = min(len(t), len(tr))
    res = FreeDecay(t[:k], y_fe[:k, 0], y_rom[:k], gamma, cycles, q0=q0)
    res.metrics = compare_decay(res.t, res.fe, res.rom, cycles)
    return res


# ------------------------------------------------------------------------------------------------
# damping methods compared
# ------------------------------------------------------------------------------------------------
def compare_damping(rom_a, rom_b, Q: np.ndarray, V: np.ndarray) -> dict:
    """Tensor differences (relative to rom_b's) and dissipated power q̇ᵀ D_T(q) q̇ along a
    motion (rows of Q, V) of two ROMs with the same stiffness."""
    out = {}
    for name in ("D1", "D2", "D3"):
        A, B = getattr(rom_a, name), getattr(rom_b, name)
        out[f"{name}_rel_diff"] = float((A - B).abs().max() / max(float(B.abs().max()), 1e-300))
    Q = torch.as_tensor(np.ascontiguousarray(Q, dtype=float))
    V = torch.as_tensor(np.ascontiguousarray(V, dtype=float))
    Pa = rom_a.dissipated_power(Q, V).numpy()
    Pb = rom_b.dissipated_power(Q, V).numpy()
    scale = max(np.abs(Pb).max(), 1e-300)
    out["power_max_rel_diff"] = float(np.abs(Pa - Pb).max() / scale)
    out["power_mean_rel_diff"] = float(np.abs(Pa - Pb).mean() / np.abs(Pb).mean())
    out["power_min_a"] = float(Pa.min())
    out["power_min_b"] = float(Pb.min())
    return out
