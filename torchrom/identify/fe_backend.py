"""FE backend for the built-in geometrically nonlinear FE (:mod:`torchrom.fe`).

A thin adapter from the ``torchrom.fe`` model (COMMON "FE" contract) to the backend protocol of
:mod:`.backend`: matrices, forces and tangents are the FE's own; static solves use the FE's
Newton solver with load stepping; the reference length is the largest extent of the grid (the
span of a wing), the transverse DOFs are the T-components along the smallest extent (the
thickness direction), and the outputs are the FE's output points (e.g. "A_Tz").
"""

from __future__ import annotations

import time

import numpy as np

from ..errors import ConvergenceError
from ..fe.wing_frame import WingFrameError, principal_axes, structural_rows
from ..rom.points import point_label
from .backend import FEBackend, StaticSolution, project


def step_midline(fe) -> float:
    """Mid-line of the "step uniform" pressure (DIGEST Sec. 6), as a position along the wing's
    chord axis (:meth:`FEModel.wing_frame`; basic x for a wing whose chord runs along +x): the
    mid-chord from the model's ``wing_chord`` (x of the leading and trailing edges, e.g. (0, 6)
    ft for the heavy Goland wing, whose 4 ft box spans x = 0..4: mid-chord 3 ft, so the step
    pressure is a lift plus a nose-up torque) where the chord runs along basic x, else the middle
    of the structure's chord extent."""
    frame = fe.wing_frame()
    chord = getattr(fe, "wing_chord", None)
    if chord is not None and abs(frame.chord[0]) > 1 - 1e-9:
        return 0.5 * (float(chord[0]) + float(chord[1])) * float(np.sign(frame.chord[0]))
    return float(frame.origin @ frame.chord)


