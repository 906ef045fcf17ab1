"""Identification pipeline: FE backend -> basis -> stiffness -> damping -> :class:`NonlinearROM`.

``identify(fe, IdentifyOptions(...))`` runs every step non-intrusively through the FE-backend
protocol and returns the ROM with everything needed to judge it (basis, POD spectrum, symmetry
residuals, eigenvalues of the extended damping matrix, FE call counts and timings);
``build_rom(fe, n_linear=9, n_dual=12, damping="decomposition")`` returns just the ROM (DESIGN
"Python API"). The ROM carries outputs (rows Φ[dof, :] of the backend's output points, e.g.
"A_Tx", "A_Ty", "A_Tz"), mode kinds "linear"/"dual", provenance metadata and, where the backend
knows the deck's grids, the basis on them (:class:`~torchrom.rom.shapes.MeshShapes`).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from .._version import __version__
from ..checks import integer, real
from ..errors import InputError
from ..rom import NonlinearROM
from ..rom.points import DEFAULT_OUTPUT, largest_translation
from ..rom.points import METADATA_KEY as POINTS_KEY
from ..units import METADATA_KEY as UNITS_KEY
from ..units import recorded_units
from .backend import FEBackend
from .basis import PAPER_COMBINATIONS, Basis, DualModeOptions, dual_basis, linear_basis
from .condensation import ModalLoadLaw, identify_stiffness_about, identify_stiffness_condensed
from .damping import (
    DampingIdentification,
    DecompositionOptions,
    damping_from_material_tangents,
    optimum_decomposition,
)
from .stiffness import (
    StiffnessIdentification,
    identification_amplitudes,
    identify_stiffness_step,
    identify_stiffness_tangent,
)

DAMPING_METHODS = ("decomposition", "exact")


def _tangent(be, Phi, amps, opt, material, progress):
    stiff, plan, _, Kmat = identify_stiffness_tangent(
        be, Phi, amps, symmetric_pairs=opt.symmetric_pairs, material=material,
        progress=progress("tangents"))
    return stiff, plan, Kmat


def _step(be, Phi, amps, opt, material, progress):
    stiff, plan, _ = identify_stiffness_step(be, Phi, amps, progress=progress("forces"))
    return stiff, plan, None


def _condensed(be, Phi, amps, opt, material, progress):
    higher = None if opt.higher_amplitude is None else \
        amps * (opt.higher_amplitude / opt.resolved_amplitude)
    if opt.about is not None:
        return _condensed_about(be, Phi, amps, opt, higher, progress)
    stiff, data = identify_stiffness_condensed(be, Phi, amps, levels=opt.levels,
                                               higher=higher,
                                               n_nonlinear=opt.nonlinear_modes,
                                               progress=progress("static solves"),
                                               skeleton=be.skeleton,
                                               tangents=opt.condensation_fit != "forces")
    return stiff, data, None


def _condensed_about(be, Phi, amps, opt, higher, progress):
    """The condensation about the deformed state that ``opt.about`` holds: mode 1 loaded to
    the amplitude's linear deflection, each higher mode j to a_1 f_1/f_j (between the first
    mode's force, which barely moves a stiff mode, and its deflection, which twists it far
    beyond a flutter motion's), or to ``higher``."""
    K1 = Phi.T @ np.asarray(be.stiffness_matrix() @ Phi)
    f = np.sqrt(np.clip(np.diag(K1) / np.diag(Phi.T @ np.asarray(be.mass_matrix() @ Phi)),
                        0.0, None))
    a = amps[0] * f[0] / f if higher is None else np.array(higher, dtype=float)
    a[0] = amps[0]
    stiff, data = identify_stiffness_about(be, Phi, opt.about, a, levels=opt.levels,
                                           n_nonlinear=opt.nonlinear_modes,
                                           progress=progress("static solves"),
                                           skeleton=be.skeleton)
    return stiff, data, None


#: what the condensation fits its cubic terms to (:class:`IdentifyOptions`)
CONDENSATION_FITS = ("forces", "forces-and-tangents")

