"""The per-case batched system the integrator advances (COMMON "Simulator per-case system").

B cases of one structural ROM, each with its own linear additions and lag states:

    (M + M_add) q̈ + (α M + γ D̄1 + C_add) q̇ + (K1 + K_add) q + s·[K2(q,q) + K3(q,q,q)]
        + γ d·[D̄2(q) + D̄3(q,q)] q̇ + lag_D ξ = load,           ξ̇ = lag_E q̇ + lag_R ξ

The structural part is the paper's Eq. 54 (α in 1/s, γ in s); s and d are the per-case
nonlinearity switches (1.0 / 0.0, or any scale). The linear additions and the first-order lag
states are how anything else enters — the aerodynamics of Eqs. 49–50 map to M_add = q∞ (b²/V²) A2,
C_add = q∞ (b/V) A1, K_add = q∞ A0, lag_D = q∞ D, lag_E = E, lag_R = (V/b) R (zero-padded from
the m aerodynamic modes to n) — so the integrator never needs to know what they represent.
Torch tensors only.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
import torch

from ..checks import integer, physical_values
from ..errors import InputError
from ..rom import NonlinearROM

Tensor = torch.Tensor

def as_float_tensor(x, device=None, dtype=torch.float64) -> Tensor:
    """A tensor of ``dtype`` from a tensor, array, list, bool or float — going through float64, so
    that Python floats are never rounded to torch's default float32 on the way."""
    if isinstance(x, Tensor):
        return x.to(device=device, dtype=dtype)
    return torch.as_tensor(np.asarray(x, dtype=np.float64)).to(device=device, dtype=dtype)


_PER_CASE_SCALARS = ("alpha", "gamma", "stiffness_nl", "damping_nl")
_PER_CASE_MATRICES = ("M_add", "C_add", "K_add", "lag_D", "lag_E", "lag_R", "load")


