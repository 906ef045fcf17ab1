"""``torchrom paper``: the whole heavy Goland study of paper Sec. IV from nothing but the package.

Steps (each result a file in the output folder; model files and sweep tables are cached by the
hash of their inputs and the package version, :mod:`.cache`):

1. the Goland pipeline (:mod:`.pipeline`): FE model, 9L12D ROM, aerodynamics, flutter — with
   the exact-damping ROM of step 5 from the same FE identification;
2. Fig. 9: α(γ) at the flutter altitude (the γ grid of ``paper_fig09.toml``);
3. the simulator's linear checks and Table 3 (:mod:`.linear`);
4. the LCO sweep of ``paper_lco.toml`` (Figs. 10–13, Fig. 11 from its histories);
5. the damping cause check (the Fig. 10 cases with the exact Kelvin–Voigt tensors) and the band
   over admissible damping decompositions between them and the optimum decomposition
   (:mod:`.band`);
6. the other wing variant beside the study's (:mod:`.variants`: pipeline, LCO sweep, findings);
7. the figures (:mod:`torchrom.study.figures`), the findings (:mod:`.findings`), ``report.md``
   and ``paper.json``.

``quick`` loads the configurations' ``[variants.quick]`` (coarser grids, shorter runs) and uses
:data:`QUICK_PIPELINE`. The configurations ship in ``torchrom/data`` (the same files as
``configs/paper_*.toml``).
"""

from __future__ import annotations

import dataclasses
import json
import time
from collections.abc import Callable
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import torch

from .._version import __version__
from ..errors import InputError
from ..identify.damping_family import (
    SDP_EPS,
    SDP_ITERATIONS,
    DampingMember,
    damping_family,
    sdp_member,
)
from ..io import atomic_path, check_folder, write_figure, write_json_atomic, write_text_atomic
from ..progress import Progress, StageCounter
from ..reference import paper_reference
from ..study import figures
from ..study.cases import orbits_of
from ..study.config import load_sweep_config, with_method
from ..study.grid import config_hash
from ..study.models import alpha_gamma_table
from ..study.plots import branch_diagram
from ..study.sweep import run_sweep, sweep_chunk_size
from ..study.table import write_histories
from . import findings as fnd
from .band import BAND_THETAS, decomposition_band, member_sweep
from .beside import Beside, study_processes
from .cache import MANIFEST, FileCache
from .dissipation import dissipation_ratio, lco_cycle, scaled_min_eigenvalue
from .hb import branch_summary, goland_branches, newmark_confirmation
from .linear import linear_checks
from .modes import kind_label, paper_mode_map
from .pipeline import GolandPipeline, goland_pipelines
from .report import render
from .stiffness_cause import CAUSE_ALTITUDE_FT, CAUSE_GAMMA, SWITCHES, stiffness_cause
from .variants import COMPARISON_VARIANTS, variant_study

#: the full pipeline is the paper's (9L12D, 8 x 20 boxes); --quick keeps the basis and uses
#: half as many dual-mode loads per combination and a coarser DLM mesh
QUICK_PIPELINE = GolandPipeline(dual_amplitudes=10, boxes=(4, 10))
FULL_PIPELINE = GolandPipeline()
#: altitudes of the damping cause check (the Fig. 10 cases again, with the exact Kelvin–Voigt
#: tensors of the FE material in place of the optimum decomposition)
DAMPING_CHECK_ALTITUDES = (4000.0, 7000.0, 10000.0)
#: cases per batch of the study's time-marching sweeps: above the Newmark integrator's
#: throughput knee on the study's ROM and settings (benchmarks/bench_batch_knee.py, CPU time:
#: B = 192 within 1.25x of the cheapest, 41 us per case-step at B = 384; B = 24-32 costs
#: 73-82 us, B = 8 145 us), so every sweep of the study (19-59 cases) is one batch — the
#: runner's default splits 59 cases into two chunks of ~30 for two workers
SWEEP_BATCH = 256
#: the linear checks: run length (s) and the window (fraction of it) for Table 3
LINEAR_T_END = {"full": 20.0, "quick": 12.0}
LINEAR_WINDOW = 0.3
FIGURE_FILES = {"table2": "table2_frequencies.png", "fig9": "fig09_alpha_gamma.png",
                "fig10": "fig10_lco_amplitude.png", "fig11": "fig11_time_histories.png",
                "fig12": "fig12_lco_frequency.png", "fig13": "fig13_amplitude_ratios.png",
                "branches": "lco_branches.png"}


