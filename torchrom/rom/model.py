"""The :class:`NonlinearROM`: structural reduced-order model with geometric stiffness nonlinearity
and Kelvin–Voigt nonlinear damping (paper Eqs. 12, 14, 29, 53–54).

    M q̈ + α M q̇ + γ (D̄1 + D̄2(q) + D̄3(q,q)) q̇ + K1 q + K2(q,q) + K3(q,q,q) = F          (Eq. 54)

Tensors are kept in torchrom's symmetric storage (see :mod:`.conventions`); batched force and
tangent evaluation go through the compact monomial kernels of :mod:`.kernels`. α (1/s), γ (s) and
the flags ``stiffness_nl`` / ``damping_nl`` are per-case inputs, so one ROM serves a whole batch of
cases. Written here: no library implements this model.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch

from ..errors import InputError
from . import conventions as cv
from .kernels import CompactForces

Tensor = torch.Tensor

#: relative tolerance of the symmetry checks at construction (identified tensors carry rounding)
SYMMETRY_RTOL = 1e-9


def _as_tensor(x, name: str) -> Tensor:
    try:
        t = torch.as_tensor(np.asarray(x.detach().cpu() if isinstance(x, Tensor) else x),
                            dtype=torch.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: not a numeric array ({exc})") from None
    return t


def _per_case(x, B: int, like: Tensor) -> Tensor:
    """Broadcast a scalar, bool or (B,) array to a (B, 1) tensor on like's device/dtype."""
    # straight to like's dtype: torch.as_tensor(0.05) would round to float32 first
    t = torch.as_tensor(x, dtype=like.dtype, device=like.device)
    if t.dim() == 0:
        return t.expand(B).reshape(B, 1)
    return t.reshape(B, 1)