#: stiffness identification methods, each (backend, Φ, amplitudes, options, material,
#: progress-of-stage) -> (StiffnessIdentification, plan with ``points``, material tangents)
STIFFNESS = {"tangent": _tangent, "step": _step, "condensed": _condensed}
STIFFNESS_METHODS = tuple(STIFFNESS)
#: the identification amplitude of each method when none is given (fraction of the span): a
#: Taylor point for the tangent and STEP plans, the largest load level (the envelope) for the
#: condensation
DEFAULT_AMPLITUDE = {"tangent": 0.01, "step": 0.01, "condensed": 0.3}


@dataclass
class IdentifyOptions:
    """Options of :func:`identify`.

    n_linear, n_dual: basis size (DIGEST Sec. 6: 9 and 12 for Goland "9L12D");
    damping: "decomposition" (paper) or "exact" (material tangent; backend must provide it);
    stiffness: "tangent" (Eqs. 37–41), "step" (enforced displacements, forces only) or
    "condensed" (applied modal loads solved by the FE, :mod:`.condensation`; no dual modes);
    amplitude: identification amplitude, largest translation of each basis function as a
    fraction of the backend's reference length (span); for "condensed" that of the largest
    load level's linear response; None: :data:`DEFAULT_AMPLITUDE` of the method;
    levels: the condensation's load levels per direction (equal steps up to the amplitude);
    nonlinear_modes: the condensation loads only the first this many elastic modes (None: all);
    the ROM's nonlinear terms are theirs (the plan grows as its cube);
    higher_amplitude: the condensation loads the modes after the first to this linear
    deflection (fraction of the span) instead of the first mode's modal force (None);
    condensation_fit: "forces" (the condensed forces of the static solves) or
    "forces-and-tangents" (each solve's condensed tangent fitted with its force: exact where
    the condensed force is a cubic; on the Pazy wing no cubic fits the tangents of 20-30 %
    tip deflection, docs/guide/pazy-aoa.md);
    symmetric_pairs: impose ±(a_j e_j + a_l e_l) for Eq. 41 (cancels the quadratic term exactly);
    dual, decomposition: options of the dual modes and of the optimum decomposition;
    about: with "condensed", the ROM about the deformed state this modal load holds
    (:func:`.condensation.identify_stiffness_about`; default amplitude
    :data:`ABOUT_AMPLITUDE`), None about rest.
    """

    n_linear: int = 9
    n_dual: int = 12
    damping: str = "decomposition"
    stiffness: str = "tangent"
    amplitude: float | None = None
    levels: int = 3
    nonlinear_modes: int | None = None
    higher_amplitude: float | None = None
    condensation_fit: str = "forces"
    symmetric_pairs: bool = True
    dual: DualModeOptions = field(default_factory=DualModeOptions)
    decomposition: DecompositionOptions = field(default_factory=DecompositionOptions)
    about: ModalLoadLaw | None = None

    def validate(self) -> None:
        if self.damping not in DAMPING_METHODS:
            raise InputError(f"damping: expected one of {DAMPING_METHODS}, got {self.damping!r}")
        if self.stiffness not in STIFFNESS_METHODS:
            raise InputError(f"stiffness: expected one of {STIFFNESS_METHODS}, got "
                             f"{self.stiffness!r}")
        if self.n_linear < 1 or self.n_dual < 0:
            raise InputError(f"basis: need n_linear >= 1 and n_dual >= 0, got {self.n_linear}, "
                             f"{self.n_dual}")
        if self.damping == "exact" and self.stiffness != "tangent":
            raise InputError("damping 'exact' needs the tangent plan (stiffness 'tangent')")
        if self.stiffness == "condensed" and self.n_dual:
            raise InputError(f"stiffness 'condensed': the FE's own static solves relax the "
                             f"in-plane motion, so the ROM takes no dual modes; got n_dual = "
                             f"{self.n_dual}: use --dual 0")
        integer("levels", self.levels, minimum=1)
        if self.condensation_fit not in CONDENSATION_FITS:
            raise InputError(f"condensation_fit (--condensation-fit): expected one of "
                             f"{', '.join(CONDENSATION_FITS)}, got {self.condensation_fit!r}")
        if self.nonlinear_modes is not None:
            if self.stiffness != "condensed":
                raise InputError(f"nonlinear_modes (--nonlinear-modes) is an option of stiffness "
                                 f"'condensed', not of {self.stiffness!r}")
            k = integer("nonlinear_modes (--nonlinear-modes)", self.nonlinear_modes, minimum=1)
            if k > self.n_linear:
                raise InputError(f"nonlinear_modes (--nonlinear-modes): expected a whole number "
                                 f"from 1 to the {self.n_linear} linear modes, got {k!r}")
        if self.higher_amplitude is not None:
            if self.stiffness != "condensed":
                raise InputError(f"higher_amplitude (--higher-amplitude) is an option of "
                                 f"stiffness 'condensed', not of {self.stiffness!r}")
            high = real("higher_amplitude (--higher-amplitude)", self.higher_amplitude,
                        positive=True)
            if high > MAX_AMPLITUDE:
                raise InputError(f"higher_amplitude (--higher-amplitude): expected a fraction "
                                 f"of the span in (0, {MAX_AMPLITUDE:g}], got {high:g}")
        if self.about is not None and self.stiffness != "condensed":
            raise InputError(f"about (--about-aero): the ROM about a deformed state is a "
                             f"condensation; use --stiffness condensed, not {self.stiffness!r}")
        if self.about is not None and self.condensation_fit != "forces":
            raise InputError("about (--about-aero): the ROM about a state is always fitted "
                             "to the solves' forces and exact tangents (a potential); "
                             "--condensation-fit forces-and-tangents is for the ROM about rest")
        amp = real("amplitude", self.resolved_amplitude, positive=True)
        if amp > MAX_AMPLITUDE:
            raise InputError(f"amplitude: expected a fraction of the span in (0, "
                             f"{MAX_AMPLITUDE:g}] (the paper identifies at 0.01), got {amp:g}")


    @property
    def resolved_amplitude(self) -> float:
        """``amplitude``, or the method's default when it is None."""
        if self.amplitude is not None:
            return self.amplitude
        return ABOUT_AMPLITUDE if self.about is not None else \
            DEFAULT_AMPLITUDE.get(self.stiffness, 0.01)