#: the study's stages and their wall-clock seconds in a reference run from nothing (bench_paper
#: on a quiet 2-core machine: harmonic balance, two processes, so the stages computed beside
#: the others cost only their wait): only the ETA of the stage lines reads them
#: (:class:`torchrom.progress.StageCounter` scales them by how the finished stages compared)
CONFIRMATION_STAGE = "Newmark confirmation (Fig. 11)"
STAGE_SECONDS = {
    "quick": {"model (FE, ROM, aero, flutter)": 12.7, "Fig. 9: alpha(gamma)": 0.1,
              "linear checks, Table 3": 0.8, "LCO sweep (Figs. 10-13)": 16.5,
              CONFIRMATION_STAGE: 5.8, "damping check (exact Kelvin-Voigt)": 10.3,
              "damping decomposition band": 22.7,
              "LCO branches in altitude (continuation)": 0.1,
              "stiffness nonlinearity at gamma = 1e-3 (cause)": 0.1,
              "other wing variant (pipeline, LCO sweep)": 0.1, "figures": 2.1},
    "full": {"model (FE, ROM, aero, flutter)": 15.3, "Fig. 9: alpha(gamma)": 0.1,
             "linear checks, Table 3": 1.3, "LCO sweep (Figs. 10-13)": 25.9,
             CONFIRMATION_STAGE: 5.6, "damping check (exact Kelvin-Voigt)": 7.9,
             "damping decomposition band": 29.2,
             "LCO branches in altitude (continuation)": 0.1,
             "stiffness nonlinearity at gamma = 1e-3 (cause)": 0.1,
             "other wing variant (pipeline, LCO sweep)": 0.1, "figures": 1.7},
}
#: the stages the second process computes (:mod:`.beside`) cost their whole time when the study
#: runs in one process (``TORCHROM_PAPER_PROCESSES=1``): their seconds in a reference run so
#: (bench_paper's one-process peer for the quick study; a full run the same day)
ONE_PROCESS_SECONDS = {
    "quick": {"damping decomposition band": 49.3,
              "LCO branches in altitude (continuation)": 23.4,
              "stiffness nonlinearity at gamma = 1e-3 (cause)": 1.1,
              "other wing variant (pipeline, LCO sweep)": 27.1},
    "full": {"damping decomposition band": 56.8,
             "LCO branches in altitude (continuation)": 14.6,
             "stiffness nonlinearity at gamma = 1e-3 (cause)": 4.3,
             "other wing variant (pipeline, LCO sweep)": 35.9},
}
#: the study's LCO solver unless ``method`` names another (``torchrom paper --method``):
#: harmonic balance, each orbit certified as one of the continuous-time equations (issue 36);
#: "newmark" is the paper's own time marching
PAPER_METHOD = "hb"


def study_stages(kind: str, marches_time: bool, processes: int = 2
                 ) -> list[tuple[str, float]]:
    """(stage, reference seconds) of the ``kind`` ("quick" or "full") study, in order; the
    Newmark confirmation only when the LCOs come from periodic orbits (not
    ``marches_time``); with one process, the second process's stages at their whole time
    (:data:`ONE_PROCESS_SECONDS`)."""
    one = ONE_PROCESS_SECONDS[kind] if processes == 1 else {}
    return [(k, one.get(k, v)) for k, v in STAGE_SECONDS[kind].items()
            if not (marches_time and k == CONFIRMATION_STAGE)]


def config_path(name: str) -> Path:
    """A configuration shipped with the package (``torchrom/data/<name>``)."""
    path = Path(str(resources.files("torchrom").joinpath("data", name)))
    if not path.is_file():
        raise InputError(f"torchrom paper: packaged configuration {name} not found at {path}")
    return path


def _check_folder(out: Path, force: bool) -> None:
    """Refuse a non-empty folder that this command did not write (unless ``force``)."""
    from ..locks import LOCK_NAME

    check_folder(out, "--out")  # a file, or a folder that cannot be written
    if (out.is_dir() and any(p.name != LOCK_NAME for p in out.iterdir())
            and not (out / MANIFEST).is_file() and not force):
        raise InputError(f"--out {out}: the folder holds files that torchrom paper did not "
                         f"write; choose another folder or pass --force")


def run_paper(out, *, quick: bool = False, force: bool = False, device: str = "cpu",
              dtype: torch.dtype = torch.float64, log: Callable[[str], None] = print,
              method: str = PAPER_METHOD) -> dict[str, Any]:
    """Run the study into ``out`` and return the summary written to ``paper.json``.

    ``method``: a sweep solver (:mod:`torchrom.study.solvers`): "hb" (the default,
    :data:`PAPER_METHOD`: the LCOs of Figs. 10, 12, 13 by harmonic balance, each certified,
    with a Newmark confirmation of a subset started on the HB orbits, which also gives
    Fig. 11; :mod:`.hb`) or "newmark" (the paper's time marching); the LCO branches in
    altitude from the flutter point either way. The stages that need only the model run in a
    second process where there is a second core (:mod:`.beside`). The folder is locked for
    the run (:mod:`torchrom.locks`: a second study into it refuses, naming this one's PID)."""
    from ..locks import folder_lock

    out = Path(out)
    processes = study_processes()  # the environment checked before anything is written
    _check_folder(out, force)
    with folder_lock(out, "torchrom paper", log=log):
        _check_folder(out, force)  # as it is now that no other run can write into it
        with Beside(out, force, processes) as beside:
            return _study(out, quick, force, device, dtype, log, method, beside)