@dataclass
class CaseSystem:
    """B cases of ``rom`` with per-case parameters (all tensors share one device and dtype).

    Attributes:
        rom: the structural ROM (M, K1, D̄1, K2, K3, D̄2, D̄3 at γ = 1).
        alpha: (B,) mass-proportional damping α (1/s), Eq. 54.
        gamma: (B,) Kelvin–Voigt factor γ (s), Eq. 53–54.
        stiffness_nl: (B,) scale s of K2(q,q) + K3(q,q,q) (1.0 on, 0.0 off).
        damping_nl: (B,) scale d of D̄2(q) + D̄3(q,q) (1.0 on, 0.0 off).
        M_add, C_add, K_add: (B, n, n) linear additions to mass, damping, stiffness, or None.
        lag_D: (B, n, na) force of the lag states on the structure, or None.
        lag_E: (B, na, n), lag_R: (B, na, na): ξ̇ = lag_E q̇ + lag_R ξ, or None (na = 0).
        load: (B, n) constant generalized force on the right-hand side, or None.
    """

    rom: NonlinearROM
    alpha: Tensor
    gamma: Tensor
    stiffness_nl: Tensor
    damping_nl: Tensor
    M_add: Tensor | None = None
    C_add: Tensor | None = None
    K_add: Tensor | None = None
    lag_D: Tensor | None = None
    lag_E: Tensor | None = None
    lag_R: Tensor | None = None
    load: Tensor | None = None

    # ------------------------------------------------------------------------------------------
    @classmethod
    def build(cls, rom: NonlinearROM, batch: int | None = None, *, alpha=0.0, gamma=0.0,
              stiffness_nl=1.0, damping_nl=1.0, M_add=None, C_add=None, K_add=None,
              lag_D=None, lag_E=None, lag_R=None, load=None, device=None,
              dtype=torch.float64) -> CaseSystem:
        """Broadcast scalars, (B,) sequences, shared (n, n) matrices or (B, ...) stacks to B cases.

        ``batch`` defaults to the first per-case dimension found among the inputs (else 1).
        Booleans are accepted for the nonlinearity switches.
        """
        if not isinstance(rom, NonlinearROM):
            raise InputError(f"CaseSystem.build: rom: expected a NonlinearROM, got "
                             f"{type(rom).__name__}")
        if batch is not None:
            batch = integer("CaseSystem.build: batch", batch, minimum=1)
        given = {"alpha": alpha, "gamma": gamma, "stiffness_nl": stiffness_nl,
                 "damping_nl": damping_nl, "M_add": M_add, "C_add": C_add, "K_add": K_add,
                 "lag_D": lag_D, "lag_E": lag_E, "lag_R": lag_R, "load": load}
        kw = {"device": device, "dtype": dtype}
        tensors = {}
        for k, v in given.items():
            if v is None:
                tensors[k] = None
                continue
            if isinstance(v, (str, bytes)):
                raise InputError(f"CaseSystem.build: {k}: expected numbers, got {v!r}")
            try:
                tensors[k] = as_float_tensor(v, **kw)
            except (TypeError, ValueError, RuntimeError) as exc:
                raise InputError(f"CaseSystem.build: {k}: expected numbers ({exc})") from None
            # the case parameters must be finite; a non-finite per-case matrix only marks its
            # own case 'failed' (the other cases are never affected)
            if k in _PER_CASE_SCALARS and bool((~torch.isfinite(tensors[k])).any()):
                bad = torch.nonzero(~torch.isfinite(tensors[k].reshape(-1)))[0].item()
                raise InputError(f"CaseSystem.build: {k}: expected finite values, got "
                                 f"{float(tensors[k].reshape(-1)[bad])} (case {bad})")
            if k in _PER_CASE_SCALARS:  # γ >= 0, scales >= 0 (one table for every entry point)
                physical_values(k, tensors[k].detach().cpu().numpy(), "CaseSystem.build:")
        if batch is None:
            batch = 1
            for name, t in tensors.items():
                if t is None:
                    continue
                shared_dim = 0 if name in _PER_CASE_SCALARS else (1 if name == "load" else 2)
                if t.dim() > shared_dim:
                    batch = t.shape[0]
                    break
        out = {}
        for name, t in tensors.items():
            if t is None:
                out[name] = None
                continue
            shared_dim = 0 if name in _PER_CASE_SCALARS else (1 if name == "load" else 2)
            if t.dim() == shared_dim:
                t = t.expand(batch, *t.shape)
            out[name] = t
        system = cls(rom, **out)
        system.validate()
        return system

    # ------------------------------------------------------------------------------------------
    @property
    def batch_size(self) -> int:
        return int(self.alpha.shape[0])

    @property
    def n(self) -> int:
        return self.rom.n

    @property
    def n_lag(self) -> int:
        return 0 if self.lag_R is None else int(self.lag_R.shape[-1])

    @property
    def device(self) -> torch.device:
        return self.alpha.device

    @property
    def dtype(self) -> torch.dtype:
        return self.alpha.dtype

    def validate(self) -> None:
        """Check shapes, devices and dtypes; InputError naming the field otherwise."""
        B, n = self.batch_size, self.n
        na = self.n_lag
        lags = [self.lag_D is None, self.lag_E is None, self.lag_R is None]
        if any(lags) and not all(lags):
            raise InputError("CaseSystem: lag_D, lag_E and lag_R must be given together")
        expected = {"alpha": (B,), "gamma": (B,), "stiffness_nl": (B,), "damping_nl": (B,),
                    "M_add": (B, n, n), "C_add": (B, n, n), "K_add": (B, n, n),
                    "lag_D": (B, n, na), "lag_E": (B, na, n), "lag_R": (B, na, na),
                    "load": (B, n)}
        for name, shape in expected.items():
            t = getattr(self, name)
            if t is None:
                continue
            if tuple(t.shape) != shape:
                raise InputError(f"CaseSystem.{name}: expected shape {shape} (B = {B}, n = {n}, "
                                 f"na = {na}), got {tuple(t.shape)}")
            if t.device != self.device or t.dtype != self.dtype:
                raise InputError(f"CaseSystem.{name}: on {t.device}/{t.dtype}, expected "
                                 f"{self.device}/{self.dtype} like alpha")

    def fields(self) -> dict[str, Tensor | None]:
        """The per-case tensors by name."""
        return {name: getattr(self, name) for name in (*_PER_CASE_SCALARS, *_PER_CASE_MATRICES)}

    def select(self, index) -> CaseSystem:
        """The cases ``index`` (a LongTensor, list or slice) as a new CaseSystem."""
        if not isinstance(index, slice):
            index = torch.as_tensor(index, dtype=torch.long, device=self.device)
        return dataclasses.replace(
            self, **{k: None if t is None else t[index] for k, t in self.fields().items()})

    @classmethod
    def concat(cls, systems: list[CaseSystem]) -> CaseSystem:
        """Stack the cases of several systems of the same ROM (e.g. chunks of a sweep)."""
        if not systems:
            raise InputError("CaseSystem.concat: no systems given")
        rom = systems[0].rom
        if any(s.rom is not rom for s in systems):
            raise InputError("CaseSystem.concat: all systems must share one ROM object")
        out = {}
        for name in systems[0].fields():
            parts = [getattr(s, name) for s in systems]
            if all(p is None for p in parts):
                out[name] = None
                continue
            if any(p is None for p in parts):
                # materialise the missing additions as zeros so that the stack is rectangular
                ref = next(p for p in parts if p is not None)
                parts = [p if p is not None else ref.new_zeros((s.batch_size, *ref.shape[1:]))
                         for p, s in zip(parts, systems)]
            out[name] = torch.cat(parts, dim=0)
        return cls(rom, **out)

    def blend(self, other: CaseSystem, weight) -> CaseSystem:
        """(1 − w)·self + w·other, field by field (w scalar or (B,)): the cases on the straight
        path between two sets of cases of the same ROM (a homotopy for continuation methods;
        a field missing on one side counts as zero)."""
        if other.rom is not self.rom or other.batch_size != self.batch_size:
            raise InputError("CaseSystem.blend: expected the same ROM and batch size")
        w = torch.as_tensor(weight, dtype=self.dtype, device=self.device).reshape(-1)
        out = {}
        for name, a in self.fields().items():
            b = getattr(other, name)
            if a is None and b is None:
                out[name] = None
                continue
            a = torch.zeros_like(b) if a is None else a
            b = torch.zeros_like(a) if b is None else b
            ww = w.reshape(-1, *([1] * (a.dim() - 1)))
            out[name] = (1 - ww) * a + ww * b
        return dataclasses.replace(self, **out)

    def to(self, device=None, dtype=None) -> CaseSystem:
        return dataclasses.replace(
            self, **{k: None if t is None else t.to(device=device, dtype=dtype)
                     for k, t in self.fields().items()})