#: the default amplitude of the condensation about a deformed state (fraction of the span):
#: the first mode's linear deflection about it. Its terms are the potential's Taylor terms
#: there (:mod:`.potential_fit`), so small loads determine them best; 1.5 % covers a flutter
#: motion's few mm, within which the quartic potential fits the skinned Pazy wing's solves
#: at 5° to 0.7 % (at 0.5 %: 0.02 %)
ABOUT_AMPLITUDE = 0.015

#: largest identification amplitude, a fraction of the span: a basis function displaced by more
#: than half the span is far beyond the cubic ROM's range (and any wing's)
MAX_AMPLITUDE = 0.5


@dataclass
class IdentificationResult:
    """The identified ROM and everything needed to judge it."""

    rom: NonlinearROM
    basis: Basis
    stiffness: StiffnessIdentification
    damping: DampingIdentification
    counters: dict
    timings: dict
    # raw data of the plan (for file exchange and the report)
    plan_points: np.ndarray | None = None

    def summary(self) -> dict:
        """A flat, JSON-ready summary (the ``--json`` record of ``torchrom identify``)."""
        d = self.damping.report
        out = {
            "n_linear": self.basis.kinds.count("linear"),
            "n_dual": self.basis.kinds.count("dual"),
            "stiffness_method": self.stiffness.method,
            "damping_method": self.damping.method,
            "fe_static_solves": self.counters["static_solves"],
            "fe_newton_iterations": self.counters["newton_iterations"],
            "fe_tangent_evaluations": self.counters["tangent_evaluations"],
            "fe_material_tangent_evaluations": self.counters["material_tangent_evaluations"],
            "fe_force_evaluations": self.counters["force_evaluations"],
        }
        out.update({f"time_{k}_s": v for k, v in self.timings.items()})
        out.update({f"residual_{k}": v for k, v in self.stiffness.residuals.items()})
        if self.damping.method == "decomposition":
            for key in ("symmetric_split", "after_subsets", "after_whole", "final"):
                out[f"damping_min_eig_scaled_{key}"] = d[key]["min_eigenvalue_scaled"]
                out[f"damping_min_eig_{key}"] = d[key]["min_eigenvalue"]
            out["damping_enforcement"] = d["enforcement"]["method"]
            out["damping_decomposition_reproduction_error_K2"] = d[
                "decomposition_reproduction_error_K2"]
            out["damping_decomposition_reproduction_error_K3"] = d[
                "decomposition_reproduction_error_K3"]
            out["damping_reproduction_error_K2"] = d["reproduction_error_K2"]
            out["damping_reproduction_error_K3"] = d["reproduction_error_K3"]
        else:
            out["damping_min_eig_scaled_final"] = d["min_eigenvalue_scaled"]
            out["damping_min_eig_final"] = d["min_eigenvalue"]
        out["frequencies_hz"] = [float(f) for f in self.basis.frequencies_hz
                                 if np.isfinite(f)]
        out["pod_spectrum_head"] = [float(v) for v in self.basis.pod_values[:self.basis.n]]
        return out