class NonlinearROM:
    """Nonlinear ROM tensors plus basis metadata.

    Args:
        M, K1: (n, n) mass and linear stiffness; M must be symmetric positive definite.
        K2: (n, n, n) symmetric in its last two indices (default zero).
        K3: (n, n, n, n) symmetric in its last three indices (default zero).
        D1: (n, n) linear damping at γ = 1 (default K1: in the linear regime Eq. 54 is Rayleigh
            damping with D̄1 = K1).
        D2: (n, n, n), force D2_mln q_l q̇_n (default zero).
        D3: (n, n, n, n) symmetric in its middle two, force D3_mlpn q_l q_p q̇_n (default zero).
        mode_kinds: one label per basis function, e.g. "linear" or "dual".
        frequencies_hz: linear natural frequency per basis function (NaN for dual modes).
        outputs: name -> (n,) row: a physical output that is linear in q (e.g. "A_Tz").
        metadata: JSON-serialisable provenance (source model, identification options, ...).
        symmetrize: symmetrize the tensors instead of rejecting small asymmetries.
        shapes: the basis on the deck's grids (:class:`~torchrom.rom.shapes.MeshShapes`), or
            None (a ROM not identified from a deck, or read from a file written before).
        reference: the deformed state the ROM is expanded about
            (:class:`~torchrom.rom.reference.ReferenceState`; its coordinates are then
            x = q − q_ref), or None (about the undeformed state).
    """

    TENSORS = ("M", "K1", "K2", "K3", "D1", "D2", "D3")

    def __init__(
        self,
        M,
        K1,
        K2=None,
        K3=None,
        D1=None,
        D2=None,
        D3=None,
        *,
        mode_kinds: Sequence[str] | None = None,
        frequencies_hz=None,
        outputs: Mapping[str, Any] | None = None,
        metadata: Mapping[str, Any] | None = None,
        symmetrize: bool = False,
        shapes=None,
        reference=None,
    ):
        M = _as_tensor(M, "M")
        if M.dim() != 2 or M.shape[0] != M.shape[1] or M.shape[0] == 0:
            raise InputError(f"M: expected a square (n, n) matrix, got shape {tuple(M.shape)}")
        n = M.shape[0]
        zeros = {"K2": (n,) * 3, "K3": (n,) * 4, "D2": (n,) * 3, "D3": (n,) * 4}
        given = {"M": M, "K1": K1, "K2": K2, "K3": K3, "D1": D1 if D1 is not None else K1,
                 "D2": D2, "D3": D3}
        t: dict[str, Tensor] = {}
        for name in self.TENSORS:
            val = given[name]
            if val is None:
                t[name] = torch.zeros(zeros[name], dtype=torch.float64)
                continue
            val = _as_tensor(val, name)
            expected = (n, n) if name in ("M", "K1", "D1") else zeros[name]
            if tuple(val.shape) != expected:
                raise InputError(
                    f"{name}: expected shape {expected} for n = {n} basis functions, "
                    f"got {tuple(val.shape)}"
                )
            if not torch.isfinite(val).all():
                bad = int((~torch.isfinite(val)).sum())
                raise InputError(f"{name}: {bad} entries are not finite (NaN or inf)")
            t[name] = val
        if symmetrize:
            for name in ("M", "K1", "D1"):
                t[name] = 0.5 * (t[name] + t[name].T)
            t["K2"] = cv.sym_last2(t["K2"])
            t["K3"] = cv.sym_last3(t["K3"])
            t["D3"] = cv.sym_middle2(t["D3"])
        else:
            for name in ("M", "K1", "D1"):
                _check_symmetric(name, t[name], t[name].T, "symmetric")
            _check_symmetric("K2", t["K2"], t["K2"].transpose(1, 2), "symmetric in its last two "
                             "indices (K2_mnl = K2_mln)")
            _check_symmetric("K3", t["K3"], cv.sym_last3(t["K3"]), "symmetric in its last three "
                             "indices")
            _check_symmetric("D3", t["D3"], t["D3"].transpose(1, 2), "symmetric in its middle two "
                             "indices (D3_mlpn = D3_mpln)")
        try:
            torch.linalg.cholesky(t["M"])
        except RuntimeError:
            emin = torch.linalg.eigvalsh(0.5 * (t["M"] + t["M"].T)).min().item()
            raise InputError(
                f"M: not positive definite (smallest eigenvalue {emin:.3e})"
            ) from None
        for name, val in t.items():
            setattr(self, name, val)
        self.n = n
        self.mode_kinds = list(mode_kinds) if mode_kinds is not None else ["linear"] * n
        if len(self.mode_kinds) != n:
            raise InputError(f"mode_kinds: expected {n} labels, got {len(self.mode_kinds)}")
        if frequencies_hz is None:
            frequencies_hz = self.linear_frequencies_hz()
        self.frequencies_hz = np.asarray(frequencies_hz, dtype=float).reshape(-1)
        if self.frequencies_hz.shape != (n,):
            raise InputError(f"frequencies_hz: expected {n} values, got "
                             f"{self.frequencies_hz.size}")
        self.outputs: dict[str, np.ndarray] = {}
        for key, row in (outputs or {}).items():
            row = np.asarray(row, dtype=float).reshape(-1)
            if row.shape != (n,) or not np.all(np.isfinite(row)):
                raise InputError(f"outputs[{key!r}]: expected {n} finite values, got shape "
                                 f"{row.shape}")
            self.outputs[str(key)] = row
        self.metadata: dict[str, Any] = dict(metadata or {})
        if shapes is not None and shapes.n != n:
            raise InputError(f"shapes: {shapes.n} basis functions on the grids, the ROM has {n}")
        self.shapes = shapes
        if reference is not None and reference.q.shape != (n,):
            raise InputError(f"reference: {reference.q.size} coordinates, the ROM has {n}")
        self.reference = reference
        self._kernels: dict[tuple, CompactForces] = {}

    # ------------------------------------------------------------------------------------------
    # construction helpers
    # ------------------------------------------------------------------------------------------
    @classmethod
    def from_combined(cls, M, K1, K2c=None, K3c=None, D1=None, D2=None, D3c=None, **kw):
        """Build from the paper's combined tensors K̃2, K̃3, D̃3 (Eqs. 25–29)."""
        sym = cv.from_combined(
            None if K2c is None else _as_tensor(K2c, "K2 (combined)"),
            None if K3c is None else _as_tensor(K3c, "K3 (combined)"),
            None if D3c is None else _as_tensor(D3c, "D3 (combined)"),
        )
        return cls(M, K1, sym.get("K2"), sym.get("K3"), D1, D2, sym.get("D3"), **kw)

    @classmethod
    def from_gram(cls, M, K1, G, H, **kw):
        """Build from the energy form (K1, G, H): stiffness and Kelvin–Voigt damping at γ = 1."""
        t = cv.tensors_from_gram(_as_tensor(K1, "K1"), _as_tensor(G, "G"), _as_tensor(H, "H"))
        return cls(M, **t, **kw)

    def replace(self, **changes) -> NonlinearROM:
        """A copy with some tensors or metadata replaced."""
        args = {name: getattr(self, name) for name in self.TENSORS}
        meta = {"mode_kinds": self.mode_kinds, "frequencies_hz": self.frequencies_hz,
                "outputs": self.outputs, "metadata": self.metadata, "shapes": self.shapes,
                "reference": self.reference}
        for key, val in changes.items():
            if key in args:
                args[key] = val
            elif key in meta:
                meta[key] = val
            else:
                raise TypeError(f"replace: unknown field {key!r}")
        return NonlinearROM(**args, **meta)

    # ------------------------------------------------------------------------------------------
    # derived quantities
    # ------------------------------------------------------------------------------------------
    def linear_frequencies_hz(self) -> np.ndarray:
        """Natural frequencies of (M, K1) in Hz, ascending (NaN where K1 has λ < 0)."""
        Li = torch.linalg.inv(torch.linalg.cholesky(self.M))
        lam = torch.linalg.eigvalsh(Li @ self.K1 @ Li.T).numpy()
        with np.errstate(invalid="ignore"):
            return np.sqrt(np.where(lam >= 0, lam, np.nan)) / (2 * math.pi)

    def combined(self) -> dict[str, Tensor]:
        """The paper's combined tensors K̃2, K̃3, D̃3 (Eqs. 25, 26, 28) as dense tensors."""
        return cv.to_combined(self.K2, self.K3, self.D3)

    def gram(self) -> tuple[Tensor, Tensor]:
        """(G, H) of the Kelvin–Voigt damping tensors (unique, see :func:`gram_from_damping`)."""
        return cv.gram_from_damping(self.D2, self.D3)

    def extended_damping_matrix(self) -> Tensor:
        """D_B (Eq. 34) on [q̇ ; sym(q ⊗ q̇)] in an orthonormal pair basis, (n + N2)²."""
        G, H = self.gram()
        return cv.damping_extended_matrix(self.D1, G, H)

    def extended_damping_min_eigenvalue(self) -> float:
        """Smallest eigenvalue of D_B on the symmetric pair subspace (≥ 0 ⇒ dissipative)."""
        return float(torch.linalg.eigvalsh(self.extended_damping_matrix()).min())

    def output_matrix(self, names: Sequence[str] | None = None) -> tuple[list[str], np.ndarray]:
        """(names, C) with C (n_out, n) such that outputs = C q."""
        names = list(self.outputs) if names is None else list(names)
        missing = [k for k in names if k not in self.outputs]
        if missing:
            raise InputError(f"outputs {missing} not defined for this ROM; it has "
                             f"{sorted(self.outputs)}")
        C = np.stack([self.outputs[k] for k in names]) if names else np.zeros((0, self.n))
        return names, C

    def grid_shapes(self, where: str = "ROM"):
        """The basis on the deck's grids (:class:`~torchrom.rom.shapes.MeshShapes`); InputError
        naming ``where`` (the ROM file) and saying to identify again when the ROM keeps none."""
        if self.shapes is None:
            from .shapes import missing_shapes_message

            raise InputError(missing_shapes_message(where))
        return self.shapes

    def content_hash(self) -> str:
        """SHA-256 (hex, first 16) of the tensors and outputs: identifies the model in caches."""
        h = hashlib.sha256()
        for name in self.TENSORS:
            h.update(name.encode())
            h.update(np.ascontiguousarray(getattr(self, name).numpy()).tobytes())
        for key in sorted(self.outputs):
            h.update(key.encode())
            h.update(self.outputs[key].tobytes())
        if self.reference is not None:  # (absent: the hash of every earlier ROM is unchanged)
            h.update(b"reference")
            h.update(self.reference.q.tobytes())
            h.update(self.reference.force.tobytes())
        return h.hexdigest()[:16]

    # ------------------------------------------------------------------------------------------
    # batched forces (Eq. 54)
    # ------------------------------------------------------------------------------------------
    def kernels(self, device=None, dtype=torch.float64, symmetric: bool = False
                ) -> CompactForces:
        """The compact monomial kernels on a device/dtype (built once, then cached);
        ``symmetric``: symmetric coefficient matrices as upper triangles (:mod:`.kernels`)."""
        key = (str(torch.device(device) if device is not None else torch.device("cpu")), dtype,
               bool(symmetric))
        if key not in self._kernels:
            self._kernels[key] = CompactForces.build(
                self.M, self.K1, self.K2, self.K3, self.D1, self.D2, self.D3,
                device=device, dtype=dtype, symmetric=symmetric,
            )
        return self._kernels[key]

    def _prep(self, q: Tensor) -> tuple[Tensor, bool, CompactForces]:
        single = q.dim() == 1
        q2 = q.reshape(1, -1) if single else q
        if q2.shape[-1] != self.n:
            raise InputError(f"q: expected last dimension {self.n}, got {q2.shape[-1]}")
        return q2, single, self.kernels(q2.device, q2.dtype)

    def stiffness_force(self, q: Tensor, stiffness_nl=True) -> Tensor:
        """K1 q + K2(q,q) + K3(q,q,q) for q (B, n) or (n,)."""
        q2, single, k = self._prep(q)
        f = q2 @ k.K1.T
        s = _per_case(stiffness_nl, q2.shape[0], q2)
        f = f + s * k.stiffness_nl(q2)
        return f[0] if single else f

    def damping_matrix(self, q: Tensor, damping_nl=True) -> Tensor:
        """Tangent damping matrix at γ = 1, D̄1 + D̄2(q) + D̄3(q,q) (Eq. 32): (B, n, n)."""
        q2, single, k = self._prep(q)
        s = _per_case(damping_nl, q2.shape[0], q2).unsqueeze(-1)
        D = k.D1 + s * k.damping_nl_matrix(q2)
        return D[0] if single else D

    def dissipated_power(self, q: Tensor, qd: Tensor) -> Tensor:
        """q̇ᵀ D_T(q) q̇ at γ = 1 (Eq. 33); ≥ 0 for a dissipative model."""
        D = self.damping_matrix(q)
        return torch.einsum("...m,...mn,...n->...", qd, D, qd)

    def force(self, q: Tensor, qd: Tensor, alpha=0.0, gamma=0.0, stiffness_nl=True,
              damping_nl=True) -> Tensor:
        """Structural force of Eq. 54 for a batch: q, q̇ (B, n); α, γ, flags scalar or (B,)."""
        q2, single, k = self._prep(q)
        qd2 = qd.reshape(q2.shape)
        B = q2.shape[0]
        m2 = q2[:, k.pair_i] * q2[:, k.pair_j]
        s_nl = _per_case(stiffness_nl, B, q2)
        d_nl = _per_case(damping_nl, B, q2)
        a = _per_case(alpha, B, q2)
        g = _per_case(gamma, B, q2)
        f = q2 @ k.K1.T + s_nl * k.stiffness_nl(q2, m2)
        d_lin = qd2 @ k.D1.T
        d_nl_force = torch.bmm(k.damping_nl_matrix(q2, m2), qd2.unsqueeze(-1)).squeeze(-1)
        f = f + a * (qd2 @ k.M.T) + g * (d_lin + d_nl * d_nl_force)
        return f[0] if single else f

    def tangents(self, q: Tensor, qd: Tensor, alpha=0.0, gamma=0.0, stiffness_nl=True,
                 damping_nl=True) -> tuple[Tensor, Tensor]:
        """(∂f/∂q, ∂f/∂q̇) of Eq. 54, each (B, n, n) (or (n, n) for a single state)."""
        q2, single, k = self._prep(q)
        qd2 = qd.reshape(q2.shape)
        B = q2.shape[0]
        s_nl = _per_case(stiffness_nl, B, q2).unsqueeze(-1)
        d_nl = _per_case(damping_nl, B, q2).unsqueeze(-1)
        a = _per_case(alpha, B, q2).unsqueeze(-1)
        g = _per_case(gamma, B, q2).unsqueeze(-1)
        Kt = k.K1 + s_nl * k.tangent_nl(q2)
        # ∂/∂q_j of D2_mln q_l q̇_n + D3_mlpn q_l q_p q̇_n = D2_mjn q̇_n + 2 D3_mjpn q_p q̇_n
        D2 = self.D2.to(q2.device, q2.dtype)
        D3 = self.D3.to(q2.device, q2.dtype)
        dD = torch.einsum("mjn,bn->bmj", D2, qd2) + 2.0 * torch.einsum(
            "mjpn,bp,bn->bmj", D3, q2, qd2
        )
        Kt = Kt + g * d_nl * dD
        Ct = a * k.M + g * (k.D1 + d_nl * k.damping_nl_matrix(q2))
        if single:
            return Kt[0], Ct[0]
        return Kt, Ct

    # ------------------------------------------------------------------------------------------
    # devices, files, display
    # ------------------------------------------------------------------------------------------
    def to(self, device=None, dtype=None) -> NonlinearROM:
        """Warm the compact kernels for a device/dtype and return self (tensors stay float64 CPU
        as the master copy; every computation moves its kernels to the inputs' device/dtype)."""
        self.kernels(device, dtype or torch.float64)
        return self

    def save(self, path) -> None:
        """Write ``rom.npz`` atomically (see :mod:`.storage`)."""
        from .storage import save_rom

        save_rom(self, path)

    @classmethod
    def load(cls, path) -> NonlinearROM:
        """Read ``rom.npz``; a corrupt or mismatched file gives an InputError naming it."""
        from .storage import load_rom

        return load_rom(path, cls)

    def __repr__(self) -> str:
        kinds = {k: self.mode_kinds.count(k) for k in dict.fromkeys(self.mode_kinds)}
        return f"NonlinearROM(n={self.n}, kinds={kinds}, outputs={sorted(self.outputs)})"


def _check_symmetric(name: str, T: Tensor, T_sym: Tensor, what: str) -> None:
    scale = T.abs().max().item()
    if scale == 0.0:
        return
    err = (T - T_sym).abs().max().item()
    if err > SYMMETRY_RTOL * scale:
        raise InputError(
            f"{name}: not {what}: largest asymmetry {err:.3e} is {err / scale:.1e} of its largest "
            f"entry (tolerance {SYMMETRY_RTOL:g}); symmetrize it or pass symmetrize=True"
        )