def _study(out: Path, quick: bool, force: bool, device: str, dtype: torch.dtype,
           log: Callable[[str], None], method: str, beside: Beside) -> dict[str, Any]:
    cache = FileCache(out, force=force)
    variant = "quick" if quick else None
    kind = "quick" if quick else "full"
    t_all, c_all = time.perf_counter(), time.process_time()
    cfg = with_method(load_sweep_config(config_path("paper_lco.toml"), variant), method)
    watch = StageCounter(study_stages(kind, cfg.solver.marches_time, beside.processes),
                         log=log)
    base = QUICK_PIPELINE if quick else FULL_PIPELINE
    cfg9 = load_sweep_config(config_path("paper_fig09.toml"), variant)
    cfg_v = (cfg if cfg.solver.marches_time
             else dataclasses.replace(_secondary(cfg), history=None))
    # the other wing variant builds its own model: to the second process (.beside) before the
    # study's model stage, which it runs beside; collected at its own stage below
    jobs = {"variants": beside.submit(_variant_studies, base, out,
                                      [c.get("gamma", 0.0) for c in cfg9.cases], cfg_v, device,
                                      dtype, force, cfg.solver.marches_time)}
    watch.start("model (FE, ROM, aero, flutter)")
    # the study's ROM and the exact-damping check's from one FE identification (same basis and
    # stiffness; the aerodynamics computed once)
    both = goland_pipelines(base, {base.damping: out / "model", "exact": out / "model_exact"},
                            force=force, log=log)
    res = both[base.damping]
    model = res.model
    fl = res.flutter
    log(f"flutter (state space): {fl['state_space']['altitude']:,.0f} ft, "
        f"{fl['state_space']['frequency_hz']:.3f} Hz (paper {fl['paper']['altitude']:,.0f} ft, "
        f"{fl['paper']['frequency_hz']:.3f} Hz)")
    model_hash = model.content_hash()
    check_cfg = dataclasses.replace(_secondary(cfg), cases=damping_check_cases(cfg),
                                    history=None)
    # the stages that need only the model, to the second process (.beside) after the variant,
    # collected at their own stage below: the SDP optimum first (the band waits for it; its
    # member's sweep runs here, at the band: the second process, with the other wing and the
    # SDP, was the longer one), the branches last (collected after the band)
    jobs["sdp"] = beside.submit(_sdp_member, model)
    jobs["branches"] = beside.submit(_branches, cfg, model, model_hash, device)
    jobs["cause"] = beside.submit(_stiffness_cause, cfg, model, quick)

    # -- Fig. 9 -----------------------------------------------------------------------------------
    watch.start("Fig. 9: alpha(gamma)")
    alpha_gamma = alpha_gamma_table(model, [c.get("gamma", 0.0) for c in cfg9.cases])
    _write_table(cache, "tables/alpha_gamma.csv", alpha_gamma, model_hash)

    # -- linear checks and Table 3 --------------------------------------------------------------
    watch.start("linear checks, Table 3")
    lin_key = FileCache.key({"model": model_hash, "t_end": LINEAR_T_END[kind],
                             "window": LINEAR_WINDOW})
    lin = cache.get_json("tables/linear_check.json", lin_key)
    if lin is None:
        log(f"linear checks: growth rate around the flutter altitude and Table 3 "
            f"({LINEAR_T_END[kind]:g} s runs, both nonlinearities off)")
        lin = linear_checks(model, t_end=LINEAR_T_END[kind], window=LINEAR_WINDOW).as_dict()
        cache.put("tables/linear_check.json", lin_key, lambda p: write_json_atomic(p, lin))
    _write_table(cache, "tables/table3.csv", pd.DataFrame(lin["table3"]), lin_key)
    log(f"  simulated flutter altitude {lin['flutter_altitude_sim_ft']:,.1f} ft vs eigenvalues "
        f"{lin['flutter_altitude_eig_ft']:,.1f} ft")

    # -- the LCO sweep ---------------------------------------------------------------------------
    watch.start("LCO sweep (Figs. 10-13)")
    hb_info: dict[str, Any] = {}
    if not cfg.solver.marches_time:  # periodic orbits: histories from a Newmark confirmation
        table, _, lco_info, orbits = _lco_sweep(cache, dataclasses.replace(cfg, history=None),
                                                model, model_hash, device, dtype, log,
                                                name=_sweep_name("lco", cfg))
        watch.start(CONFIRMATION_STAGE)
        confirm, histories = _confirmation(cache, cfg, model, model_hash, table, orbits, device,
                                           log)
        hb_info["confirmation"] = confirm.to_dict(orient="records")
    else:
        table, histories, lco_info, orbits = _lco_sweep(cache, cfg, model, model_hash, device,
                                                        dtype, log, name=_sweep_name("lco", cfg))
    # -- cause check: the Fig. 10 cases with the exact Kelvin-Voigt damping ------------------
    watch.start("damping check (exact Kelvin-Voigt)")
    check, exact, exact_table = _damping_check(cache, cfg, check_cfg, model,
                                               both["exact"].model, device, dtype, log,
                                               _cycle_orbit(table, orbits, model))

    # -- the band over admissible damping decompositions ---------------------------------------
    watch.start("damping decomposition band")
    keys = ["altitude_ft", "gamma", "stiffness_nl", "damping_nl"]
    main_cases = table.merge(exact_table[keys], on=keys)  # the check's cases of the main sweep
    log(f"damping decompositions: the Fig. 10 cases at θ = "
        f"{', '.join(f'{t:g}' for t in BAND_THETAS[kind])} between the optimum decomposition "
        "(0) and the exact tensors (1)")
    swept: dict[str, pd.DataFrame] = {}

    def sweep(m, name: str) -> pd.DataFrame:
        if name not in swept:
            swept[name] = _lco_sweep(cache, check_cfg, m, m.content_hash(), device, dtype, log,
                                     name=name)[0]
        return swept[name]

    # the members between the ends first, while the second process may still solve the SDP
    family = damping_family(model.rom, model.rom, exact.rom, BAND_THETAS[kind])
    for member in family:
        if 0.0 < member.theta < 1.0:
            sweep(*member_sweep(model, member))
    band = decomposition_band(model, exact, BAND_THETAS[kind], (main_cases, exact_table), sweep,
                              extra=(jobs["sdp"].result(cache, log),), family=family)
    for key, verdict in band["findings"].items():
        log(f"  {key}: {verdict}")

    watch.start("LCO branches in altitude (continuation)")
    branches = jobs["branches"].result(cache, log)
    hb_info["branches"] = branch_summary(branches)

    # -- why the stiffness nonlinearity matters at gamma = 1e-3 --------------------------------
    watch.start("stiffness nonlinearity at gamma = 1e-3 (cause)")
    cause = jobs["cause"].result(cache, log)

    # -- the other wing variant(s) -------------------------------------------------------------
    watch.start("other wing variant (pipeline, LCO sweep)")
    variants = jobs["variants"].result(cache, log)

    # -- figures ---------------------------------------------------------------------------------
    watch.start("figures")
    fig_dir = out / "figures"
    kinds = [r.get("kind") for r in fl["table2"]]
    q4 = paper_q4(fl["table2"])
    h_f = float(fl["state_space"]["altitude"])
    # a figure that fails is a warning (missing from "figures"): the tables and the report stay
    paths = {"table2": write_figure(figures.table2, pd.DataFrame(fl["table2"]),
                                    fig_dir / FIGURE_FILES["table2"], force=True),
             "fig9": write_figure(figures.fig9, alpha_gamma, fig_dir / FIGURE_FILES["fig9"],
                                  force=True),
             "fig10": write_figure(figures.fig10, table, fig_dir / FIGURE_FILES["fig10"],
                                   force=True, flutter_altitude_ft=h_f),
             "fig12": write_figure(
                 figures.fig12, table, fig_dir / FIGURE_FILES["fig12"], force=True,
                 flutter_altitude_ft=h_f,
                 flutter_frequency_hz=float(fl["state_space"]["frequency_hz"]),
                 table3={float(r["altitude_ft"]): float(r["frequency_eig_hz"])
                         for r in lin["table3"]}),
             "fig13": write_figure(figures.fig13, table, fig_dir / FIGURE_FILES["fig13"],
                                   force=True, q4_mode=q4["mode"], q4_note=q4["note"],
                                   flutter_altitude_ft=h_f)}
    if len(histories):
        paths["fig11"] = write_figure(figures.fig11, table, histories,
                                      fig_dir / FIGURE_FILES["fig11"], force=True)
    if len(branches):
        paths["branches"] = write_figure(
            branch_diagram, branches, fig_dir / FIGURE_FILES["branches"],
            parameter="altitude_ft", units="ft", y="amplitude_pct_span",
            y_label="LCO amplitude of point A (% of span)",
            title="LCO branches from the flutter point (harmonic balance, matched α)",
            label_of=lambda row: f"γ = {row['gamma']:g} s", force=True)
    failed = sorted(k for k, v in paths.items() if v is None)
    paths = {k: v for k, v in paths.items() if v is not None}

    # -- findings and report ---------------------------------------------------------------------
    table = table.copy()
    ratio4 = figures.ratio_column(table, q4["mode"])
    found = fnd.evaluate(table, histories, alpha_gamma, h_f, kinds, q4_column=ratio4,
                         q4_note=q4["note"], marches_time=cfg.solver.marches_time)
    watch.stop()
    watch.wall["total"] = time.perf_counter() - t_all
    watch.cpu["total"] = time.process_time() - c_all
    summary = {
        "version": __version__, "quick": quick, "out": str(out), "seconds": watch.wall,
        "cpu_seconds": watch.cpu, "model_seconds": res.seconds,
        "reused": res.reused + lco_info.pop("reused_files"),
        "pipeline": (QUICK_PIPELINE if quick else FULL_PIPELINE).as_dict(),
        "flutter": fl, "linear": lin, "linear_t_end": LINEAR_T_END[kind],
        "linear_window": LINEAR_WINDOW, "lco": lco_info,
        "alpha_gamma": alpha_gamma.to_dict(orient="records"),
        "findings": [f.as_dict() for f in found],
        "damping_check": check, "decomposition_band": band, "method": method, "hb": hb_info,
        "processes": beside.processes,
        "stiffness_cause": cause,
        "variant": (QUICK_PIPELINE if quick else FULL_PIPELINE).variant, "variants": variants,
        "figures": {k: str(v) for k, v in paths.items()},
        "paper_q4": {**q4, "column": ratio4},
        "figures_failed": failed,
        "identification": res.identification,
        "sweeps": _sweep_timings(cache),
    }
    write_text_atomic(out / "report.md", render(summary, found, table, alpha_gamma))
    write_json_atomic(out / "paper.json", summary)
    return summary


