"""Generalized aerodynamic forces Q(k) from the doublet-lattice method.

The aerodynamic influence coefficients — vortex-lattice steady part plus the doublet-lattice
oscillatory increment, quartic [Rodden et al. 1998] or parabolic [Rodden et al. 1971] kernel
approximation — come from :mod:`torchrom.aero.dlm_kernel` (written here, vectorised over box
pairs and reduced frequencies; ``engine="torch"``) or from PanelAero (``engine="panelaero"``,
``VLM.calc_Ajj`` + ``DLM.calc_Ajj`` one frequency at a time: the reference the torch kernel is
tested against). Written here: normalwash from the modal box motion, the pressure solve (on the
half model when the boxes and the motion are xz-symmetric), the generalized-force integration
and the reduced-frequency conversion.

Conventions (DESIGN; REFERENCE Sec. 7):

* reduced frequency k = ω b / V with b the reference semichord (Nastran/ZAERO); PanelAero
  takes k_PA = ω / V, so ``k_PA = k / b`` is applied here and nowhere else;
* harmonic motion q(t) = q̄ e^{iωt}; PanelAero's normalwash w_j (positive like an angle of
  attack, giving Δc_p > 0 along the box normal) is w_j = -(∂h/∂x + i (k/b) h) at the
  three-quarter-chord point;
* the GAF follows the paper's sign (Eq. 49): the aerodynamic force on the modal coordinates is
  F_aero = -q∞ Q(ik) q, so Q_ij = -Σ_p h_i(p) A_p Δc_p(j) with h_i at the quarter-chord (load)
  point, summed over the boxes of the modelled (half) structure only — image boxes of a
  mirrored model carry the image wing's loads. At k = 0, Q is an aerodynamic stiffness; the
  imaginary part of Q_ii is positive for aerodynamic damping. (Nastran's QHH is -Q.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from .panels import AeroPanels

KERNELS = ("quartic", "parabolic")
ENGINES = ("torch", "panelaero")


@dataclass
class BoxMotion:
    """Modal motion of the aerodynamic boxes (n_modes rows, one column per box).

    h_load:     normal displacement at the quarter-chord (load) points
    h_control:  normal displacement at the three-quarter-chord (normalwash) points
    slope_control: ∂h/∂x at the three-quarter-chord points
    """

    h_load: np.ndarray
    h_control: np.ndarray
    slope_control: np.ndarray

    def __post_init__(self):
        self.h_load = np.atleast_2d(np.asarray(self.h_load, dtype=float))
        self.h_control = np.atleast_2d(np.asarray(self.h_control, dtype=float))
        self.slope_control = np.atleast_2d(np.asarray(self.slope_control, dtype=float))
        shapes = {self.h_load.shape, self.h_control.shape, self.slope_control.shape}
        if len(shapes) != 1:
            raise InputError(
                f"box motion: arrays must have one shape (n_modes, n_boxes), got {shapes}"
            )

    @property
    def n_modes(self) -> int:
        return self.h_load.shape[0]

    @classmethod
    def from_function(cls, panels: AeroPanels, shapes) -> BoxMotion:
        """Motion from callables ``(h(x, y), dh/dx(x, y))`` per mode (analytic test shapes)."""
        lp, cp = panels.doublet_points, panels.control_points
        return cls(
            h_load=[f(lp[:, 0], lp[:, 1]) for f, _ in shapes],
            h_control=[f(cp[:, 0], cp[:, 1]) for f, _ in shapes],
            slope_control=[g(cp[:, 0], cp[:, 1]) for _, g in shapes],
        )


@dataclass
class GAF:
    """Generalized aerodynamic forces Q(ik) (paper sign: F_aero = -q∞ Q q), Q shape (nk, m, m)."""

    mach: float
    semichord: float
    k: np.ndarray
    Q: np.ndarray
    kernel: str = "quartic"

    def __post_init__(self):
        self.k = np.asarray(self.k, dtype=float)
        self.Q = np.asarray(self.Q, dtype=complex)
        if self.Q.ndim != 3 or self.Q.shape[0] != len(self.k) or self.Q.shape[1] != self.Q.shape[2]:
            raise InputError(
                f"GAF: Q: expected shape (nk, m, m) with nk={len(self.k)}, got {self.Q.shape}"
            )

    @property
    def n_modes(self) -> int:
        return self.Q.shape[1]

    def subset(self, n_modes: int) -> GAF:
        return GAF(self.mach, self.semichord, self.k, self.Q[:, :n_modes, :n_modes], self.kernel)


def _check_k(k_list, semichord: float) -> np.ndarray:
    k = np.asarray(k_list, dtype=float).reshape(-1)
    if len(k) == 0 or np.any(~np.isfinite(k)) or np.any(k < 0):
        raise InputError(f"GAF: reduced frequencies: expected finite k >= 0, got {k_list!r}")
    if not semichord > 0:
        raise InputError(f"GAF: reference semichord: expected > 0, got {semichord!r}")
    return k


def compute_gaf(
    panels: AeroPanels,
    motion: BoxMotion,
    mach: float,
    k_list,
    semichord: float,
    kernel: str = "quartic",
    progress=None,
    engine: str = "torch",
    k_exact: int | None = None,
) -> GAF:
    """Q(ik) for every reduced frequency k (= ω b / V, b = ``semichord``) in ``k_list``.

    ``motion`` gives the modal box motion on *these* panels (already mirrored if full span).
    ``progress``: optional callable(i, nk) called after each frequency.
    ``engine``: "torch" (:mod:`torchrom.aero.dlm_kernel`) or "panelaero" (the reference).
    ``k_exact``: solve the DLM at no more than this many of the k (:func:`exact_k_indices`) and
    interpolate Q at the others by a cubic spline in k per entry (None: every k solved).
    """
    from ..bounds import check_boxes

    if engine not in ENGINES:
        raise InputError(f"GAF: engine: expected one of {ENGINES}, got {engine!r}")
    check_boxes("GAF", panels.n)  # all the boxes together (several CAERO panels, mirrored)
    if kernel not in KERNELS:
        raise InputError(f"GAF: kernel: expected one of {KERNELS}, got {kernel!r}")
    if not (0.0 <= mach < 1.0):
        raise InputError(f"GAF: mach: the doublet-lattice method is subsonic, got {mach!r}")
    if motion.h_load.shape[1] != panels.n:
        raise InputError(
            f"GAF: box motion has {motion.h_load.shape[1]} boxes, the panels have {panels.n}"
        )
    k = _check_k(k_list, semichord)
    # Generalized forces act on the modal coordinates of the structure that is modelled: with a
    # mirrored (full-span) aero model the image boxes shape the flow, but their loads act on the
    # image wing, so only the half-model boxes are integrated.
    weights = motion.h_load * panels.areas * ~panels.mirrored  # (m, n): h_i(p) A_p
    solved = exact_k_indices(k, k_exact)
    solver = _gaf_torch if engine == "torch" else _gaf_panelaero
    q = solver(panels, motion, weights, mach, k[solved], semichord, kernel, progress)
    if len(solved) < len(k):
        from scipy.interpolate import CubicSpline

        order = np.argsort(k[solved])
        q_solved = q
        q = CubicSpline(k[solved][order], q_solved[order], axis=0)(k)
        q[solved] = q_solved  # the spline passes through them: keep them to the last bit
    return GAF(mach=float(mach), semichord=float(semichord), k=k, Q=q, kernel=kernel)


def exact_k_indices(k: np.ndarray, k_exact: int | None) -> np.ndarray:
    """Indices of the k at which the DLM is solved when at most ``k_exact`` may be: all of them,
    or ``k_exact`` (≥ 4, for a cubic spline) spread evenly over the sorted list — its
    clustering kept — with both ends and k = 0 (the steady limit) always included."""
    if k_exact is None or k_exact >= len(k):
        return np.arange(len(k))
    if isinstance(k_exact, bool) or not isinstance(k_exact, (int, np.integer)) or k_exact < 4:
        raise InputError(f"GAF: k_exact: expected an integer >= 4, got {k_exact!r}")
    order = np.argsort(k, kind="stable")
    picks = set(order[np.unique(np.linspace(0, len(k) - 1, k_exact).round().astype(int))])
    picks |= set(np.flatnonzero(k == 0.0))
    return np.array(sorted(picks))


def _gaf_panelaero(panels, motion, weights, mach, k, semichord, kernel, progress):
    from panelaero import DLM, VLM

    a_steady, _ = VLM.calc_Ajj(aerogrid=panels.to_panelaero(), Ma=mach)
    q = np.empty((len(k), motion.n_modes, motion.n_modes), dtype=complex)
    for i, ki in enumerate(k):
        a = a_steady.astype(complex)
        if ki > 0.0:
            # PanelAero's reduced frequency is ω/V: the k/b conversion happens here only.
            a = a + DLM.calc_Ajj(
                aerogrid=panels.to_panelaero(), Ma=mach, k=ki / semichord, method=kernel
            )
        w = -(motion.slope_control + 1j * (ki / semichord) * motion.h_control)  # (m, n)
        # Δc_p = Qjj w with Qjj = -Ajj⁻¹  ->  Δc_p = solve(Ajj, -w)
        dcp = np.linalg.solve(a, -w.T)  # (n, m)
        q[i] = -(weights @ dcp)
        if progress is not None:
            progress(i + 1, len(k))
    return q


@dataclass
class XZFold:
    """Half-model reduction of an xz-mirrored lattice with a symmetric (sign +1) or
    antisymmetric (-1) motion: the image box of unknown j carries ``sign`` times its Δc_p, so
    the AIC columns of the images fold onto their source boxes and only the half-model boxes
    receive (rows). Exact: the full system's solution has that symmetry."""

    rows: np.ndarray
    images: np.ndarray
    sign: float

    def apply(self, a: np.ndarray) -> np.ndarray:
        return a[..., self.rows] + self.sign * a[..., self.images]


