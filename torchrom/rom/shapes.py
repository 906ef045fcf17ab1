"""The ROM's shapes on the deck's grids, and the motions they make (DESIGN "Viewers").

A :class:`MeshShapes` holds, for every grid of the deck the ROM was identified on, its id, its
position (basic frame, the deck's length unit) and the six components of each basis function
there, Φ (G, 6, n): T1 T2 T3 along basic x y z, R1 R2 R3 about them (rad) — the free-DOF basis
expanded through the constraints (SPC'd components zero, RBE2/RBE3/MPC dependents filled in);
plus the mesh lines and faces to draw it with (shells as quads and triangles, rods, bars and
beams as lines; rigid elements, springs, masses and solids are left out). ``rom.npz`` keeps it
under the ``shape_*`` keys (:meth:`MeshShapes.to_arrays`).

Motions from modal coordinates, all linear in q (u = Φ q, the ROM's own kinematics):

- :meth:`MeshShapes.motion`: grid displacements of one or many states q;
- :func:`phase_frames`: a complex mode (a flutter eigenvector Φ v) as the real motions
  Re(u e^{iφ}) at equally spaced phases φ over one cycle;
- :func:`orbit_states`: a periodic orbit's Fourier coefficients X (rows a₀, a₁, b₁, a₂, b₂, …,
  :mod:`torchrom.periodic.fourier`) as q(t) at N instants of one period T = 2π/ω.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

#: the six components of a grid's motion, in the basic frame
COMPONENTS = ("T1", "T2", "T3", "R1", "R2", "R3")
#: the arrays of ``rom.npz`` that hold the shapes
KEYS = ("shape_grid_ids", "shape_xyz", "shape_phi", "shape_quads", "shape_trias", "shape_lines",
        "shape_info_json")


def missing_shapes_message(where: str) -> str:
    """One line: ``where`` (a ROM file) keeps no mode shapes, and how to get them."""
    return (f"{where}: this ROM keeps no mode shapes on the deck's grids (written before torchrom "
            f"stored them, or not by identify); re-run `torchrom identify` on its deck")


@dataclass
class MeshShapes:
    """Basis functions on the deck's grids (module docstring).

    Attributes:
        grid_ids: (G,) grid ids.
        xyz: (G, 3) positions in the basic frame, in ``length_unit``.
        phi: (G, 6, n) each basis function's T1..R3 at each grid (basic axes; rotations in rad),
            per unit modal coordinate.
        quads, trias, lines: (·, 4), (·, 3), (·, 2) rows of ``grid_ids`` (0-based).
        length_unit: the deck's length unit ("ft", "m", ...; None when the deck does not say).
        source: the deck (a path or a name).
    """

    grid_ids: np.ndarray
    xyz: np.ndarray
    phi: np.ndarray
    quads: np.ndarray = field(default_factory=lambda: np.zeros((0, 4), dtype=np.int64))
    trias: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), dtype=np.int64))
    lines: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    length_unit: str | None = None
    source: str = ""

    def __post_init__(self):
        self.grid_ids = np.asarray(self.grid_ids, dtype=np.int64).reshape(-1)
        self.xyz = np.asarray(self.xyz, dtype=float)
        self.phi = np.asarray(self.phi, dtype=float)
        G = self.grid_ids.size
        if self.xyz.shape != (G, 3):
            raise InputError(f"shapes: xyz: expected ({G}, 3), got {self.xyz.shape}")
        if self.phi.ndim != 3 or self.phi.shape[:2] != (G, 6):
            raise InputError(f"shapes: phi: expected ({G}, 6, n), got {self.phi.shape}")
        if not (np.all(np.isfinite(self.xyz)) and np.all(np.isfinite(self.phi))):
            raise InputError("shapes: xyz or phi holds entries that are not finite")
        for name, width in (("quads", 4), ("trias", 3), ("lines", 2)):
            a = np.asarray(getattr(self, name), dtype=np.int64).reshape(-1, width)
            if a.size and (a.min() < 0 or a.max() >= G):
                raise InputError(f"shapes: {name}: grid rows outside 0..{G - 1}")
            setattr(self, name, a)

    @property
    def n(self) -> int:
        """Number of basis functions."""
        return self.phi.shape[2]

    @property
    def n_grid(self) -> int:
        return self.grid_ids.size

    def motion(self, q) -> np.ndarray:
        """Grid displacements u = Φ q: q (..., n), real or complex -> (..., G, 6)."""
        q = np.asarray(q)
        if q.shape[-1] != self.n:
            raise InputError(f"shapes: expected {self.n} modal coordinates, got {q.shape[-1]}")
        return np.einsum("gcj,...j->...gc", self.phi, q)

    def span(self) -> float:
        """The mesh's largest extent (its span, for a wing), in ``length_unit``."""
        return float(np.ptp(self.xyz, axis=0).max()) if self.n_grid else 0.0

    def with_modes(self, n: int) -> MeshShapes:
        """The first ``n`` basis functions only."""
        return MeshShapes(self.grid_ids, self.xyz, self.phi[:, :, :n], self.quads, self.trias,
                          self.lines, self.length_unit, self.source)

    # -- rom.npz -----------------------------------------------------------------------------
    def to_arrays(self) -> dict[str, np.ndarray]:
        """The ``shape_*`` arrays of ``rom.npz`` (float64 shapes, int64 ids and rows)."""
        info = {"frame": "basic", "components": list(COMPONENTS),
                "length_unit": self.length_unit, "source": self.source,
                "grids": f"all {self.n_grid} grids of the deck"}
        return {"shape_grid_ids": self.grid_ids, "shape_xyz": self.xyz, "shape_phi": self.phi,
                "shape_quads": self.quads, "shape_trias": self.trias,
                "shape_lines": self.lines, "shape_info_json": np.array(json.dumps(info))}

    @classmethod
    def from_arrays(cls, data, where: str) -> MeshShapes | None:
        """The shapes stored in ``data`` (a mapping of ``rom.npz`` arrays); None when it holds
        none (a file written before shapes were stored); InputError naming ``where`` when they
        are incomplete or inconsistent."""
        present = [k for k in KEYS if k in data]
        if not present:
            return None
        missing = [k for k in KEYS if k not in data]
        if missing:
            raise InputError(f"{where}: incomplete mode shapes: missing arrays {missing}")
        try:
            info = json.loads(str(data["shape_info_json"]))
        except json.JSONDecodeError as exc:
            raise InputError(f"{where}: shape_info_json is not valid JSON ({exc})") from None
        try:
            return cls(data["shape_grid_ids"], data["shape_xyz"], data["shape_phi"],
                       data["shape_quads"], data["shape_trias"], data["shape_lines"],
                       info.get("length_unit"), str(info.get("source", "")))
        except InputError as exc:
            raise InputError(f"{where}: {exc}") from None