def _variant_studies(cache: FileCache, base: GolandPipeline, out: Path, gammas: list[float],
                     cfg_v, device, dtype, force: bool, marches_time: bool, *,
                     log: Callable[[str], None]) -> dict[str, dict[str, Any]]:
    """:func:`.variants.variant_study` of every wing variant but the study's, each swept with
    ``cfg_v`` (cached in ``cache`` like the study's sweeps)."""
    return {name: variant_study(
        name, base, out / f"model_{name}", gammas,
        lambda m, nm: _lco_sweep(cache, cfg_v, m, m.content_hash(), device, dtype, log,
                                 name=nm)[:3],
        paper_q4, force=force, log=log, marches_time=marches_time)
        for name in COMPARISON_VARIANTS if name != base.variant}


def _sweep_timings(cache: FileCache) -> dict[str, dict[str, Any]]:
    """Per sweep of this run (computed or reused from the cache), what its ``timing.json``
    records: cases, case-steps, the solver's seconds and, of them, the certificate's (absent
    for a sweep cached before they were counted apart)."""
    out = {}
    for name in sorted(set(cache.hits + cache.built)):
        parts = name.split("/")
        if len(parts) == 3 and parts[0] == "sweeps" and parts[2] == "timing.json":
            info = json.loads((cache.folder / name).read_text())
            out[parts[1]] = {k: info[k] for k in ("cases", "case_steps", "wall_time_s",
                                                  "certificate_s") if k in info}
    return out