def xz_fold(panels: AeroPanels, motion: BoxMotion) -> XZFold | None:
    """The :class:`XZFold` of these panels and motion, or None when they are not exactly
    xz-mirror symmetric (no images, xy images, unpaired boxes, asymmetric motion)."""
    mirrored = panels.mirrored
    if not mirrored.any() or panels.xy_image.any() or 2 * mirrored.sum() != panels.n:
        return None
    rows, images = np.flatnonzero(~mirrored), np.flatnonzero(mirrored)
    by_source = {int(s): i for s, i in zip(panels.source[images], images)}
    if len(by_source) != len(images) or len(set(panels.source[rows].tolist())) != len(rows):
        return None
    if any(int(s) not in by_source for s in panels.source[rows]):
        return None
    pair = np.array([by_source[int(s)] for s in panels.source[rows]])
    image_corners = panels.corners[rows][:, [3, 2, 1, 0], :] * [1.0, -1.0, 1.0]
    size = float(np.abs(panels.corners).max())
    if not np.allclose(panels.corners[pair], image_corners, rtol=0.0, atol=1e-13 * size):
        return None
    arrays = (motion.h_load, motion.h_control, motion.slope_control)
    for sign in (1.0, -1.0):
        if all(np.array_equal(a[:, pair], sign * a[:, rows]) for a in arrays):
            return XZFold(rows, pair, sign)
    return None


