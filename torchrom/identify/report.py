"""Validation report of an identified ROM: Markdown + PNG figures (paper Figs. 3–8, free decay).

``write_report(result, backend, directory)`` runs :mod:`.validate` (static responses at point A
under the uniform and step-uniform pressures, a free decay with Kelvin–Voigt damping, the
comparison of the ``decomposition`` and ``exact`` damping) and writes ``report.md`` with the
figures beside it; it returns the numbers as a flat dict for ``--json``. Figures are drawn by
matplotlib (Agg backend); every file is written atomically.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import torch

from ..io import atomic_path, write_text_atomic
from ..rom import NonlinearROM
from . import validate as v
from .damping import damping_from_material_tangents, optimum_decomposition


def _savefig(fig, path: Path) -> None:
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=110, bbox_inches="tight")


def _units(backend) -> tuple[str, str]:
    """(length, pressure) unit labels of the FE model (its ``units``, e.g. ft and lbf/ft²);
    "FE length" / "FE force/length²" when the deck does not say."""
    units = dict(getattr(getattr(backend, "fe", None), "units", {}) or {})
    length = units.get("length")
    force = units.get("force")
    pressure = f"{force}/{length}²" if force and length else "FE force/length²"
    return (length or "FE length units"), pressure


def _static_figure(curves: dict, path: Path, units: tuple[str, str]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted(next(iter(curves.values())).fe, reverse=True)  # A_Tz, A_Ty, A_Tx
    fig, axes = plt.subplots(len(curves), len(names), figsize=(4 * len(names) + 1,
                                                                3.4 * len(curves)), squeeze=False)
    for row, (shape, c) in enumerate(curves.items()):
        for col, k in enumerate(names):
            ax = axes[row, col]
            ax.plot(c.levels, c.fe[k], "ko-", ms=4, label="FE (Newton)")
            ax.plot(c.levels, c.rom[k], "r^--", ms=4, label="ROM (Newton)")
            if shape == "mode1_inertia":  # the level multiplies M φ₁ (a stick model)
                ax.set_xlabel("load level (× M φ₁, the first elastic mode's inertia load)")
                ax.set_title(f"mode-1 inertia load: {k}")
            else:
                ax.set_xlabel(f"pressure ({units[1]})")
                ax.set_title(f"{shape} pressure: {k}")
            ax.set_ylabel(f"{k} ({units[0]})")
            ax.grid(alpha=0.3)
        axes[row, 0].legend()
    fig.tight_layout()
    _savefig(fig, path)
    plt.close(fig)


def _decay_figure(dec: v.FreeDecay, path: Path, length: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 3.6))
    ax.plot(dec.t, dec.fe, "k-", lw=1.2, label="FE transient")
    ax.plot(dec.t, dec.rom, "r--", lw=1.0, label="ROM")
    ax.set_xlabel("t (s)")
    ax.set_ylabel(f"{dec.output} ({length})")
    ax.set_title(f"free decay, Kelvin–Voigt γ = {dec.gamma:g} s")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    _savefig(fig, path)
    plt.close(fig)


def _power_figure(t, Pa, Pb, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(10, 3.4))
    ax.plot(t, Pb, "k-", label="exact (material tangent)")
    ax.plot(t, Pa, "r--", label="decomposition")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("q̇ᵀ D_T(q) q̇ at γ = 1")
    ax.set_title("dissipated power along the ROM free decay")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    _savefig(fig, path)
    plt.close(fig)


def _other_damping(result, backend):
    """The damping by the method not used for the ROM (None if it cannot be computed); a free
    structure's on its elastic coordinates, embedded as the ROM's (:func:`.build._embed_rigid`)."""
    from .build import _embed_rigid

    st = result.stiffness
    r = int(getattr(result.basis, "n_rigid", 0))
    elastic = slice(r, None)
    if result.damping.method == "exact":
        other = optimum_decomposition(st.K1[elastic, elastic], st.K2[elastic, elastic, elastic],
                                      st.K3[elastic, elastic, elastic, elastic])
        return _embed_rigid(other, r) if r else other
    if not backend.has_material_tangent:
        return None
    from .stiffness import TangentPlan

    plan = TangentPlan(st.amplitudes)
    _, Km = backend.projected_tangents(result.basis.Phi[:, elastic], plan.points, material=True)
    other = damping_from_material_tangents(plan, Km)
    return _embed_rigid(other, r) if r else other


#: tip-deflection bands (% of span) of the static error tables, besides the whole curve
BANDS_PCT = (10.0, 15.0, 20.0)


def write_report(result, backend, directory, *, gamma: float = 1e-3, cycles: int = 10,
                 dynamic: bool = True, max_tip_fraction: float = 0.25,
                 decay_tip_fraction: float = 0.15) -> dict:
    """Validate ``result`` (an :class:`~.build.IdentificationResult`) against ``backend`` and
    write ``directory/report.md`` + figures. Returns the measured numbers (flat dict). Outputs,
    load shapes and a free structure's inertia relief: :mod:`.validate`.

    Static curves go up to ``max_tip_fraction`` of the span; the free decay starts from the
    static deflection with a tip at ``decay_tip_fraction`` of the span (Goland: 10 % = 2 ft)."""
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    rom, Phi = result.rom, result.basis.Phi
    # a free structure (rigid-body modes first in the basis) is validated under inertia relief
    r = int(getattr(result.basis, "n_rigid", 0))
    outputs = v.validation_outputs(backend, Phi, r)
    shapes = v.load_shapes(backend, Phi, r)
    numbers: dict = {}
    t0 = time.perf_counter()
    curves = {}
    for shape, load in shapes.items():
        c = v.static_validation(backend, rom, Phi, shape, load,
                                max_tip_fraction=max_tip_fraction, outputs=outputs, n_rigid=r)
        curves[shape] = c
        for k, e in c.errors.items():
            numbers[f"static_{shape}_{k}_max_rel_error"] = e
        for band in BANDS_PCT:
            for k, e in c.error_table(max_tip_pct=band).items():
                numbers[f"static_{shape}_{k}_max_rel_error_tip_le_{band:g}pct"] = e
        numbers[f"static_{shape}_max_tip_pct_span"] = float(c.tip_pct_span.max())
    step_x = getattr(backend, "step_x", None)
    if step_x is not None:
        numbers["static_step_midline_x"] = float(step_x)
    if curves:
        _static_figure(curves, directory / "static.png", _units(backend))
    numbers["time_static_validation_s"] = time.perf_counter() - t0
    dec = None
    if dynamic:
        t1 = time.perf_counter()
        # released from the uniform pressure's deflection (a stick model: the mode-1 load's)
        release = shapes.get("uniform", next(iter(shapes.values())))
        decay_output = next(k for k in outputs if k.endswith("Tz") or k.startswith("max"))
        dec = v.free_decay_validation(backend, rom, Phi, release, gamma=gamma, cycles=cycles,
                                      tip_fraction=decay_tip_fraction,
                                      dof=outputs[decay_output], n_rigid=r)
        dec.output = decay_output
        _decay_figure(dec, directory / "free_decay.png", _units(backend)[0])
        numbers.update({f"decay_{k}": val for k, val in dec.metrics.items()})
        numbers["time_free_decay_s"] = time.perf_counter() - t1
    other = _other_damping(result, backend)
    if other is not None:
        rom_other = NonlinearROM(rom.M, rom.K1, rom.K2, rom.K3, other.D1, other.D2, other.D3,
                                 symmetrize=True)
        dec_rom, exact_rom = ((rom_other, rom) if result.damping.method == "exact"
                              else (rom, rom_other))
        # a sampled motion: the ROM free decay (or random states if no decay was run)
        if dec is not None:
            # from the decay's own start (the nonlinear static deflection): a linear shape
            # scaled to that amplitude is far from the dual modes' equilibrium
            t, Q, V = v.rom_free_decay(rom, dec.q0, t_end=dec.t[-1], dt=dec.t[1] - dec.t[0],
                                       gamma=gamma)
        else:
            g = torch.Generator().manual_seed(0)
            Q = 0.1 * torch.randn(200, rom.n, generator=g, dtype=torch.float64).numpy()
            V = torch.randn(200, rom.n, generator=g, dtype=torch.float64).numpy()
            t = np.arange(len(Q))
        cmp = v.compare_damping(dec_rom, exact_rom, Q, V)
        numbers.update({f"damping_{k}": val for k, val in cmp.items()})
        Pa = dec_rom.dissipated_power(torch.as_tensor(Q), torch.as_tensor(V)).numpy()
        Pb = exact_rom.dissipated_power(torch.as_tensor(Q), torch.as_tensor(V)).numpy()
        _power_figure(t, Pa, Pb, directory / "dissipation.png")
    write_text_atomic(directory / "report.md",
                      _markdown(result, curves, dec, numbers, decay_tip_fraction))
    return numbers


def _fmt(x) -> str:
    if isinstance(x, float):
        return f"{x:.3e}" if (x != 0 and (abs(x) < 1e-2 or abs(x) >= 1e4)) else f"{x:.4g}"
    return str(x)


def _err(x) -> str:
    """A relative error, or – where none is defined (NaN: the FE value is ~0)."""
    return "–" if isinstance(x, float) and x != x else _fmt(x)


def _markdown(result, curves, dec, numbers, decay_tip_fraction) -> str:
    s = result.summary()
    rom = result.rom
    lines = [f"# ROM identification report: {rom.metadata['source'].get('name', '')}", "",
             f"Basis: {s['n_linear']} linear + {s['n_dual']} dual modes; stiffness by the "
             f"{s['stiffness_method']} method; damping by `{s['damping_method']}`.", "",
             "## FE work and time", "",
             "| quantity | value |", "|---|---|"]
    for k in ("fe_static_solves", "fe_newton_iterations", "fe_tangent_evaluations",
              "fe_material_tangent_evaluations", "fe_force_evaluations"):
        lines.append(f"| {k} | {s[k]} |")
    for k, val in result.timings.items():
        lines.append(f"| time {k} (s) | {val:.2f} |")
    lines += ["", "## Linear frequencies (Hz)", "",
              ", ".join(f"{f:.3f}" for f in s["frequencies_hz"]), "",
              "## POD spectrum of the dual-mode residuals (normalised, leading values)", "",
              ", ".join(f"{x:.2e}" for x in s["pod_spectrum_head"][: s["n_dual"] + 3]), ""]
    failed = [r for r in result.basis.snapshots if r.get("status") != "ok"]
    if failed:
        lines += [f"{len(failed)} of {len(result.basis.snapshots)} dual-mode loads were not "
                  "carried by the FE (no converged static solution) or skipped after one; the "
                  "POD used the rest.", ""]
    from .stiffness import residual_wording

    largest = max(result.stiffness.residuals.values(), default=float("nan"))
    lines += ["## Identification residuals (relative)", "",
              f"Largest {largest:.1e}: {residual_wording(largest)}.", "",
              "| residual | value |", "|---|---|"]
    lines += [f"| {k} | {_fmt(val)} |" for k, val in result.stiffness.residuals.items()]
    lines += ["", "## Damping", "", "| quantity | value |", "|---|---|"]
    lines += [f"| {k} | {_fmt(val)} |" for k, val in s.items() if k.startswith("damping_")]
    if curves:
        where = ("point A" if "A_Tz" in next(iter(curves.values())).fe
                 else ", ".join(next(iter(curves.values())).fe))
        lines += ["", f"## Static validation at {where} (Figs. 3–8)", "",
                  "![static](static.png)", ""]
        if "mode1_inertia" in curves:
            lines += ["No pressure skin (a beam stick model): the load is the inertia load "
                      "M φ₁ of the first elastic mode.", ""]
        if getattr(result.basis, "n_rigid", 0):
            lines += [f"A free structure ({result.basis.n_rigid} rigid-body modes): the FE and "
                      "the ROM under inertia relief (the load balanced by the rigid-body "
                      "inertia loads, no rigid-body displacement in the M-weighted mean).", ""]
        lines += ["Largest |ROM − FE| / |FE| over the load levels with a tip deflection of "
                  "at least 1 % of the span and at most the band's:", "",
                  "| load | output | " + " | ".join(f"≤ {b:g} %" for b in BANDS_PCT)
                  + " | whole curve | max tip % span |", "|---|---|" + "---|" * (len(BANDS_PCT)
                                                                                + 2)]
        for shape, c in curves.items():
            bands = [c.error_table(max_tip_pct=b) for b in BANDS_PCT]
            for k, e in c.errors.items():
                lines.append(f"| {shape} | {k} | " + " | ".join(_err(t[k]) for t in bands)
                             + f" | {_err(e)} | {c.tip_pct_span.max():.1f} |")
        lines += ["", "–: the FE response of that output stays below 1e-6 of the largest "
                  "output over the band (e.g. A_Tx of a symmetric load), so no relative error "
                  "is defined."]
        if numbers.get("static_step_midline_x") is not None:
            lines += ["", "Step pressure: +1 where the position along the wing's chord axis is "
                      f"below {numbers['static_step_midline_x']:g}, −1 beyond."]
    if dec is not None:
        m = dec.metrics
        lines += ["", f"## Free decay (γ = {dec.gamma:g} s, {dec.cycles} cycles, initial tip "
                  f"{100 * decay_tip_fraction:g} % of span)", "",
                  "![free decay](free_decay.png)", "",
                  f"Envelope error {_fmt(m.get('envelope_error'))}, frequency error "
                  f"{_fmt(m.get('frequency_error'))} (FE {_fmt(m.get('frequency_fe_hz'))} Hz, "
                  f"ROM {_fmt(m.get('frequency_rom_hz'))} Hz)."]
    dam = {k: val for k, val in numbers.items() if k.startswith("damping_")}
    if dam:
        lines += ["", "## `decomposition` vs `exact` damping", "",
                  "![dissipation](dissipation.png)", "", "| quantity | value |", "|---|---|"]
        lines += [f"| {k[8:]} | {_fmt(val)} |" for k, val in dam.items()]
    return "\n".join(lines) + "\n"