def paper_q4(table2: list[dict[str, Any]]) -> dict[str, Any]:
    """Our mode compared with the paper's mode 4 (Fig. 13b), matched by kind
    (:func:`.modes.paper_mode_map`; our mode 4 when the kinds are unknown); ``table2``: the
    flutter summary's rows (``kind``, ``content``)."""
    ref = paper_reference()
    kinds = [r.get("kind") for r in table2]
    mapping = paper_mode_map(kinds, ref.table2_kinds) if any(kinds) else {}
    ours = mapping.get(4, 4)
    row = table2[ours - 1] if ours - 1 < len(table2) else {}
    kind = kind_label(row.get("kind"), row.get("content"))
    note = (f"our mode {ours}, {kind}, for the paper's mode 4 ({ref.table2_kinds[3]})"
            if ours != 4 or row.get("content") else None)
    return {"mode": ours, "kind": row.get("kind") or "unknown kind", "note": note}


def _secondary(cfg):
    """``cfg`` for the study's secondary harmonic-balance sweeps (the exact-damping check, the
    decomposition band, the other wing variant): time-integration seeds only for the cases
    harmonic balance does not converge (``seed = "unconverged"``), whatever the main sweep's
    setting — seeding every LCO not accepted in H ("unresolved", the paper configuration's,
    for the figures) made ``torchrom paper --method hb`` several times slower, most of it in
    these sweeps. Their LCOs are certified without ``dt_error`` (the comparisons they make
    share the step; a third of the certificate's cost)."""
    cfg = dataclasses.replace(cfg, certificate=dataclasses.replace(cfg.certificate,
                                                                   richardson=False))
    if cfg.solver.marches_time or cfg.hb.seed == "off":  # no [hb] method to lighten
        return cfg
    return dataclasses.replace(cfg, hb=dataclasses.replace(cfg.hb, seed="unconverged"))


def _sdp_member(cache: FileCache, model, log) -> DampingMember:
    """The decomposition criterion's SDP optimum for the study's ROM (the band's member
    ``sdp``), cached per ROM (the SCS solve is the costly part); a job of the second process
    (:mod:`.beside`), whose member the band stage sweeps."""
    key = FileCache.key({"rom": model.rom.content_hash(), "iterations": SDP_ITERATIONS,
                         "eps": SDP_EPS, "formulation": "null-space"})
    name = "tables/damping_sdp.npz"
    path = cache.get(name, key)
    fields = ("D1", "D2", "D3")
    if path is not None:
        with np.load(path) as z:
            info = json.loads(str(z["member"]))
            return DampingMember(**info, **{k: z[k] for k in fields})
    log(f"damping decompositions: the criterion's optimum (semidefinite program, SCS to "
        f"{SDP_EPS:g}, at most {SDP_ITERATIONS:,} iterations)")
    member = sdp_member(model.rom, model.rom)
    info = {k: v for k, v in dataclasses.asdict(member).items() if k not in fields}
    log(f"  SDP optimum t* = {member.report['optimum_t']:.3g} ({member.report['status']}, "
        f"{member.report['seconds']:.0f} s); smallest scaled eigenvalue "
        f"{member.min_eigenvalue_scaled:.2g}")

    def write(p):
        with atomic_path(p) as tmp, open(tmp, "wb") as fh:
            np.savez(fh, member=json.dumps(info), **{k: getattr(member, k) for k in fields})

    cache.put(name, key, write)
    return member