#: load steps of :func:`static_equilibrium` (a cubic ROM at a wing's static deflection: Newton
#: from rest under the whole load can overshoot past a fold of the polynomial)
EQUILIBRIUM_LOAD_STEPS = 8


def static_equilibrium(system: CaseSystem, rtol: float = 1e-12, max_iter: int = 30) -> Tensor:
    """(B, n) the static states of the cases: (K1 + K_add) q + s·[K2(q,q) + K3(q,q,q)] = load
    (zero without a load), by Newton under the load in :data:`EQUILIBRIUM_LOAD_STEPS` equal
    steps. A case that does not converge is NaN (its own rows only)."""
    B, n = system.batch_size, system.n
    q = torch.zeros(B, n, device=system.device, dtype=system.dtype)
    if system.load is None:
        return q
    rom, zero = system.rom, torch.zeros_like(q)
    scale = system.load.norm(dim=1).clamp_min(torch.finfo(system.dtype).tiny)
    ok = torch.ones(B, dtype=torch.bool, device=system.device)
    for step in range(1, EQUILIBRIUM_LOAD_STEPS + 1):
        load = system.load * (step / EQUILIBRIUM_LOAD_STEPS)
        done = torch.zeros(B, dtype=torch.bool, device=system.device)
        for _ in range(max_iter):
            r = rom.stiffness_force(q, system.stiffness_nl) - load
            if system.K_add is not None:
                r = r + (system.K_add @ q.unsqueeze(-1)).squeeze(-1)
            done = torch.isfinite(r).all(dim=1) & (r.norm(dim=1) <= rtol * scale)
            if bool((done | ~ok).all()):
                break
            Kt, _ = rom.tangents(q, zero, stiffness_nl=system.stiffness_nl)
            if system.K_add is not None:
                Kt = Kt + system.K_add
            dq, info = torch.linalg.solve_ex(Kt, r.unsqueeze(-1))
            move = (info == 0)[:, None] & ~done[:, None] & ok[:, None]
            q = q - torch.where(move, dq.squeeze(-1), torch.zeros_like(q))
        ok &= done
    return torch.where(ok[:, None], q, torch.full_like(q, float("nan")))
