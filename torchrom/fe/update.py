"""FE model updating: fit declared deck parameters to target natural frequencies.

The deck's cards (properties' NSM or dimensions, material densities, CONM2 masses, offsets and
inertias; :data:`~torchrom.fe.update_config.FIELDS`) are changed on the model's pyNastran deck,
so the updated deck is written with the same cards (``write_bdf``) and read back by any
Nastran reader.

Method (hand-written; the optimiser and the assignment are SciPy's):

- residuals r_i = w_i (f_i − f*_i) / f*_i of the paired modes (plus √ρ (x − x₀) when a
  regularization ρ is asked for), x the parameters scaled to [0, 1] by their bounds;
- eigenvalue sensitivities (Fox & Kapoor 1968), for mass-normalised φ_i:
  dλ_i/dp = φ_iᵀ (dK/dp − λ_i dM/dp) φ_i,  df_i/dp = (dλ_i/dp) / (8 π² f_i);
  the matrix derivatives dK/dp, dM/dp by central differences of the assembled matrices, exact
  for the mass fields (M is affine in an NSM, a density or a CONM2 mass, quadratic in a CONM2
  offset) and O(h²) for the dimensions (plate bending ∝ t³); repeated eigenvalues are not
  treated specially;
- ``scipy.optimize.least_squares`` (trust-region reflective, bounded; it evaluates the Jacobian
  only at accepted iterates, which are the iterations of the history);
- pairing: with a reference deck, each target is paired at every evaluation with the mode of
  largest MAC against its reference mode (one-to-one, Hungarian); otherwise the initial model's
  modes are paired by ``mode`` or ``kind`` (:func:`~torchrom.fe.mac.pair_by_kind`) and then
  tracked by MAC against the shapes of the best point so far, so that a target follows its
  shape when two modes swap order; or (``pairing = "kind"``) re-paired by kind and frequency
  order at every evaluation, so that the targets keep their order (a published table whose
  mode shapes are unknown).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from .assembly import project
from .mac import kind_matches, mac_matrix, pair_by_kind, pair_by_mac
from .model import assemble_mass
from .update_config import FIELDS, UpdateOptions, UpdateParameter, UpdateSpec, check_parameter


def _cards(bdf, p: UpdateParameter, where: str):
    table = {"MAT1": bdf.materials, "CONM2": bdf.masses}.get(p.card, bdf.properties)
    cards = []
    for i in p.ids:
        card = table.get(i)
        if card is None or card.type != p.card:
            found = "not found" if card is None else f"is a {card.type}"
            raise InputError(f"{where}: {p.card} {i} {found} in the deck")
        cards.append(card)
    return cards


def get_value(bdf, p: UpdateParameter, where: str = "update") -> float:
    """The deck's value of ``p`` (equal on all its cards, else an error)."""
    attr, idx, _ = FIELDS[p.card][p.field]
    vals = []
    for card in _cards(bdf, p, where):
        v = getattr(card, attr)
        v = v[idx] if idx is not None else v
        vals.append(float(v or 0.0))
    if max(vals) - min(vals) > 1e-12 * max(abs(v) for v in vals):
        raise InputError(f"{where}: parameter {p.name}: the {p.card} cards {list(p.ids)} have "
                         f"different {p.field} values {vals}; give 'initial' or one id each")
    return vals[0]


def set_value(bdf, p: UpdateParameter, value: float, where: str = "update") -> None:
    attr, idx, _ = FIELDS[p.card][p.field]
    for card in _cards(bdf, p, where):
        if idx is None:
            setattr(card, attr, float(value))
        else:
            arr = np.array(getattr(card, attr), dtype=float)
            arr[idx] = float(value)
            setattr(card, attr, arr if not isinstance(getattr(card, attr), list)
                    else arr.tolist())


def total_mass(fe, mesh=None) -> float:
    """Rigid-body mass along basic x, all grids (constrained ones included)."""
    mesh = mesh if mesh is not None else fe.mesh
    u = np.zeros(6 * mesh.n_grid)
    u[0::6] = 1.0
    return float(u @ (assemble_mass(mesh) @ u))