def as_backend(fe) -> FEBackend:
    """The FE-backend of an object: a backend itself, or a built-in ``torchrom.fe`` model."""
    if isinstance(fe, FEBackend):
        return fe
    from .fe_backend import BuiltinFEBackend

    if BuiltinFEBackend.accepts(fe):
        return BuiltinFEBackend(fe)
    raise InputError(f"identify: cannot use a {type(fe).__name__} as an FE model; pass a "
                     "torchrom.fe model or a torchrom.identify.FEBackend (e.g. CallableBackend)")


#: the FE element sets whose stiffness is geometrically nonlinear (Green strain, or
#: co-rotational); CBAR/CBEAM (``bars``) only with large rotations, and CELAS, CBUSH, GENEL and
#: solids never (:meth:`torchrom.fe.model.FEModel.linear_elements`)
NONLINEAR_ELEMENT_SETS = ("rods", "quads", "trias", "shears")


def check_nonlinear_elements(backend, n_dual: int) -> None:
    """Before the dual-mode FE solves: dual modes need a nonlinear static response, which an
    FE model of linear elements only (a stick model of CBARs) cannot give — its responses
    differ from the linear modes' by rounding (5e-15 measured), and dual modes made of that
    ended in a Cholesky LinAlgError (issue 34). Backends without a torchrom FE mesh are left
    to the snapshots' own check (:func:`~torchrom.identify.basis.dual_modes_from_responses`)."""
    fe = getattr(backend, "fe", None)
    mesh = getattr(fe, "mesh", None)
    sets = NONLINEAR_ELEMENT_SETS + (("bars",) if getattr(fe, "rotations", "") == "large" else ())
    if mesh is None or sum(len(getattr(mesh, k)) for k in sets):
        return
    raise InputError(f"{backend.name}: n_dual = {n_dual} (--dual): every element of the model "
                     f"is linear (CELAS/CBUSH/solid elements, or CBAR/CBEAM with small "
                     f"rotations): its "
                     f"static responses have nothing outside the linear modes, so no dual mode "
                     f"can be made; use --dual 0")


def identify(fe, options: IdentifyOptions | None = None,
             progress: Callable[[str, int, int], None] | None = None) -> IdentificationResult:
    """Identify the nonlinear ROM of an FE model non-intrusively (DIGEST Secs. 4–6).

    ``progress(stage, done, total)`` is called as the FE work advances (stages "dual modes",
    "tangents", "forces").
    """
    opt = options or IdentifyOptions()
    return identify_each_damping(fe, opt, (opt.damping,), progress)[opt.damping]