class BuiltinFEBackend(FEBackend):
    """Backend over a ``torchrom.fe.FEModel``.

    ``step_x``: chordwise position (basic x) of the mid-line of the "step uniform" pressure;
    default :func:`step_midline`.
    ``static_tol``: relative residual of the FE's Newton solver. 1e-8 rather than tighter: with
    E ≈ 1.5e9 psf the element forces carry rounding of ~1e-7 lbf, which is ~1e-9 of the smallest
    dual-mode loads (0.1 % of span), so a tighter tolerance cannot always be met.
    """

    has_material_tangent = True
    #: modified Newton's limits in one static solve (:meth:`_modified_newton`): residual
    #: evaluations and tangent factorisations before the FE's full Newton takes over
    MODIFIED_NEWTON_ITERATIONS = 40
    MODIFIED_NEWTON_TANGENTS = 8

    @staticmethod
    def accepts(fe) -> bool:
        return all(hasattr(fe, a) for a in ("n_dof", "internal_force", "tangent_stiffness",
                                            "mass_matrix", "free_dofs", "static_solve"))

    def __init__(self, fe, *, static_tol: float = 1e-8, step_x: float | None = None):
        super().__init__()
        self.fe = fe
        self._step_x = None if step_x is None else float(step_x)
        self.n_dof = int(fe.n_dof)
        self.name = str(getattr(fe, "name", "fe"))
        self.static_tol = static_tol
        self._rows = structural_rows(fe)
        try:
            frame = fe.wing_frame()
            axes = frame.axes
        except WingFrameError:  # a beam-line model nobody said the up axis of
            frame = None
            axes = principal_axes(np.asarray(fe.grid_xyz, float)[self._rows])
        self._up = None if frame is None else frame.up
        #: the wing's length: its largest extent along its own axes (rotation-invariant)
        self.reference_length = float(np.ptp(np.asarray(fe.grid_xyz, float) @ axes.T,
                                             axis=0).max())
        comps = np.array([c for _, c in fe.free_dofs()])
        self._transverse_dofs = np.zeros(0, dtype=int)
        self._translational_dofs = np.flatnonzero(comps <= 3)
        self._rigid: np.ndarray | None = None
        self.n_rigid = 0
        self._outputs = {name: int(fe.dof_index(gid, comp))
                         for name, (gid, comp) in getattr(fe, "output_points", {}).items()}
        self._labels = [point_label(g, c) for g, c in fe.free_dofs()]
        self._linear_factor = None  # K's factorisation: modified Newton from rest
        self._factor = None  # the last converged static solve's tangent factorisation

    @property
    def step_x(self) -> float:
        """The step pressure's mid-line (:func:`step_midline` unless set)."""
        if self._step_x is None:
            self._step_x = step_midline(self.fe)
        return self._step_x

    @step_x.setter
    def step_x(self, value: float) -> None:
        self._step_x = float(value)

    def transverse_displacements(self, u) -> np.ndarray:
        """Each structural grid's displacement along the wing's up axis (none where the axis
        cannot be told): the transverse deflection whatever the deck's orientation and CD
        systems."""
        if self._up is None:
            return np.zeros(0)
        return self.fe.expand(np.asarray(u, dtype=float))[self._rows, :3] @ self._up

    def dof_label(self, dof: int) -> str:
        """``"G1001:T3"``: the grid and component of a free DOF."""
        return self._labels[int(dof)]

    def mesh_shapes(self, Phi):
        """The columns of ``Phi`` on the deck's grids (:func:`torchrom.fe.shapes.mesh_shapes`)."""
        from ..fe.shapes import mesh_shapes

        return mesh_shapes(self.fe, Phi)

    def add_output_points(self, points) -> None:
        """Add output points (name -> (grid id, component 1..6)); InputError naming the point
        when the grid is not in the deck or the DOF is not independent (e.g. an SPC)."""
        for name, (gid, comp) in points.items():
            self._outputs[str(name)] = int(self.fe.dof_index(gid, comp,
                                                             f"--output {name}"))

    @property
    def metadata(self) -> dict:
        meta = super().metadata
        meta["source"] = str(getattr(self.fe, "source", ""))
        meta["units"] = dict(getattr(self.fe, "units", {}) or {})
        try:
            meta["wing_frame"] = self.fe.wing_frame().as_dict()
        except WingFrameError:
            pass
        return meta

    def _mass(self):
        return self.fe.mass_matrix()

    def _stiffness(self):
        return self.fe.stiffness_matrix()

    def _internal_force(self, u):
        return self.fe.internal_force(u)

    def _tangent_stiffness(self, u):
        return self.fe.tangent_stiffness(u)

    def _material_tangent(self, u):
        return self.fe.material_tangent(u)

    def _static_solve(self, load, u0):
        rigid = self.rigid_shapes()
        if rigid.shape[1]:
            # a free structure: the load balanced by the rigid-body inertia loads (INREL)
            from ..fe.solvers import inertia_relief_static

            res = inertia_relief_static(self.fe, load, rigid, u0=u0, tol=self.static_tol,
                                        max_cuts=12)
        else:
            # modified Newton where a tangent is dear (co-rotational elements); full Newton on
            # a small-rotation model, whose dual modes (the paper's Goland ROM) stay those of
            # full Newton to rounding (1e-13): its damping decomposition amplifies a 1e-8 change of
            # the static solutions to 1e-4 in D2, D3
            if getattr(self.fe, "rotations", "small") == "large":
                sol = self._modified_newton(load, u0)
                if sol is not None:
                    return sol
                res = None  # modified Newton from the guess failed
            else:  # the continuation guess u0 gets one full-load Newton
                res = None if u0 is None else self.fe.static_solve(
                    load, u0=u0, tol=self.static_tol, max_cuts=0)
            if res is None or not res.converged:
                # the load stepped from u = 0 (static_solve cuts steps around its start, and a
                # failed guess is no solution at any load: as inertia_relief_static does)
                res = self.fe.static_solve(load, tol=self.static_tol, max_cuts=12)
        if not res.converged:
            raise ConvergenceError(f"{self.name}: static solve did not converge "
                                   f"({getattr(res, 'message', '')})")
        return StaticSolution(res.u, True, int(res.iterations), float(res.load_factor))

    def _modified_newton(self, load, u0) -> StaticSolution | None:
        """f(u) = load by modified Newton (:func:`torchrom.fe.solvers.modified_newton`) with
        the last converged solve's tangent factorisation (none yet: the linear stiffness's),
        to ‖f(u) − load‖ ≤ ``static_tol`` ‖load‖ or the work criterion of the full Newton
        (:data:`~torchrom.fe.solvers.WORK_TOL`); None when it does not converge within
        :attr:`MODIFIED_NEWTON_ITERATIONS` residuals and :attr:`MODIFIED_NEWTON_TANGENTS`
        factorisations (the FE's full Newton with load steps then solves).

        Why: the dual-mode loads and the validation's load levels are solved in sequence,
        each from the last solution, so the last tangent is often a close one; on a
        co-rotational model a tangent and its factorisation cost ten residuals (Pazy, 16,764
        DOFs: 1.5 s + 0.2 s against 0.17 s of CPU), where full Newton spent most of its
        time. Where the last tangent is not close enough (the start is far from equilibrium:
        the callers scale the last solution to the new load, whose in-plane part is quadratic
        in it), modified Newton takes the step back and refactorises; wherever the residual is
        above the load's norm it refactorises before the step (full Newton far from
        equilibrium, :data:`~torchrom.fe.solvers.NEWTON_ABOVE`: on the TACS wingbox's 100
        dual-mode solves 287 tangents instead of 1,084).
        """
        from ..fe.solvers import NEWTON_ABOVE, WORK_TOL, factor_symmetric, modified_newton

        if self._linear_factor is None:
            self._linear_factor = factor_symmetric(self.fe.stiffness_matrix())
        start = np.zeros(self.n_dof) if u0 is None else u0
        factor = self._linear_factor if u0 is None or self._factor is None else self._factor
        try:
            u, n_res, _, factor = modified_newton(
                self.fe, load, start, tol=self.static_tol, factor=factor,
                max_iter=self.MODIFIED_NEWTON_ITERATIONS,
                max_tangents=self.MODIFIED_NEWTON_TANGENTS, work_tol=WORK_TOL,
                factor_at_start=u0 is None, newton_above=NEWTON_ABOVE)
        except ConvergenceError:
            return None
        self._factor = factor
        return StaticSolution(u, True, int(n_res), 1.0)

    def projected_tangents(self, Phi: np.ndarray, Q: np.ndarray, material: bool = False):
        """Φᵀ K_T(Φq) Φ for each row q of Q (:meth:`FEBackend.projected_tangents`), the FE's
        tangents of all rows from :meth:`~torchrom.fe.model.FEModel.tangent_stiffnesses`
        (co-rotational elements: several states a pass); with ``material`` one state at a
        time, as the protocol's default."""
        tangents = getattr(self.fe, "tangent_stiffnesses", None)
        if material or tangents is None:
            return super().projected_tangents(Phi, Q, material)
        Q = np.atleast_2d(Q)
        t0 = time.perf_counter()
        KT = np.stack([project(K, Phi) for K in tangents(np.stack([Phi @ q for q in Q]))])
        self.counters.tangent_evaluations += len(Q)
        self.counters.add_time("tangent_stiffness", time.perf_counter() - t0)
        return KT, None

    def load_shapes(self) -> dict[str, np.ndarray]:
        """Uniform pressure (1 per unit area, pushing up) and the "step uniform" pressure (+1
        where the chord coordinate is below ``step_x``, −1 beyond) on the FE's default pressure
        skin."""
        if not len(self.fe.pressure_elements()):
            return {}
        frame = self.fe.wing_frame()
        x_mid = self.step_x - float(frame.origin @ frame.chord)  # from the frame's origin
        return {"uniform": self.fe.pressure_load(1.0),
                "step": self.fe.pressure_load(lambda s, c: np.where(c < x_mid, 1.0, -1.0),
                                              local=True)}

    def free_decay(self, u0, *, t_end, dt, gamma, record):
        """The FE's own nonlinear transient (Newmark + Newton, Kelvin–Voigt γ K_mat(u) u̇)."""
        res = self.fe.transient(t_end=t_end, dt=dt, u0=u0, gamma=gamma, record=list(record))
        return np.asarray(res.t), np.asarray(res.u)

    def rigid_shapes(self) -> np.ndarray:
        """(n_dof, r) M-orthonormal rigid-body shapes of the model (r = 0 when restrained;
        :func:`torchrom.fe.rigid.rigid_body_modes`, as the deck's flutter analysis uses)."""
        if self._rigid is None:
            from ..fe.rigid import rigid_body_modes

            m = self.fe.modes(1)
            self._rigid = (rigid_body_modes(self.fe, m)[0] if m.n_rigid
                           else np.zeros((self.n_dof, 0)))
        return self._rigid

    def modes(self, n: int):
        """The ``n`` lowest modes; a free structure's rigid-body modes first, at 0 Hz, as
        Nastran's SOL 145 keeps them (counted among the ``n``; ``n_rigid`` says how many)."""
        from ..fe.rigid import modal_basis_with_rigid

        m = self.fe.modes(n)
        f, shapes = modal_basis_with_rigid(self.fe, m, n, [])
        self.n_rigid = min(int(m.n_rigid), n)
        return np.asarray(f, float), np.asarray(shapes, float)