@dataclass
class UpdateResult:
    """Outcome of :func:`update_model`: ``parameters`` (name → initial, final, bounds,
    at_bound), ``targets`` (per target: frequencies initial/final, residual %, paired mode,
    kind, MAC of the final mode against the initially paired or reference shape), ``history``
    (per iteration: cost, rms and max |%| residual, parameter values), ``mac`` (targets ×
    computed modes at the end, against the initially paired or reference shapes), mass totals
    (model units) and the optimiser's status."""

    parameters: dict[str, dict]
    targets: list[dict]
    history: list[dict]
    mac: list[list[float]]
    total_mass_initial: float
    total_mass_final: float
    converged: bool
    message: str
    n_evaluations: int
    n_iterations: int
    final_modes: list[dict] = field(default_factory=list)
    notes: list[str] = field(default_factory=list)

    def summary(self) -> dict:
        res = np.array([t["final_diff_pct"] for t in self.targets])
        return {"rms_diff_pct": float(np.sqrt(np.mean(res**2))),
                "max_abs_diff_pct": float(np.max(np.abs(res)))}

    def as_dict(self) -> dict:
        return {"parameters": self.parameters, "targets": self.targets,
                "history": self.history, "mac": self.mac,
                "total_mass_initial": self.total_mass_initial,
                "total_mass_final": self.total_mass_final, "converged": self.converged,
                "message": self.message, "n_evaluations": self.n_evaluations,
                "n_iterations": self.n_iterations, "final_modes": self.final_modes,
                "notes": self.notes, **self.summary()}