def identify_each_damping(fe, options: IdentifyOptions, methods, progress=None
                          ) -> dict[str, IdentificationResult]:
    """The ROM of each damping method in ``methods`` ("decomposition", "exact") from one FE
    identification: the basis and the stiffness are computed once (with the material tangents
    when "exact" is among them) and are, bit for bit, what :func:`identify` with each method
    alone computes — the damping is identified after the stiffness from its results only
    (Eqs. 42–44 or the material tangents). ``progress``: as :func:`identify`'s."""
    methods = tuple(dict.fromkeys(methods))
    for method in methods:  # each as identify would check it
        replace(options, damping=method).validate()
    opt = options
    be = as_backend(fe)
    exact = "exact" in methods
    if exact and not be.has_material_tangent:
        raise InputError(f"{be.name}: damping 'exact' needs the FE material tangent, which this "
                         "backend does not provide; use damping 'decomposition'")

    def stage(name):
        return None if progress is None else (lambda d, t: progress(name, d, t))

    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    n_dof = getattr(be, "n_dof", None)
    if n_dof is not None and opt.n_linear + opt.n_dual > n_dof:
        raise InputError(f"basis: {opt.n_linear} linear + {opt.n_dual} dual modes asked for "
                         f"(--linear, --dual), but the model has {n_dof} DOFs; a basis holds "
                         f"at most that many independent vectors: ask for at most {n_dof} in "
                         f"all (e.g. --linear {min(opt.n_linear, n_dof)} --dual "
                         f"{n_dof - min(opt.n_linear, n_dof)})")
    basis = linear_basis(be, opt.n_linear)
    timings["linear_modes"] = time.perf_counter() - t0
    if opt.n_dual > 0:
        check_nonlinear_elements(be, opt.n_dual)
        t1 = time.perf_counter()
        dual_opt = opt.dual
        if dual_opt.combinations == PAPER_COMBINATIONS and opt.n_linear < 5:
            # the paper's combinations need modes 1..5: keep those within the basis
            dual_opt = replace(dual_opt, combinations=tuple(
                c for c in PAPER_COMBINATIONS if max(c) <= opt.n_linear))
            opt = replace(opt, dual=dual_opt)
        basis = dual_basis(be, basis, opt.n_dual, dual_opt, progress=stage("dual modes"))
        timings["dual_modes"] = time.perf_counter() - t1
    # a free structure's rigid-body modes (the first basis.n_rigid columns) take no part in the
    # nonlinear fit: their K1 row is zero and they enter no K2/K3/D term (see _embed_rigid)
    r = basis.n_rigid
    if r and opt.stiffness == "condensed":
        raise InputError(f"{be.name}: stiffness 'condensed' solves the structure under applied "
                         f"loads, but it is free ({r} rigid-body modes); restrain it (SPC) or "
                         "use --stiffness tangent with dual modes")
    Phi = basis.Phi[:, r:]
    amps = identification_amplitudes(Phi, opt.resolved_amplitude, be.reference_length,
                                     be.translational_dofs)
    t1 = time.perf_counter()
    stiff, plan, Kmat = STIFFNESS[opt.stiffness](be, Phi, amps, opt, exact, stage)
    timings["stiffness"] = time.perf_counter() - t1
    out = {}
    for method in methods:
        t1 = time.perf_counter()
        if method == "exact":
            damp = damping_from_material_tangents(plan, Kmat)
        else:
            damp = optimum_decomposition(stiff.K1, stiff.K2, stiff.K3, opt.decomposition)
        times = {**timings, "damping": time.perf_counter() - t1}
        times["total"] = sum(times.values())
        # the amplitudes the plan used (the condensation's differ from ``amps`` past mode 1)
        st, dm, a = stiff, damp, stiff.amplitudes
        if r:
            st, dm = _embed_rigid(stiff, r), _embed_rigid(damp, r)
            a = np.concatenate([np.zeros(r), stiff.amplitudes])
        mopt = replace(opt, damping=method)
        rom = assemble_rom(be, basis, st, dm, mopt, a, times)
        out[method] = IdentificationResult(rom, basis, st, dm, be.counters.as_dict(), times,
                                           plan.points)
    return out


def _embed_rigid(ident, r: int):
    """The identification (stiffness or damping tensors) on the elastic coordinates, extended by
    ``r`` leading rigid-body coordinates with zero entries in every term.

    A rigid translation strains nothing; a rigid rotation θ of a total-Lagrangian model strains
    at second order (Green strain ½ θ² of the rotated fibres), which a finite rotation's exact
    kinematics would cancel but a rigid-body *mode* (the linearised rotation u = θ × x, the
    Nastran SOL 145 mode) does not: fitted, those terms would be an artificial stiffening of
    the aircraft's pitch with its amplitude (tests/test_identify_free_free.py measures them).
    The ROM keeps the rigid-body coordinates linear (zero stiffness and damping) and the
    nonlinear terms in the elastic coordinates, as a mean-axes formulation does."""
    def pad(a):
        a = np.asarray(a)
        return np.pad(a, [(r, 0)] * a.ndim) if a.ndim else a

    names = ("K1", "K2", "K3") if hasattr(ident, "K1") else ("D1", "D2", "D3")
    return replace(ident, **{k: pad(getattr(ident, k)) for k in names if getattr(ident, k)
                             is not None})


