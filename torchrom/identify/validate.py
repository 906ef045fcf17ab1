"""Validation of an identified ROM against its FE model (paper Sec. III.E, Figs. 3–8; issue 4).

- **Static**: for a load shape F (uniform pressure, "step uniform" pressure: positive ahead of
  the wing's mid-chord line, negative behind — for the Goland wing x = 3 ft of the 6 ft chord,
  i.e. a lift plus a nose-up torque on the 4 ft box, see
  :func:`torchrom.identify.fe_backend.step_midline`), load levels from the linear range up to a
  tip deflection of ≈ 25 % of the span: FE Newton (the backend's static solver, continuation in
  the level) vs ROM Newton on K1 q + K2(q,q) + K3(q,q,q) = Φᵀ F (Eqs. 12, 14); outputs at
  point A (A_Tx, A_Ty, A_Tz), or, where the deck names no point A, at the ROM's default
  output (the translation that moves most in the first elastic mode, :func:`validation_outputs`).
  A deck without a pressure skin (a beam stick model) is loaded by the inertia load M φ of its
  first elastic mode instead (:func:`load_shapes`). A free structure (rigid-body modes) is
  solved under inertia relief on both sides: the FE by its INREL solve (Gᵀ M u = 0), the ROM
  by the Galerkin projection of it (its rigid-body coordinates' rows of M q = 0, the rigid
  accelerations balancing the load, :func:`rom_static_solve`).
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
                     max_iter: int = 50, n_rigid: int = 0) -> np.ndarray:
    """Newton–Raphson with load halving for K1 q + K2(q,q) + K3(q,q,q) = f (generalized).

    ``n_rigid`` > 0 (a free structure's rigid-body modes, the first basis functions): under
    inertia relief, K(q) + M_r a = f with M_rᵀ q = 0 (M_r: the first ``n_rigid`` columns of
    M; a: the rigid-body accelerations), the Galerkin projection of the FE's INREL solve
    (:func:`torchrom.fe.solvers.inertia_relief_static`)."""
    f = np.asarray(f, float)
    r = int(n_rigid)
    Mr = rom.M.numpy()[:, :r]
    q = np.zeros(rom.n) if q0 is None else np.array(q0, float)
    lam, inc = 0.0, 1.0
    scale = max(np.linalg.norm(f), 1e-300)
    zeros = torch.zeros(rom.n, dtype=torch.float64)
    a = np.zeros(r)
    while lam < 1.0:
        target = min(1.0, lam + inc)
        v, b, ok = q.copy(), a.copy(), False
        for _ in range(max_iter):
            qt = torch.as_tensor(v)
            res = np.concatenate([target * f - rom.stiffness_force(qt).numpy() - Mr @ b,
                                  -Mr.T @ v])
            if np.linalg.norm(res) <= tol * scale:
                ok = True
                break
            Kt, _ = rom.tangents(qt, zeros)
            step = scipy.linalg.solve(np.block([[Kt.numpy(), Mr], [Mr.T, np.zeros((r, r))]]),
                                      res)
            v, b = v + step[: rom.n], b + step[rom.n:]
            if not np.all(np.isfinite(v)):
                break
        if ok:
            q, a, lam = v, b, target
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
        ref = max(max(np.abs(v).max(initial=0.0) for v in self.fe.values()), 1e-300)
        out = {}
        for k in self.fe:
            fe, ro = self.fe[k][sel], self.rom[k][sel]
            big = np.abs(fe) > 1e-6 * ref
            out[k] = float(np.max(np.abs(ro[big] - fe[big]) / np.abs(fe[big]))) if big.any() \
                else float("nan")
        return out


def validation_outputs(backend, Phi: np.ndarray, n_rigid: int = 0) -> dict[str, int]:
    """Name -> FE DOF of the compared outputs: point A's translations (A_Tx, A_Ty, A_Tz) where
    the deck names them (the Goland deck), else the ROM's default output ``max_mode1``, the
    translation that moves most in the first elastic mode (basis function ``n_rigid``), named
    with its grid and component (e.g. ``max_mode1 G1001:T3``)."""
    if all(k in backend.outputs for k in OUTPUTS):
        return {k: int(backend.outputs[k]) for k in OUTPUTS}
    from ..rom.points import largest_translation

    dof = largest_translation(Phi, backend.translational_dofs, mode=n_rigid)
    label = backend.dof_label(dof) if hasattr(backend, "dof_label") else None
    return {"max_mode1" + (f" {label}" if label else ""): int(dof)}


def linear_response(backend, load: np.ndarray) -> np.ndarray:
    """K⁻¹ load; for a free structure (the backend's ``rigid_shapes``) the inertia-relief
    response (:func:`torchrom.fe.solvers.inertia_relief_solve`)."""
    from .backend import solve_linear

    rigid = backend.rigid_shapes() if hasattr(backend, "rigid_shapes") else np.zeros((0, 0))
    if rigid.size:
        from ..fe.solvers import inertia_relief_solve

        return inertia_relief_solve(backend.stiffness_matrix(), backend.mass_matrix(), rigid,
                                    load)
    return solve_linear(backend.stiffness_matrix(), load)


def tip_measure(backend, u_lin: np.ndarray):
    """The function u → tip deflection (largest |·|): of the backend's transverse
    displacements, or of its translations where the load ``u_lin`` moves none of those (a
    straight beam's "thickness direction" is either of two: a bending mode may move the
    other)."""
    moved = np.abs(u_lin[backend.translational_dofs]).max(initial=0.0)
    tr = np.abs(backend.transverse_displacements(u_lin))
    if tr.size and tr.max() > 1e-6 * moved:
        return lambda u: float(np.abs(backend.transverse_displacements(u)).max())
    dofs = np.asarray(backend.translational_dofs)
    return lambda u: float(np.abs(u[dofs]).max())


def load_shapes(backend, Phi: np.ndarray, n_rigid: int = 0) -> dict[str, np.ndarray]:
    """The backend's static load shapes that load the structure (the pressures of a wing's
    skin); none on a deck without a pressure skin (a beam stick model): then the inertia load
    M φ of the first elastic mode (basis function ``n_rigid``), whose linear response is
    φ/ω² — a load every structure carries."""
    shapes = {k: v for k, v in backend.load_shapes().items() if np.any(v)}
    if shapes:
        return shapes
    return {"mode1_inertia": np.asarray(backend.mass_matrix() @ Phi[:, n_rigid])}


def static_validation(backend, rom, Phi: np.ndarray, shape: str, unit_load: np.ndarray, *,
                      max_tip_fraction: float = 0.25, n_levels: int = 10,
                      outputs: dict[str, int] | None = None, n_rigid: int = 0) -> StaticCurve:
    """FE vs ROM static responses at point A (or ``outputs``: name -> FE DOF, the ROM's
    output the row Φ[dof]) for ``level × unit_load``, up to a tip deflection of
    ``max_tip_fraction`` of the span (levels chosen from the linear response, then extended
    while the FE's tip deflection is below the target); ``n_rigid`` > 0: both under inertia
    relief (the module docstring)."""
    if outputs is None:
        missing = [k for k in OUTPUTS if k not in backend.outputs or k not in rom.outputs]
        if missing:
            raise InputError(f"static validation needs the outputs {missing} on the FE and "
                             f"the ROM")
        outputs = {k: backend.outputs[k] for k in OUTPUTS}
    span = backend.reference_length
    u_lin = linear_response(backend, unit_load)
    tip = tip_measure(backend, u_lin)
    tip_lin = tip(u_lin)
    p_target = max_tip_fraction * span / tip_lin
    levels = list(np.linspace(p_target / n_levels, p_target, n_levels))
    dofs = dict(outputs)
    rows = {k: np.asarray(Phi)[dof] for k, dof in dofs.items()}
    fe_out = {k: [] for k in dofs}
    rom_out = {k: [] for k in dofs}
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
        q = rom_static_solve(rom, Phi.T @ (p * unit_load), q_prev, n_rigid=n_rigid)
        tips.append(100 * tip(u) / span)
        for k in dofs:
            fe_out[k].append(u[dofs[k]])
            rom_out[k].append(float(rows[k] @ q))
        done.append(p)
        u_prev, q_prev, p_prev = u, q, p
        i += 1
        # stiffening: keep going until the FE tip really reaches the target (within 0.5 %)
        if (i == len(levels) and tips[-1] < 100 * max_tip_fraction * (1 - 5e-3)
                and len(levels) < 3 * n_levels):
            levels.append(p * min(1.5, 100 * max_tip_fraction / tips[-1]))
    if not done:
        raise ConvergenceError(
            f"static validation, {shape} load: the FE's static solve failed at the first level "
            f"({levels[0]:.4g} x the load, {100 * max_tip_fraction / n_levels:.3g} % of the "
            f"span at the tip by the linear response): the ROM stands, its report cannot be "
            f"made (check the deck's constraints and the pressure skin)")
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
    #: name of the compared output (:func:`validation_outputs`)
    output: str = "A_Tz"


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
                          dof: int | None = None, n_rigid: int = 0) -> FreeDecay:
    """Release from the static deflection under ``p·unit_load`` (FE tip ≈ ``tip_fraction`` of
    span) and compare A_Tz (or the FE DOF ``dof``) of the FE and ROM transients over
    ``cycles`` periods of the first elastic mode; ``n_rigid`` > 0: the deflection under
    inertia relief (a free structure released from it keeps zero momentum)."""
    span = backend.reference_length
    u_lin = linear_response(backend, unit_load)
    p = tip_fraction * span / tip_measure(backend, u_lin)(u_lin)
    u0 = backend.static_solve(p * unit_load).u
    q0 = rom_static_solve(rom, Phi.T @ (p * unit_load), n_rigid=n_rigid)
    f = np.asarray(rom.frequencies_hz, dtype=float)
    f1 = float(f[np.isfinite(f) & (f > 0)].min())  # the rigid-body modes' 0 Hz left out
    dt = dt or 1.0 / (f1 * 200)
    t_end = (cycles + 0.75) / f1
    dof = backend.outputs["A_Tz"] if dof is None else int(dof)
    t, y_fe = backend.free_decay(u0, t_end=t_end, dt=dt, gamma=gamma, record=[dof])
    tr, Q, _ = rom_free_decay(rom, q0, t_end=t_end, dt=dt, gamma=gamma)
    y_rom = Q @ np.asarray(Phi)[dof]
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