class ModelUpdater:
    """Evaluates modes, pairing and sensitivities of ``fe`` (a model with a pyNastran deck) as
    functions of the parameters; :meth:`run` optimises. The deck ``fe.bdf`` is modified in
    place (it holds the current parameter values)."""

    def __init__(self, fe, spec: UpdateSpec, *, reference=None, drilling: float = 1e-4):
        if getattr(fe, "bdf", None) is None:
            raise InputError(f"update: model {fe.name!r} has no Nastran deck")
        self.fe = fe
        self.bdf = fe.bdf
        self.spec = spec
        self.drilling = drilling
        self.params = spec.parameters
        for p in self.params:
            check_parameter(p, f"update: parameter {p.name}")
        self.targets = spec.targets
        self.options: UpdateOptions = spec.options
        nt = len(self.targets)
        self.n_modes = self.options.n_modes or min(2 * nt + 2, fe.n_dof - 1)
        if self.n_modes < nt:
            raise InputError(f"update: {nt} targets but only {self.n_modes} modes computed")
        self.stiffness = any(p.stiffness for p in self.params)
        self.K0 = fe.stiffness_matrix()
        self.M_deck = fe.mass_matrix()  # the deck as read, before any parameter is set
        self.lower = np.array([p.lower for p in self.params])
        self.upper = np.array([p.upper for p in self.params])
        self.p0 = np.array([p.initial if p.initial is not None else get_value(self.bdf, p)
                            for p in self.params])
        for p, v in zip(self.params, self.p0):
            if not p.lower <= v <= p.upper:
                raise InputError(f"update: parameter {p.name}: the deck's value {v} is outside "
                                 f"[{p.lower}, {p.upper}]; give 'initial'")
        self.f_target = np.array([t.frequency_hz for t in self.targets])
        self.weights = np.array([t.weight for t in self.targets])
        self._cache: dict[bytes, dict] = {}
        self.history: list[dict] = []
        self.n_eval = 0
        self.reference = reference
        ev0 = self.evaluate(self.p0, pair=False)
        self.ref_shapes = self._initial_pairing(ev0)
        self.initial_shapes = self.ref_shapes
        self.best = (np.inf, self.ref_shapes)

    # -- matrices --------------------------------------------------------------------------------
    def _model_at(self, values):
        for p, v in zip(self.params, values):
            set_value(self.bdf, p, v, f"update: parameter {p.name}")
        if self.stiffness:
            from .bdf_read import from_pynastran

            fe = from_pynastran(self.bdf, source=self.fe.source, name=self.fe.name,
                                units=self.fe.units, drilling=self.drilling)
            if fe.free_dofs() != self.fe.free_dofs():
                raise InputError("update: the free DOFs changed with the parameters (a dimension "
                                 "reached zero?); tighten the bounds")
            return fe.stiffness_matrix(), fe.mass_matrix()
        return self.K0, project(assemble_mass(self._mesh()), self.fe.T)

    def _mesh(self):
        """The mesh of the deck's current values (cards re-read; grids unchanged)."""
        from .bdf_read import _Reader

        return _Reader(self.bdf, self.fe.source or self.fe.name).mesh(None)

    def matrices(self, values):
        """(K, M) on the free DOFs at parameter ``values`` (the deck keeps them)."""
        return self._model_at(np.asarray(values, dtype=float))

    def _step(self, j: int, value: float) -> float:
        p = self.params[j]
        return self.options.fd_step * max(abs(value), abs(p.upper - p.lower))

    def matrix_derivatives(self, values, j: int):
        """(dK/dp_j, dM/dp_j) by central differences (module docstring)."""
        values = np.asarray(values, dtype=float)
        h = self._step(j, values[j])
        vp, vm = values.copy(), values.copy()
        vp[j] += h
        vm[j] -= h
        Kp, Mp = self._model_at(vp)
        Km, Mm = self._model_at(vm)
        self._model_at(values)
        return (Kp - Km) / (2 * h), (Mp - Mm) / (2 * h)

    # -- modes and pairing -----------------------------------------------------------------------
    def evaluate(self, values, pair: bool = True) -> dict:
        """Modes at ``values`` and (``pair``) the paired modes of the targets."""
        values = np.asarray(values, dtype=float)
        key = values.tobytes()
        ev = self._cache.get(key)
        if ev is None:
            ev = self._modes(*self._model_at(values), values)
            self.n_eval += 1
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = ev
        return self._paired(ev) if pair else ev

    def _modes(self, K, M, values) -> dict:
        from .kinds import classify
        from .solvers import eigenpairs

        lam, phi = eigenpairs(K, M, self.n_modes)
        kinds, _ = classify(self.fe, phi)
        return {"values": values, "K": K, "M": M, "lam": lam, "phi": phi, "kinds": kinds,
                "freq": np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)}

    def deck_modes(self) -> dict:
        """The modes of the deck as read (its own parameter values, whatever 'initial' values
        the targets file starts the update from), paired with the targets."""
        return self._paired(self._modes(self.K0, self.M_deck, None))

    def _paired(self, ev) -> dict:
        """``ev`` with the targets' paired modes (by MAC against the reference shapes, or by
        kind)."""
        if ev.get("paired_with") is not self.ref_shapes:
            mac = mac_matrix(self.ref_shapes, ev["phi"], ev["M"])
            ev["mac"] = mac
            ev["pairs"] = (self._pair_by_kind(ev) if self.options.pairing == "kind"
                           else pair_by_mac(mac))
            ev["paired_with"] = self.ref_shapes
        return ev

    def _pair_by_kind(self, ev, strict: bool = False) -> np.ndarray:
        # not strict during the iterations: a trial point without a mode of a wanted kind (say
        # the in-plane mode pushed above the computed ones) gets a poor pairing, hence a large
        # residual, and the step is rejected; the final pairing is reported with kind_ok
        fixed = [None if t.mode is None else t.mode - 1 for t in self.targets]
        return pair_by_kind(ev["kinds"], [t.kind for t in self.targets], fixed, strict)

    def _initial_pairing(self, ev) -> np.ndarray:
        if self.reference is not None:
            ref = self.reference.modes(max(t.mode or 0 for t in self.targets) or self.n_modes)
            if self.reference.free_dofs() != self.fe.free_dofs():
                raise InputError("update: [reference] deck: its free DOFs differ from the "
                                 "model's (same grids and constraints expected)")
            idx = []
            for i, t in enumerate(self.targets):
                if t.mode is None:
                    raise InputError(f"update: target {i + 1} ({t.name}): with a reference "
                                     "deck every target needs 'mode' (its reference mode)")
                idx.append(t.mode - 1)
            return ref.shapes[:, idx]
        for i, t in enumerate(self.targets):
            if t.mode is not None and t.mode > self.n_modes:
                raise InputError(f"update: target {i + 1} ({t.name}): mode {t.mode} but only "
                                 f"{self.n_modes} modes are computed")
        return ev["phi"][:, self._pair_by_kind(ev, strict=True)]

    # -- residuals and Jacobian ------------------------------------------------------------------
    def _scale(self, x):
        return self.lower + np.asarray(x) * (self.upper - self.lower)

    def _x(self, values):
        return (np.asarray(values) - self.lower) / (self.upper - self.lower)

    def _regularization(self) -> float:
        return float(np.sqrt(self.options.regularization))

    def residuals(self, x) -> np.ndarray:
        ev = self.evaluate(self._scale(x))
        f = ev["freq"][ev["pairs"]]
        r = self.weights * (f - self.f_target) / self.f_target
        if self.options.regularization:
            r = np.concatenate((r, self._regularization() * (np.asarray(x) - self.x0)))
        cost = 0.5 * float(r @ r)
        if cost < self.best[0] and self.reference is None:
            # track shapes from the best point so far (a rejected trial step is not followed)
            self.best = (cost, ev["phi"][:, ev["pairs"]])
        return r

    def frequency_sensitivities(self, values) -> np.ndarray:
        """df_i/dp_j (Hz per parameter unit) of the paired modes (targets × parameters)."""
        ev = self.evaluate(values)
        phi = ev["phi"][:, ev["pairs"]]
        lam = ev["lam"][ev["pairs"]]
        f = ev["freq"][ev["pairs"]]
        S = np.zeros((len(self.targets), len(self.params)))
        for j in range(len(self.params)):
            dK, dM = self.matrix_derivatives(values, j)
            dlam = np.einsum("ik,ik->k", phi, dK @ phi) - lam * np.einsum("ik,ik->k", phi,
                                                                          dM @ phi)
            S[:, j] = dlam / (8 * np.pi**2 * np.maximum(f, 1e-300))
        return S

    def jacobian(self, x) -> np.ndarray:
        values = self._scale(x)
        S = self.frequency_sensitivities(values) * (self.upper - self.lower)[None, :]
        J = (self.weights / self.f_target)[:, None] * S
        ev = self.evaluate(values)
        self._record(ev, x)
        if self.reference is None:
            self.ref_shapes = self.best[1]
        if self.options.regularization:
            J = np.vstack((J, self._regularization() * np.eye(len(self.params))))
        return J

    def _record(self, ev, x) -> None:
        f = ev["freq"][ev["pairs"]]
        d = 100 * (f - self.f_target) / self.f_target
        r = self.residuals(x)
        self.history.append({
            "iteration": len(self.history), "evaluations": self.n_eval,
            "cost": 0.5 * float(r @ r), "rms_diff_pct": float(np.sqrt(np.mean(d**2))),
            "max_abs_diff_pct": float(np.max(np.abs(d))),
            "frequencies_hz": [float(v) for v in f],
            "parameters": {p.name: float(v) for p, v in zip(self.params, ev["values"])},
        })

    # -- driver ----------------------------------------------------------------------------------
    def run(self) -> UpdateResult:
        from scipy.optimize import least_squares

        deck = self.deck_modes()
        f0 = deck["freq"][deck["pairs"]]  # the "initial" column: the deck's own frequencies
        ev0 = self.evaluate(self.p0)  # where the fit starts (the re-pairing note's "start")
        check_plausible_targets(self.targets, ev0["freq"][ev0["pairs"]])
        self._model_at(self.p0)
        mass0 = total_mass(self.fe, self._mesh())
        self.x0 = self._x(self.p0)
        tol = self.options.tolerance
        sol = least_squares(self.residuals, self.x0, jac=self.jacobian, bounds=(0.0, 1.0),
                            method="trf", x_scale=1.0, ftol=tol, xtol=tol, gtol=tol,
                            max_nfev=self.options.max_evaluations)
        values = self._scale(np.clip(sol.x, 0.0, 1.0))
        ev = self.evaluate(values)
        self._record(ev, sol.x)
        mesh = self._mesh()
        pairs = ev["pairs"]
        f = ev["freq"][pairs]
        # MAC of the final modes against the initially paired (or reference) shapes: how far
        # each target's shape moved
        mac = mac_matrix(self.initial_shapes, ev["phi"], ev["M"])
        targets = []
        for i, t in enumerate(self.targets):
            k = int(pairs[i])
            targets.append({
                "name": t.name, "target_hz": t.frequency_hz, "kind_wanted": t.kind,
                "weight": t.weight, "initial_hz": float(f0[i]),
                "initial_diff_pct": float(100 * (f0[i] - t.frequency_hz) / t.frequency_hz),
                "final_hz": float(f[i]),
                "final_diff_pct": float(100 * (f[i] - t.frequency_hz) / t.frequency_hz),
                "mode": k + 1, "kind": ev["kinds"][k],
                "kind_ok": kind_matches(ev["kinds"][k], t.kind),
                "mac": float(mac[i, k]),
            })
        params = {}
        for p, a, b in zip(self.params, self.p0, values):
            params[p.name] = {"card": p.card, "ids": list(p.ids), "field": p.field,
                              "initial": float(a), "final": float(b), "lower": p.lower,
                              "upper": p.upper,
                              "at_bound": bool(np.isclose(b, p.lower, rtol=0, atol=1e-9 *
                                                          (p.upper - p.lower))
                                               or np.isclose(b, p.upper, rtol=0, atol=1e-9 *
                                                             (p.upper - p.lower)))}
        modes = [{"mode": k + 1, "frequency_hz": float(ev["freq"][k]), "kind": ev["kinds"][k]}
                 for k in range(len(ev["freq"]))]
        # a target whose paired mode changed during the fit (shapes tracked by MAC, or modes
        # swapping order) is said so, never re-paired silently
        notes = [f"target {t.name}: paired with mode {int(a) + 1} at the start, mode "
                 f"{int(b) + 1} at the end (MAC {float(mac[i, int(b)]):.3f})"
                 for i, (t, a, b) in enumerate(zip(self.targets, ev0["pairs"], pairs))
                 if int(a) != int(b)]
        return UpdateResult(
            parameters=params, targets=targets, history=self.history,
            mac=[[float(v) for v in row] for row in mac],
            total_mass_initial=mass0, total_mass_final=total_mass(self.fe, mesh),
            converged=bool(sol.success), message=str(sol.message), n_evaluations=self.n_eval,
            n_iterations=len(self.history) - 1, final_modes=modes, notes=notes)