def _write_table(cache: FileCache, name: str, df: pd.DataFrame, key: str) -> Path:
    def write(p):
        from ..io import atomic_path

        with atomic_path(p) as tmp:
            df.to_csv(tmp, index=False)

    return cache.put(name, FileCache.key({"table": name, "of": key}), write)


def damping_check_cases(cfg) -> list[dict[str, Any]]:
    """The LCO sweep's cases at :data:`DAMPING_CHECK_ALTITUDES`, without the linear ones (γ = 0,
    no stiffness nonlinearity: they do not depend on the damping tensors)."""
    return [c for c in cfg.cases if float(c.get("altitude_ft", -1.0)) in DAMPING_CHECK_ALTITUDES
            and not (float(c.get("gamma", 0.0)) == 0.0 and not c.get("stiffness_nl", True))]


def _damping_check(cache: FileCache, cfg, check_cfg, main, model, device, dtype, log,
                   orbit=None) -> tuple[dict[str, Any], Any, pd.DataFrame]:
    """The Fig. 10 curves at :data:`DAMPING_CHECK_ALTITUDES` with ``model``, whose ROM's
    damping tensors are the exact Kelvin–Voigt ones (the pipeline with ``damping="exact"``,
    same basis and aerodynamics): tells how much of a difference from the paper the optimum
    decomposition causes (``check_cfg``: the study's secondary sweep of those cases). Returns
    the check (JSON-ready), the exact-damping model and its table. ``orbit``: the dissipation
    cycle's orbit from the main sweep (:func:`_cycle_orbit`), if any."""
    table, _, info, _ = _lco_sweep(cache, check_cfg, model, model.content_hash(), device, dtype,
                                   log, name=_sweep_name("lco_exact_damping", cfg))
    found = fnd.fig10_acceptance(table)
    for f in found:
        log(f"  exact damping: {f.key}: {f.verdict} ({f.ours})")
    cols = ["altitude_ft", "gamma", "stiffness_nl", "damping_nl", "status", "amplitude_pct_span",
            "frequency_hz"]
    return ({"findings": [f.as_dict() for f in found], "lco": info,
             "table": table[[c for c in cols if c in table]].to_dict(orient="records"),
             "dissipation": _dissipation_check(cache, cfg, main, model, log, orbit)}, model,
            table)


def _cycle_orbit(table: pd.DataFrame, orbits: pd.DataFrame | None, model
                 ) -> tuple[np.ndarray, float] | None:
    """The main HB sweep's orbit of the dissipation cycle's case (γ = 0, both nonlinearities,
    matched α, at the lowest check altitude) as (X, ω), or None (time marching, no such LCO)."""
    if orbits is None:
        return None
    row = table[(table["altitude_ft"] == min(DAMPING_CHECK_ALTITUDES)) & (table["gamma"] == 0.0)
                & (table["stiffness_nl"] == 1) & (table["damping_nl"] == 1)
                & (table["alpha_matched"] == 1) & (table["status"] == "lco")]
    if len(row) != 1:
        return None
    X, omega = orbits_of(orbits, [row["case_id"].iloc[0]], model.rom.n)
    return X[0], float(omega[0])


def _dissipation_check(cache: FileCache, cfg, main, exact, log, orbit=None) -> dict[str, Any]:
    """Nonlinear over linear dissipation of both damping identifications on the same γ = 0 LCO
    cycle (:mod:`.dissipation`) at the lowest check altitude, and the decomposition criterion
    (smallest scaled eigenvalue) of each; cached with the two models."""
    altitude = min(DAMPING_CHECK_ALTITUDES)
    key = FileCache.key({"config": cfg.hash, "altitude": altitude,
                         "models": [main.content_hash(), exact.content_hash()]})
    cached = cache.get_json("tables/dissipation_check.json", key)
    if cached is not None:
        return cached
    q, qd, status = lco_cycle(main, cfg, altitude, orbit=orbit)
    report = main.rom.metadata.get("damping", {}).get("report", {})
    out = {"altitude_ft": altitude, "status": status,
           "decomposition_ratio": dissipation_ratio(main.rom, q, qd),
           "exact_ratio": dissipation_ratio(exact.rom, q, qd),
           "decomposition_min_eigenvalue": scaled_min_eigenvalue(main.rom),
           "decomposition_min_eigenvalue_before_enforcement":
               report.get("after_whole", {}).get("min_eigenvalue_scaled"),
           "exact_min_eigenvalue": scaled_min_eigenvalue(exact.rom)}
    log(f"  dissipation on the gamma = 0 LCO at {altitude:,.0f} ft (nonlinear / linear): "
        f"decomposition {out['decomposition_ratio']:+.3f}, exact {out['exact_ratio']:+.3f}")
    cache.put("tables/dissipation_check.json", key, lambda p: write_json_atomic(p, out))
    return out


