"""Initial states on the ROM's static manifold (hand-written; batched Newton with torch.linalg).

A start with a large displacement of the linear modes only puts the dual coordinates (the
in-plane / membrane basis functions that carry the geometric nonlinearity, ``rom.mode_kinds``
"dual") far from where the linear coordinates hold them: their static response to the linear
motion is quadratic in it, and a start without it excites the stiff dual modes violently
enough to break the nonlinear iteration at the paper's step (beyond ≈ 5 % of span on the Goland
wing at dt = 1 ms). :func:`static_manifold` gives the dual coordinates q_D their nonlinear static
values for the given linear coordinates q_L:

    r_D(q) = [K_T q + s ⊙ (K2(q,q) + K3(q,q,q))]_D = 0,        q = [q_L (fixed); q_D]

(the dual rows of the static part of Eq. 54, K_T = K1 + K_add the case's linear stiffness),
solved by Newton with the Jacobian [K_T + s K_nl,t(q)]_DD (the ROM's tangent stiffness), one
batched solve per iteration. Cases never mix; a case whose iteration does not converge keeps its
last iterate and is reported in the returned flag.
"""

from __future__ import annotations

import numpy as np
import torch

from .system import CaseSystem, as_float_tensor

Tensor = torch.Tensor


def dual_indices(rom) -> list[int]:
    """Indices of the ROM's dual basis functions (``mode_kinds == "dual"``)."""
    return [i for i, kind in enumerate(rom.mode_kinds) if kind == "dual"]


def static_manifold(system: CaseSystem, q0, *, iterations: int = 20, rtol: float = 1e-12
                    ) -> tuple[np.ndarray, np.ndarray]:
    """(q, converged): ``q0`` (B, n) or (n,) with the dual coordinates replaced by their
    nonlinear static values for its linear coordinates (see the module docstring); float64.

    ``rtol``: Newton stops when the largest update is below rtol × (1 + |q_D|∞) in every case.
    A ROM without dual basis functions returns ``q0`` unchanged."""
    rom = system.rom
    B, n = system.batch_size, system.n
    q = as_float_tensor(q0, device="cpu").reshape(-1, n).expand(B, n).clone()
    dual = dual_indices(rom)
    converged = torch.ones(B, dtype=torch.bool)
    if not dual:
        return q.numpy(), converged.numpy()
    sysd = system.to(device="cpu", dtype=torch.float64)
    s = sysd.stiffness_nl
    K_add = sysd.K_add
    d = torch.as_tensor(dual)
    zero = torch.zeros_like(q)
    # start from the linear static response of the dual rows (exact for a linear ROM)
    converged = torch.zeros(B, dtype=torch.bool)
    for _ in range(int(iterations)):
        f = rom.stiffness_force(q, s)
        Kt, _ = rom.tangents(q, zero, 0.0, 0.0, s, 0.0)
        if K_add is not None:
            f = f + torch.einsum("bij,bj->bi", K_add, q)
            Kt = Kt + K_add
        J = Kt[:, d][:, :, d]
        step, info = torch.linalg.solve_ex(J, f[:, d])
        ok = (info == 0) & torch.isfinite(step).all(1)
        step = torch.where(ok.unsqueeze(1), step, 0.0)
        q[:, d] -= step
        size = step.abs().amax(1)
        converged = ok & (size <= rtol * (1.0 + q[:, d].abs().amax(1)))
        if bool(converged.all()):
            break
    return q.numpy(), converged.numpy()