#: a target more than this factor from its paired mode's initial frequency is no update (the
#: declared cards move frequencies by tens of percent; a factor 10 is a unit slip, e.g. kHz)
MAX_TARGET_RATIO = 10.0
#: the updated deck is not written when a target is still this far off (%) after the fit
MAX_FINAL_MISFIT_PCT = 50.0


def check_plausible_targets(targets, initial_hz) -> None:
    """InputError when a target frequency is more than :data:`MAX_TARGET_RATIO` from the
    initial frequency of the mode paired with it."""
    for i, (t, f) in enumerate(zip(targets, initial_hz)):
        ratio = max(t.frequency_hz / f, f / t.frequency_hz) if f > 0 else math.inf
        if ratio > MAX_TARGET_RATIO:
            raise InputError(f"update: target {i + 1} ({t.name}): {t.frequency_hz:g} Hz is "
                             f"{ratio:.3g} times the {f:.6g} Hz of its paired mode; expected "
                             f"within a factor {MAX_TARGET_RATIO:g} (a unit slip? an update "
                             f"moves frequencies by tens of percent)")


def check_final_misfit(result) -> None:
    """InputError (the deck is then not written) when a target is still more than
    :data:`MAX_FINAL_MISFIT_PCT` off after the fit."""
    worst = max(result.targets, key=lambda t: abs(t["final_diff_pct"]))
    if not abs(worst["final_diff_pct"]) <= MAX_FINAL_MISFIT_PCT:
        raise InputError(f"update: target {worst['name']} is still {worst['final_diff_pct']:+.3g}"
                         f" % off after the fit (more than {MAX_FINAL_MISFIT_PCT:g} %); the "
                         f"updated deck is not written: widen the parameters' bounds or check "
                         f"the target")


def update_model(fe, spec: UpdateSpec, *, reference=None, drilling: float = 1e-4):
    """Update ``fe``'s deck parameters to the targets of ``spec``; returns (the updated
    :class:`~torchrom.fe.model.FEModel`, :class:`UpdateResult`). ``fe.bdf`` is modified in
    place (it holds the final values). ``reference``: a model whose modes are the reference
    shapes (targets' ``mode``)."""
    from .bdf_read import from_pynastran

    updater = ModelUpdater(fe, spec, reference=reference, drilling=drilling)
    result = updater.run()
    new = from_pynastran(fe.bdf, source=fe.source, name=fe.name, units=fe.units,
                         drilling=drilling, output_points=fe.output_points or None)
    new.wing_chord = fe.wing_chord
    _keep_wing_axes(fe, new)
    return new, result


def _keep_wing_axes(old, new) -> None:
    """The updated model keeps the original's wing axes: a section stiffened past its other
    plane (the beams' weakest bending direction flips) is the same wing, and its modes keep
    their kinds."""
    from .wing_frame import WingFrameError

    try:
        frame = old.wing_frame()
    except WingFrameError:
        return
    new.set_wing_axes(up=frame.up, span=frame.span)
