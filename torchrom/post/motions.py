"""What a viewer shows: a mesh and a few frames of grid displacements (:class:`Motion`).

Built from what torchrom computes or keeps (the reconstruction itself is
:mod:`torchrom.rom.shapes`):

- :func:`mode_motion`: mode shapes (a deck's FE modes, or a ROM's basis), one frame per mode,
  as computed (mass-normalised: Φᵀ M Φ = I);
- :func:`flutter_motion`: the flutter mode at the flutter point (:mod:`torchrom.aero.flutter_mode`),
  u = Φ v on the grids, scaled so its largest translation is 1 (length unit) with phase 0
  there, as the real motions Re(u e^{iφ}) at equally spaced phases over one cycle;
- :func:`lco_motion`: a sweep row's LCO over one period from its stored orbit (harmonic balance:
  ``orbits.parquet``, the Fourier coefficients of q) or its history (time marching, a
  ``[history]`` that kept q1..qn), as physical displacements at N instants.

:func:`sweep_row` reads a sweep folder's row, its orbit or history.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..rom.shapes import MeshShapes, history_period, normalised_mode, orbit_states, phase_frames

#: what the frames of a motion are
KINDS = ("modes", "phases", "period")


@dataclass
class Motion:
    """A mesh and F frames of grid displacements (F, G, 6: T1..T3 along basic x y z, in the
    mesh's length unit, R1..R3 in rad).

    ``kind``: "modes" (``values`` Hz), "phases" (``values`` degrees) or "period" (``values`` s);
    ``keys``: a short name per frame ("mode2", "phase090", "t07"); ``complex_shape``: the complex
    mode (G, 6) of a "phases" motion, with its ``eigenvalue`` s (rad/s); ``scale``: what one unit
    of the displacements means ("mass-normalised", "largest translation 1 ft", "physical")."""

    shapes: MeshShapes
    kind: str
    keys: list[str]
    values: np.ndarray
    displacements: np.ndarray
    title: str
    scale: str
    complex_shape: np.ndarray | None = None
    eigenvalue: complex | None = None

    def __post_init__(self):
        if self.kind not in KINDS:
            raise InputError(f"motion: kind {self.kind!r}: expected one of {KINDS}")
        self.values = np.asarray(self.values, dtype=float).reshape(-1)
        self.displacements = np.asarray(self.displacements, dtype=float)
        F = len(self.keys)
        if self.values.shape != (F,) or self.displacements.shape != (F, self.shapes.n_grid, 6):
            raise InputError(f"motion: {F} frames, {self.values.size} values, displacements "
                             f"{self.displacements.shape}")

    def label(self, i: int) -> str:
        """The frame's value with its unit, e.g. "mode 2, 3.077 Hz", "phase 90°", "t = 0.12 s"."""
        v = self.values[i]
        if self.kind == "modes":
            return f"{self.keys[i].replace('mode', 'mode ')}, {v:.4g} Hz"
        if self.kind == "phases":
            return f"phase {v:.0f}°"
        return f"t = {v:.4g} s"


def mode_motion(shapes: MeshShapes, frequencies_hz, modes=None, title: str = "mode shapes"
                ) -> Motion:
    """The basis functions ``modes`` (1-based; default all) as frames (module docstring)."""
    f = np.asarray(frequencies_hz, dtype=float).reshape(-1)
    picked = list(range(1, shapes.n + 1)) if not modes else [int(m) for m in modes]
    bad = [m for m in picked if not 1 <= m <= shapes.n]
    if bad:
        raise InputError(f"--mode {bad[0]}: expected a mode number from 1 to {shapes.n}")
    u = np.stack([shapes.phi[:, :, m - 1] for m in picked])
    return Motion(shapes, "modes", [f"mode{m}" for m in picked],
                  np.array([f[m - 1] if m - 1 < f.size else np.nan for m in picked]), u, title,
                  "mass-normalised (Φᵀ M Φ = I)")


def flutter_motion(shapes: MeshShapes, vector, eigenvalue: complex, n_phases: int,
                   title: str) -> Motion:
    """The flutter mode (modal ``vector`` on the first m ≤ n basis functions, the aero modes;
    the others, which the aerodynamics do not load, zero) as phase frames (module docstring)."""
    v = np.zeros(shapes.n, dtype=complex)
    vec = np.asarray(vector, dtype=complex).reshape(-1)
    if vec.size > shapes.n:
        raise InputError(f"flutter mode: {vec.size} modal coordinates, the shapes have "
                         f"{shapes.n}")
    v[:vec.size] = vec
    u = shapes.motion(normalised_mode(v, shapes))
    phases, frames = phase_frames(u, n_phases)
    unit = shapes.length_unit or "length unit"
    return Motion(shapes, "phases", [f"phase{p:03.0f}" for p in phases], phases, frames, title,
                  f"largest translation 1 {unit}", complex_shape=u,
                  eigenvalue=complex(eigenvalue))


def lco_motion(shapes: MeshShapes, t, q, title: str) -> Motion:
    """An LCO's states q (N, n) at instants t (N,) of one period as physical displacements."""
    u = shapes.motion(np.asarray(q, dtype=float))
    return Motion(shapes, "period", [f"t{i:02d}" for i in range(len(t))], t, u, title,
                  "physical")


# -- a sweep's rows -----------------------------------------------------------------------------
@dataclass
class SweepRow:
    """One row of a sweep table and its LCO: ``t`` (N,) and ``q`` (N, n) over one period."""

    index: int
    case_id: str
    row: dict
    t: np.ndarray
    q: np.ndarray
    source: str


def _read(path: Path):
    import pandas as pd

    try:
        return pd.read_parquet(path)
    except Exception as exc:  # noqa: BLE001 - any reader failure is a bad file
        raise InputError(f"{path}: not a readable table ({type(exc).__name__}: {exc})") from None


def sweep_row(folder, row: str, n: int, n_frames: int) -> SweepRow:
    """The LCO of row ``row`` (its 0-based position in ``results.parquet``, or its case_id) of
    the sweep folder ``folder`` over one period at ``n_frames`` instants, for a ROM of ``n``
    basis functions: from ``orbits.parquet`` (harmonic balance) or ``histories.parquet`` with
    columns q1..qn (time marching). InputError naming the folder, the row and what is missing."""
    folder = Path(folder)
    table_path = folder / "results.parquet"
    if not table_path.is_file():
        raise InputError(f"{folder}: no results.parquet: expected the output folder of "
                         f"`torchrom sweep`")
    table = _read(table_path)
    ids = [str(c) for c in table["case_id"]] if "case_id" in table else []
    text = str(row).strip()
    if text.lstrip("-").isdigit():
        i = int(text)
        if not 0 <= i < len(table):
            raise InputError(f"--row {row}: {table_path} has rows 0..{len(table) - 1}")
    elif text in ids:
        i = ids.index(text)
    else:
        raise InputError(f"--row {row!r}: not a row number (0..{len(table) - 1}) nor a case_id "
                         f"of {table_path}")
    rec = table.iloc[i].to_dict()
    cid = ids[i] if ids else str(i)
    if rec.get("status") != "lco":
        raise InputError(f"--row {row}: case {cid} of {table_path} has status "
                         f"{rec.get('status')!r}, not an LCO: no period to show")
    names = [f"q{j + 1}" for j in range(n)]
    orbits, hist = folder / "orbits.parquet", folder / "histories.parquet"
    if orbits.is_file():
        from ..study.cases import orbits_of

        frame = _read(orbits)
        missing = [c for c in ("case_id", "omega", "k", *names) if c not in frame]
        if missing:
            raise InputError(f"{orbits}: missing columns {missing[:3]} (an orbit table of a "
                             f"ROM with {n} basis functions has case_id, omega, k, q1..q{n})")
        if cid in set(frame["case_id"].astype(str)):
            X, omega = orbits_of(frame, [cid], n)
            t, q = orbit_states(X[0], float(omega[0]), n_frames)
            return SweepRow(i, cid, rec, t, q, str(orbits))
    if hist.is_file():
        frame = _read(hist)
        own = frame[frame["case_id"].astype(str) == cid] if "case_id" in frame else frame[:0]
        if len(own) and all(c in own for c in names):
            t, q = history_period(own["t"].to_numpy(float), own[names].to_numpy(float),
                                  float(rec.get("frequency_hz", np.nan)), n_frames)
            return SweepRow(i, cid, rec, t, q, str(hist))
        if len(own):
            raise InputError(f"--row {row}: {hist} keeps case {cid}'s outputs "
                             f"{[c for c in own.columns if c not in ('case_id', 't')]}, not "
                             f"q1..q{n}: add \"q1\" .. \"q{n}\" to [lco] outputs and run the "
                             f"sweep again")
    raise InputError(f"--row {row}: {folder} keeps no orbit or history of case {cid}: run the "
                     f"sweep by harmonic balance (method = \"hb\": orbits.parquet) or keep its "
                     f"history with q1..q{n} among [lco] outputs ([history])")