def _gaf_torch(panels, motion, weights, mach, k, semichord, kernel, progress):
    from .dlm_kernel import LatticeGeometry, oscillatory_aic, steady_aic

    fold = xz_fold(panels, motion)
    rows = np.arange(panels.n) if fold is None else fold.rows
    geometry = LatticeGeometry.from_panels(panels, rows)
    a_steady = steady_aic(geometry, mach)
    if fold is not None:
        a_steady = fold.apply(a_steady)
    weights = weights[:, rows]
    q = np.empty((len(k), motion.n_modes, motion.n_modes), dtype=complex)
    done = 0

    def solve(indices, a):
        nonlocal done
        kb = (k[indices] / semichord)[:, None, None]
        w = -(motion.slope_control[:, rows] + 1j * kb * motion.h_control[:, rows])  # (nk, m, n)
        # Δc_p = solve(Ajj, -w): (nk, n, m)
        dcp = np.linalg.solve(a, -np.swapaxes(w, 1, 2))
        q[indices] = -(weights @ dcp)
        for _ in indices:
            done += 1
            if progress is not None:
                progress(done, len(k))

    steady = np.flatnonzero(k == 0.0)
    if len(steady):
        solve(steady, np.broadcast_to(a_steady, (len(steady),) + a_steady.shape).astype(complex))
    moving = np.flatnonzero(k > 0.0)
    if len(moving):
        # PanelAero's reduced frequency is ω/V: the k/b conversion happens here only.
        for idx, d in oscillatory_aic(geometry, mach, k[moving] / semichord, kernel):
            a = d if fold is None else fold.apply(d)
            a += a_steady
            solve(moving[idx], a)
    return q


def lift_curve_slope(
    panels: AeroPanels, mach: float, k: float = 0.0, kernel: str = "quartic", semichord: float = 1.0
) -> complex:
    """C_Lα of a rigid pitch (about x = 0) from the GAF pipeline: -Q_plunge,pitch / S."""
    motion = BoxMotion.from_function(
        panels,
        [
            (lambda x, y: np.ones_like(x), lambda x, y: np.zeros_like(x)),
            (lambda x, y: -x, lambda x, y: -np.ones_like(x)),
        ],
    )
    gaf = compute_gaf(panels, motion, mach, [k], semichord, kernel)
    return -gaf.Q[0, 0, 1] / panels.areas[~panels.mirrored].sum()