def unit_label(shapes: MeshShapes) -> str:
    """The length unit for labels ("length unit of the deck" when it is unknown)."""
    return shapes.length_unit or "deck length unit"


def phase_frames(u_complex, n_phases: int) -> tuple[np.ndarray, np.ndarray]:
    """(φ in degrees (N,), Re(u e^{iφ}) (N, ...)) at φ = 360° k / N, k = 0..N-1: the real motion
    of a complex mode u over one cycle (φ = 0 is Re u, φ = -90° is Im u)."""
    if int(n_phases) < 1:
        raise InputError(f"phases: expected at least 1, got {n_phases}")
    phi = 2 * np.pi * np.arange(int(n_phases)) / int(n_phases)
    u = np.asarray(u_complex, dtype=complex)
    frames = np.real(np.exp(1j * phi).reshape((-1,) + (1,) * u.ndim) * u[None])
    return np.degrees(phi), frames


def normalised_mode(v, shapes: MeshShapes | None = None) -> np.ndarray:
    """A complex mode scaled so that its largest translation (the grid component of largest
    modulus, or the largest modal coordinate without ``shapes``) is 1 + 0i: the phase reference
    of the frames and the unit of the shape (a mode has no amplitude of its own)."""
    v = np.asarray(v, dtype=complex)
    ref = shapes.motion(v)[..., :3].reshape(-1) if shapes is not None else v
    k = int(np.argmax(np.abs(ref)))
    if abs(ref[k]) == 0:
        raise InputError("mode: every translation is zero; nothing to normalise")
    return v / ref[k]


def orbit_states(X, omega: float, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(t (N,), q (N, n)) of a periodic orbit at t_k = k T / N, k = 0..N-1, T = 2π/ω:
    q(t) = a₀ + Σ_h a_h cos hωt + b_h sin hωt with X rows [a₀, a₁, b₁, a₂, b₂, …]."""
    X = np.asarray(X, dtype=float)
    if X.ndim != 2 or X.shape[0] % 2 != 1:
        raise InputError(f"orbit: expected Fourier coefficients (2H+1, n), got {X.shape}")
    if not (np.isfinite(omega) and omega > 0):
        raise InputError(f"orbit: expected a positive angular frequency, got {omega!r}")
    if int(n_frames) < 2:
        raise InputError(f"frames: expected at least 2 per period, got {n_frames}")
    t = 2 * np.pi / omega * np.arange(int(n_frames)) / int(n_frames)
    q = np.repeat(X[:1], t.size, axis=0)
    for h in range(1, (X.shape[0] - 1) // 2 + 1):
        q = q + np.outer(np.cos(h * omega * t), X[2 * h - 1]) \
            + np.outer(np.sin(h * omega * t), X[2 * h])
    return t, q


def history_period(t, q, frequency_hz: float, n_frames: int) -> tuple[np.ndarray, np.ndarray]:
    """(t (N,), q (N, n)) over the last full period 1/f of a sampled history (t (T,), q (T, n)),
    linearly interpolated at N equally spaced instants (t from 0): the LCO a time-marching sweep
    kept. InputError when the history is shorter than a period."""
    t = np.asarray(t, dtype=float)
    q = np.asarray(q, dtype=float)
    if not (np.isfinite(frequency_hz) and frequency_hz > 0):
        raise InputError(f"history: the row's frequency_hz is {frequency_hz!r}: no period")
    T = 1.0 / frequency_hz
    if t.size < 2 or t[-1] - t[0] < T:
        raise InputError(f"history: {t[-1] - t[0] if t.size else 0:g} s long, shorter than one "
                         f"period ({T:g} s)")
    ts = t[-1] - T + T * np.arange(int(n_frames)) / int(n_frames)
    qs = np.stack([np.interp(ts, t, q[:, j]) for j in range(q.shape[1])], axis=1)
    return ts - ts[0], qs