def assemble_rom(be: FEBackend, basis: Basis, stiff: StiffnessIdentification,
                 damp: DampingIdentification, opt: IdentifyOptions, amplitudes: np.ndarray,
                 timings: dict | None = None) -> NonlinearROM:
    """The :class:`NonlinearROM` from identified parts (also used by the Nastran exchange)."""
    Phi = basis.Phi
    M = Phi.T @ np.asarray(be.mass_matrix() @ Phi)
    dofs = dict(be.outputs)
    # a deck without named points still gets one output: where the first elastic mode moves
    # most (a free structure's rigid-body modes come first in the basis and move everything)
    dofs.setdefault(DEFAULT_OUTPUT, largest_translation(Phi, be.translational_dofs,
                                                        mode=basis.n_rigid))
    outputs = {name: Phi[dof, :] for name, dof in dofs.items()}
    points = {name: be.dof_label(dof) for name, dof in dofs.items()
              if be.dof_label(dof) is not None}
    metadata = {
        "torchrom_version": __version__,
        "source": be.metadata,
        "basis": {"kinds": basis.kinds, "n_linear": basis.kinds.count("linear"),
                  "n_rigid": basis.n_rigid,
                  "n_dual": basis.kinds.count("dual"),
                  "dual_combinations": [list(c) for c in opt.dual.combinations],
                  "dual_amplitudes": opt.dual.n_amplitudes,
                  "dual_tip_range": list(opt.dual.tip_range),
                  "dual_amplitude_control": opt.dual.amplitude_control,
                  "dual_pod_norm": opt.dual.pod_norm,
                  "dual_fe_solves": sum(r.get("solves", 0) for r in basis.snapshots),
                  "dual_snapshots_ok": sum(r.get("status") == "ok" for r in basis.snapshots),
                  "dual_snapshots_failed": sum(r.get("status") == "failed"
                                               for r in basis.snapshots),
                  "pod_spectrum": basis.pod_values[: basis.n + 5].tolist()},
        "identification": {"stiffness_method": stiff.method,
                           "amplitude": opt.resolved_amplitude,
                           "modal_amplitudes": np.asarray(amplitudes).tolist(),
                           "symmetric_pairs": opt.symmetric_pairs,
                           **({"condensation_fit": opt.condensation_fit}
                              if stiff.method == "condensed" else {}),
                           **stiff.plan_info,
                           "residuals": stiff.residuals},
        "damping": {"method": damp.method, "report": _jsonable(damp.report)},
        "linear_frequencies_hz": [float(f) for f in basis.frequencies_hz if np.isfinite(f)],
        "fe_counters": be.counters.as_dict(),
        "timings_s": dict(timings or {}),
        POINTS_KEY: points,
    }
    system = recorded_units(be.metadata)
    if system is not None:  # the FE model's, which the ROM's tensors are in
        metadata[UNITS_KEY] = system.name
    return NonlinearROM(M, stiff.K1, stiff.K2, stiff.K3, damp.D1, damp.D2, damp.D3,
                        mode_kinds=basis.kinds, frequencies_hz=basis.frequencies_hz,
                        outputs=outputs, metadata=metadata, symmetrize=True,
                        shapes=be.mesh_shapes(Phi), reference=stiff.reference)


def build_rom(fe, n_linear: int = 9, n_dual: int = 12, damping: str = "decomposition",
              **options) -> NonlinearROM:
    """The identified :class:`NonlinearROM` of an FE model (DESIGN "Python API").

    Extra keyword arguments are :class:`IdentifyOptions` fields (stiffness, amplitude, dual, ...).
    """
    opt = IdentifyOptions(n_linear=n_linear, n_dual=n_dual, damping=damping, **options)
    return identify(fe, opt).rom


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    if hasattr(obj, "__dataclass_fields__"):
        return _jsonable(asdict(obj))
    return obj