#: the stiffness nonlinearity's parts switched off in the report's cause section (the quick
#: run: whole and off only)
CAUSE_SWITCHES = {"full": tuple(SWITCHES), "quick": tuple(SWITCHES)[:2]}


def _stiffness_cause(cache: FileCache, cfg, model, quick: bool, log) -> dict[str, Any]:
    """:func:`.stiffness_cause.stiffness_cause` at 4,000 ft, γ = 1e-3 s (harmonic balance with
    the paper configuration's options), cached with the model."""
    switches = CAUSE_SWITCHES["quick" if quick else "full"]
    hb = with_method(cfg, "hb").hb.options
    key = FileCache.key({"model": model.content_hash(), "hb": repr(hb), "switches": switches,
                         "altitude": CAUSE_ALTITUDE_FT, "gamma": CAUSE_GAMMA})
    path = cache.get("tables/stiffness_cause.json", key)
    if path is not None:
        return json.loads(path.read_text())
    log(f"stiffness nonlinearity at gamma = {CAUSE_GAMMA:g} s, {CAUSE_ALTITUDE_FT:,.0f} ft: "
        f"{len(switches)} settings by harmonic balance, energy per cycle of each term")
    with Progress(len(switches), "  settings done", unit="settings") as bar:
        out = stiffness_cause(model, hb, altitudes=(CAUSE_ALTITUDE_FT,), switches=switches,
                              progress=bar.update_to)
    cache.put("tables/stiffness_cause.json", key, lambda p: write_json_atomic(p, out))
    return out


def _confirmation(cache: FileCache, cfg, model, model_hash: str, table: pd.DataFrame,
                  orbits: pd.DataFrame, device, log) -> tuple[pd.DataFrame, pd.DataFrame]:
    """:func:`.hb.newmark_confirmation` from the sweep's ``orbits``, cached with the HB table
    it confirms."""
    key = FileCache.key({"config": cfg.hash, "model": model_hash,
                         "table": config_hash(table["case_id"].tolist()),
                         "history": repr(cfg.history)})
    # beside the sweep's own files (its histories.parquet is the sweep's: sharing the name, each
    # replaced the other's and a rerun recomputed both)
    folder = f"sweeps/{_sweep_name('lco', cfg)}"
    names = (f"{folder}/confirmation.csv", f"{folder}/confirmation_histories.parquet")
    found = [cache.get(n, key) for n in names]
    if all(p is not None for p in found):
        return pd.read_csv(found[0]), pd.read_parquet(found[1])
    log("Newmark confirmation: a subset from the HB orbits at the paper's step")
    confirm, histories = newmark_confirmation(cfg, model, table, orbits, device)
    if len(confirm):
        worst = confirm["amplitude_diff_pct"].abs().max()
        log(f"  {len(confirm)} cases, amplitude within {worst:.2f} % of HB, frequency within "
            f"{confirm['frequency_diff_pct'].abs().max():.3f} %")

    def write_csv(p):
        from ..io import atomic_path

        with atomic_path(p) as tmp:
            confirm.to_csv(tmp, index=False)

    cache.put(names[0], key, write_csv)
    cache.put(names[1], key, lambda p: write_histories([histories], p))
    return confirm, histories


def _branches(cache: FileCache, cfg, model, model_hash: str, device, log) -> pd.DataFrame:
    """:func:`.hb.goland_branches`, cached by the model."""
    key = FileCache.key({"model": model_hash, "lco": repr(cfg.lco), "outputs": cfg.outputs,
                         "branches": "altitude", "certificate": repr(cfg.certificate)})
    name = "tables/lco_branches.csv"
    found = cache.get(name, key)
    if found is not None:
        table = pd.read_csv(found)
        table["stable"] = table["stable"].astype("boolean")
        return table
    log("LCO branches in altitude from the flutter point (gamma = 0 and 1e-3 s)")
    from ..periodic.newton import single_thread

    # one intra-op thread: with two, a Newton corrector of the continuation on the updated
    # wing's quick ROM stepped to -33,699 ft (outside the atmosphere) — torch 2.13's CPU
    # batched LU with two threads is unreliable for these systems (periodic.newton)
    with single_thread(), Progress(100, "  altitude range covered", unit="%") as bar:
        table = goland_branches(cfg, model, device,
                                progress=lambda f: bar.update_to(int(100 * f)), log=bar.write)

    def write_csv(p):
        from ..io import atomic_path

        with atomic_path(p) as tmp:
            table.to_csv(tmp, index=False)

    cache.put(name, key, write_csv)
    return table


