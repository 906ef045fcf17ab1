"""``aero.npz``: generalized aerodynamic forces and their RFA (DESIGN file contract).

On numpy's ``.npz`` container, written atomically (:func:`torchrom.io.atomic_path`).

Arrays (m modes, nk reduced frequencies, n_a lag states), sign F_aero = -q∞ Q q (paper Eq. 49):

==============  ===============  ===========================================================
key             shape            meaning
==============  ===============  ===========================================================
format_version  ()               this layout's version (1)
mach            ()               Mach number of the GAFs
semichord       ()               reference length b of k = ω b / V and p = s b / V
k               (nk,)            reduced frequencies (k[0] = 0)
Q               (m, m, nk)       complex GAF Q(ik)
A0, A1, A2      (m, m)           RFA polynomial matrices (Eq. 49)
D, R, E         (m,n_a) (n_a,n_a) (n_a,m)  lag matrices (Eqs. 49–50)
lag_roots       (n_L,)           lag roots γ (R = -diag(γ) for minimum state)
rfa_kind        ()               "minimum-state" or "roger"
fit_error       ()               JSON text of the fit-error report
metadata        ()               JSON text (kernel, panels, units, source, frequencies, ...)
incidence       (m,)             optional: Q_iα, the k = 0 generalized force of a rigid nose-up
                                 incidence of 1 rad on each mode, F_i = −q∞ Q_iα α (the steady
                                 load of a root angle of attack; files written before it lack it)
==============  ===============  ===========================================================
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..io import atomic_path, check_can_write
from .dlm import GAF
from .rfa import RFA

FORMAT_VERSION = 1


@dataclass
class AeroData:
    """GAFs on the first m structural modes plus their RFA (what ``aero.npz`` holds)."""

    gaf: GAF
    rfa: RFA
    metadata: dict = field(default_factory=dict)
    incidence: np.ndarray | None = None

    @property
    def n_modes(self) -> int:
        return self.gaf.n_modes

    @property
    def mach(self) -> float:
        return self.gaf.mach

    @property
    def semichord(self) -> float:
        return self.gaf.semichord

    def padded_incidence(self, n: int, where: str = "aero file") -> np.ndarray:
        """The incidence load Q_iα on n ≥ m coordinates (zero past the m modes: dual modes
        carry no aerodynamic force); InputError naming ``where`` for a file without one."""
        if self.incidence is None:
            raise InputError(f"{where}: no steady incidence load (written by an older torchrom "
                             "aero; build it again with torchrom aero)")
        out = np.zeros(n)
        out[:self.n_modes] = self.incidence
        return out

    def padded_steady_stiffness(self, n: int, where: str = "aero file") -> np.ndarray:
        """Q(0) (n, n), the steady aerodynamic stiffness per unit dynamic pressure (the GAF at
        k = 0, real; zero past the m modes); InputError naming ``where`` without a k = 0 GAF."""
        zero = np.flatnonzero(self.gaf.k == 0.0)
        if not len(zero):
            raise InputError(f"{where}: no GAF at k = 0 (the steady aerodynamic stiffness)")
        out = np.zeros((n, n))
        m = self.n_modes
        out[:m, :m] = self.gaf.Q[zero[0]].real
        return out

    def save(self, path: str | os.PathLike, force: bool = False) -> Path:
        return save_aero(self, path, force=force)

    @classmethod
    def load(cls, path: str | os.PathLike) -> AeroData:
        return load_aero(path)


def save_aero(data: AeroData, path: str | os.PathLike, force: bool = False) -> Path:
    path = Path(path)
    check_can_write(path, force, "aero file")
    r = data.rfa
    with atomic_path(path) as tmp:
        np.savez(
            tmp,
            format_version=np.array(FORMAT_VERSION),
            mach=np.array(data.gaf.mach),
            semichord=np.array(data.gaf.semichord),
            k=data.gaf.k,
            Q=np.transpose(data.gaf.Q, (1, 2, 0)),
            A0=r.A0,
            A1=r.A1,
            A2=r.A2,
            D=r.D,
            R=r.R,
            E=r.E,
            lag_roots=r.lag_roots,
            rfa_kind=np.array(r.kind),
            fit_error=np.array(json.dumps(r.fit_error)),
            metadata=np.array(json.dumps({"kernel": data.gaf.kernel, **data.metadata})),
            **({} if data.incidence is None else {"incidence": np.asarray(data.incidence, float)}),
        )
    return path


def load_aero(path: str | os.PathLike) -> AeroData:
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: aero file not found")
    try:
        z = np.load(path, allow_pickle=False)
    except Exception as exc:  # noqa: BLE001 - any unreadable file is a user error
        raise InputError(f"{path}: not a readable .npz file ({exc})") from None
    need = [
        "format_version",
        "mach",
        "semichord",
        "k",
        "Q",
        "A0",
        "A1",
        "A2",
        "D",
        "R",
        "E",
        "lag_roots",
        "rfa_kind",
    ]
    missing = [key for key in need if key not in z.files]
    if missing:
        raise InputError(f"{path}: array {missing[0]!r} missing (not an aero.npz file?)")
    version = int(z["format_version"])
    if version != FORMAT_VERSION:
        raise InputError(f"{path}: format_version: expected {FORMAT_VERSION}, got {version}")
    q = z["Q"]
    k = z["k"]
    if q.ndim != 3 or q.shape[0] != q.shape[1] or q.shape[2] != len(k):
        raise InputError(f"{path}: Q: expected shape (m, m, {len(k)}), got {q.shape}")
    m = q.shape[0]
    na = z["R"].shape[0]
    shapes = {"A0": (m, m), "A1": (m, m), "A2": (m, m), "D": (m, na), "R": (na, na), "E": (na, m)}
    for key, shape in shapes.items():
        if z[key].shape != shape:
            raise InputError(f"{path}: {key}: expected shape {shape}, got {z[key].shape}")
    for key in ["k", "Q", *shapes]:
        if not np.all(np.isfinite(z[key])):
            raise InputError(f"{path}: {key}: contains non-finite values")
    incidence = None
    if "incidence" in z.files:
        incidence = np.asarray(z["incidence"], dtype=float)
        if incidence.shape != (m,) or not np.all(np.isfinite(incidence)):
            raise InputError(f"{path}: incidence: expected {m} finite values, got shape "
                             f"{incidence.shape}")
    meta = json.loads(str(z["metadata"])) if "metadata" in z.files else {}
    kernel = meta.pop("kernel", "quartic")
    gaf = GAF(float(z["mach"]), float(z["semichord"]), k, np.transpose(q, (2, 0, 1)), kernel)
    rfa = RFA(
        z["A0"],
        z["A1"],
        z["A2"],
        z["D"],
        z["R"],
        z["E"],
        z["lag_roots"],
        str(z["rfa_kind"]),
        float(z["semichord"]),
        float(z["mach"]),
        json.loads(str(z["fit_error"])) if "fit_error" in z.files else {},
    )
    return AeroData(gaf, rfa, meta, incidence)