def _sweep_name(name: str, cfg) -> str:
    """A sweep's cache folder name: ``name``, suffixed with the method unless it is the
    study's default (:data:`PAPER_METHOD`)."""
    return name if cfg.method == PAPER_METHOD else f"{name}_{cfg.method}"


def _sweep_key(cfg, model_hash: str, device, dtype) -> str:
    """The cache key of a sweep: the configuration, its cases and history, and the solver's
    own settings too — the study adjusts them after loading (:func:`_secondary`), which the
    configuration's hash does not see."""
    return FileCache.key({"config": cfg.hash, "cases": config_hash(cfg.cases),
                          "solver": repr(cfg.solver), "history": repr(cfg.history),
                          "model": model_hash, "device": str(device), "dtype": str(dtype)})


def _lco_sweep(cache: FileCache, cfg, model, model_hash: str, device, dtype, log,
               name: str = "lco"):
    """The LCO table, histories, timing and, by harmonic balance, the orbits (else None;
    :func:`torchrom.study.cases.orbit_table`), cached by the configuration, the model and the
    precision in ``sweeps/<name>/``."""
    key = _sweep_key(cfg, model_hash, device, dtype)
    names = (f"sweeps/{name}/results.parquet", f"sweeps/{name}/histories.parquet",
             f"sweeps/{name}/timing.json") + ((f"sweeps/{name}/orbits.parquet",)
                                              if cfg.solver.writes_orbits else ())
    found = [cache.get(n, key) for n in names]
    if all(p is not None for p in found):
        log(f"LCO sweep: reusing {found[0]}")
        timing = json.loads(found[2].read_text())
        return (pd.read_parquet(found[0]), pd.read_parquet(found[1]),
                {**timing, "reused": True, "reused_files": list(names)},
                pd.read_parquet(found[3]) if len(found) > 3 else None)
    how = cfg.solver.describe(cfg)
    log(f"LCO sweep: {len(cfg.cases)} cases of '{cfg.title}', {how}")
    hist: list[pd.DataFrame] = []
    orb: list[pd.DataFrame] = []
    certifies = cfg.solver.certificate(cfg).enabled
    with Progress(len(cfg.cases), "  cases done") as bar:
        def progress(done: int, total: int) -> None:
            if certifies and done >= total > bar.done:
                # the certificate of the last chunk's LCOs follows, without a count of its own
                bar.write(f"  {'every case' if cfg.solver.marches_time else 'every orbit'} "
                          "done; certifying the LCO rows (one shooting evaluation each)")
            bar.update_to(done)

        # finished chunks are kept in sweeps/<name>/parts (keyed by this sweep's cache key,
        # so the parts of another configuration, model or source are replaced, never reused):
        # an interrupted study resumes the sweep where it stopped
        # one batch up to the integrator's throughput knee (SWEEP_BATCH), not the runner's
        # default of several chunks for several workers: the study runs in one process, and
        # the study's sweeps (24-59 cases) are one chunk each — resumed chunk by chunk only
        # beyond SWEEP_BATCH cases or with [run] chunk_size
        table, timing = run_sweep(cfg, model=model, device=torch.device(device), dtype=dtype,
                                  progress=progress, on_history=hist.append,
                                  on_orbits=orb.append, out=cache.folder / "sweeps" / name,
                                  force=True, context=key, log=bar.write,
                                  chunk_size=sweep_chunk_size(cfg) or min(SWEEP_BATCH,
                                                                          cfg.batch_size))
    histories = pd.concat(hist, ignore_index=True) if hist else pd.DataFrame()
    orbits = pd.concat(orb, ignore_index=True) if cfg.solver.writes_orbits and orb else None
    counts = table["status"].value_counts().to_dict()
    log("  status: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())) +
        f"; {cfg.solver.cost_line(timing)} (the certificate {timing['certificate_s']:.1f} s "
        f"of it)")
    info = {"cases": len(table), "case_steps": int(timing["case_steps"]),
            "wall_time_s": float(timing["wall_time_s"]),
            "certificate_s": float(timing["certificate_s"]),  # of wall_time_s
            "us_per_case_step": float(timing["us_per_case_step"]),
            "resumed_cases": int(timing["reused"])}  # from the parts of an interrupted run

    def write_table(p):
        from ..io import atomic_path

        with atomic_path(p) as tmp:
            table.to_parquet(tmp, index=False)
        with atomic_path(p.with_suffix(".csv")) as tmp:
            table.to_csv(tmp, index=False)

    cache.put(names[0], key, write_table)
    cache.put(names[1], key, lambda p: write_histories([histories], p))
    cache.put(names[2], key, lambda p: write_json_atomic(p, info))
    if len(names) > 3:
        def write_orbits(p):
            with atomic_path(p) as tmp:
                (orbits if orbits is not None else pd.DataFrame(columns=["case_id", "omega", "k"])
                 ).to_parquet(tmp, index=False)

        cache.put(names[3], key, write_orbits)
    return table, histories, {**info, "reused": False, "reused_files": []}, orbits
