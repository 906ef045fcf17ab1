"""Regenerate ``docs/paper/`` and the generated blocks of the README and the docs pages.

    PYTHONPATH=. python docs/regenerate.py                      # runs `torchrom paper --out paper`
    PYTHONPATH=. python docs/regenerate.py --paper-dir DIR --no-run   # use an existing full run

Steps:

1. ``torchrom paper --out DIR`` (the full study, with one thread: the decomposition's D̄2, D̄3
   depend on the summation order; DIR defaults to ``paper/``, which git ignores, so a rerun
   reuses its cache and takes seconds once the study has been run);
2. copy ``DIR/figures/*.png`` and ``DIR/report.md`` into ``docs/paper/``, and ``DIR/paper.json``
   into ``docs/paper/paper.json`` without the fields that depend on the run rather than on the
   results (wall/CPU seconds, which files came from the cache, the output folder), and with the
   report's "Run" section pointing to the benchmark instead of that run's own timings;
3. ``torchrom flutter tests/decks/pynastran_pt145/pt145.bdf`` as given and with ``--symxz 1``;
4. rewrite every block between ``<!-- generated:NAME -->`` and ``<!-- /generated:NAME -->`` of
   the README and ``docs/**/*.md`` from ``docs/paper/paper.json``,
   ``benchmarks/results/*.json``, the sweep configuration's keys and step 3.

The numbers therefore come from files anyone can regenerate; ``tests/test_readme.py`` and
``tests/test_docs.py`` check that the blocks equal what :func:`render_blocks` makes of the
committed files. Deterministic: the same results give the same
files byte for byte, so running it twice changes nothing.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
from torchrom.paper.report import STIFFNESS_CAUSE_HEADING  # noqa: E402

README = ROOT / "README.md"
DOCS = ROOT / "docs" / "paper"
RESULTS = ROOT / "benchmarks" / "results"
BENCH = RESULTS / "bench_paper.json"
DECK_NAME = "tests/decks/pynastran_pt145/pt145.bdf"
DECK = ROOT / DECK_NAME
#: paper.json fields that describe the run, not its results
VOLATILE = ("seconds", "cpu_seconds", "model_seconds", "reused", "out", "figures", "processes")
BLOCK = re.compile(r"(<!-- generated:(?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /generated:"
                   r"(?P=name) -->)", re.S)


# -- formatting -----------------------------------------------------------------------------------
def _ft(x: float, digits: int = 0) -> str:
    return f"{x:,.{digits}f}"


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def _bench_runs(bench: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {r["form"]: r for r in bench["runs"]}


def block_commands(bench: dict[str, Any]) -> str:
    runs = _bench_runs(bench)
    full, quick = runs["full"], runs["quick"]
    cached = runs.get("quick, cached rerun")
    meta = bench.get("meta", {})
    lines = [
        f"    torchrom paper --out paper            # full study: {full['wall_s']:.0f} s",
        f"    torchrom paper --quick --out quick    # coarser grids, shorter runs: "
        f"{quick['wall_s']:.0f} s (CI runs it)",
        "",
        f"Times measured by `benchmarks/bench_paper.py` (`benchmarks/results/bench_paper.json`) "
        f"on a {meta.get('cpus', '?')}-core {meta.get('machine', '')} machine, torch "
        f"{meta.get('torch', '?')}, load average {full.get('load_average_1min_start', 0):.1f} at "
        f"the start: full {full['wall_s']:.0f} s, quick {quick['wall_s']:.0f} s (limits "
        f"{full['limit_s']:.0f} s and {quick['limit_s']:.0f} s)."]
    if cached is not None:
        lines[-1] += (f" A rerun into the same folder reuses every cached file and spends "
                      f"{cached['wall_s']:.1f} s in the study itself; the command adds the start "
                      f"of Python and the imports of torch, pandas and matplotlib.")
    return "\n".join(lines)


def block_flutter(paper: dict[str, Any]) -> str:
    fl, lin = paper["flutter"], paper["linear"]
    ss, pk, ref = fl["state_space"], fl["pk"], fl["paper"]
    return "\n".join([
        f"| flutter, Mach {fl['mach']:.2f}, baseline damping | altitude ft | frequency Hz |",
        "|---|---|---|",
        f"| torchrom, state space on the RFA (Eqs. 49–50) | {_ft(ss['altitude'])} | "
        f"{ss['frequency_hz']:.3f} |",
        f"| torchrom, p-k on the GAF table | {_ft(pk['altitude'])} | {pk['frequency_hz']:.3f} |",
        f"| batched simulator: sign change of the linear growth rate | "
        f"{_ft(lin['flutter_altitude_sim_ft'], 1)} (eigenvalues "
        f"{_ft(lin['flutter_altitude_eig_ft'], 1)}) | |",
        f"| paper (ZAERO) | {_ft(ref['altitude'])} | {ref['frequency_hz']:.3f} |"])


#: findings whose cause the report investigates in a section of its own: (summary key of the
#: section's data, the section's heading in report.md)
INVESTIGATED = {"stiffness_nl_small_at_gamma_1e-3": ("stiffness_cause", STIFFNESS_CAUSE_HEADING)}


def block_findings(paper: dict[str, Any]) -> str:
    rows = ["| | the paper | ours | verdict |", "|---|---|---|---|"]
    for f in paper["findings"]:
        ours = _cell(f["ours"])
        data, heading = INVESTIGATED.get(f["key"], (None, None))
        if data and paper.get(data):
            ours += f" — why: [report.md](docs/paper/report.md), section “{heading}”"
        rows.append(f"| {_cell(f['figure'])} | {_cell(f['paper'])} | {ours} | "
                    f"{f['verdict']} |")
    return "\n".join(rows)


def block_cause_check(paper: dict[str, Any]) -> str:
    check = paper["damping_check"]
    diss = check["dissipation"]
    lines = ["The report's *cause check* reruns the Fig. 10 cases at "
             + ", ".join(f"{a:,.0f}" for a in sorted({r['altitude_ft'] for r in check['table']}))
             + " ft with the exact Kelvin–Voigt tensors of the FE material in place of the "
               "optimum decomposition:", ""]
    for f in check["findings"]:
        lines.append(f"- {_cell(f['paper'])}: {_cell(f['ours'])} ({f['verdict']});")
    lines.append(
        f"- on the γ = 0 LCO cycle at {diss['altitude_ft']:,.0f} ft the nonlinear damping terms "
        f"dissipate {diss['decomposition_ratio']:+.3f} times the linear term's energy with our "
        f"decomposition and {diss['exact_ratio']:+.3f} with the exact tensors (nonlinear / "
        f"linear); the decomposition criterion (smallest scaled eigenvalue of the extended "
        f"damping matrix) is {diss['decomposition_min_eigenvalue']:.2e} for the decomposition and "
        f"{diss['exact_min_eigenvalue']:.2e} for the exact tensors.")
    return "\n".join(lines)


def block_band(paper: dict[str, Any]) -> str:
    """The Fig. 10 findings over the admissible damping decompositions (report.md's band)."""
    band = paper.get("decomposition_band")
    if not band:
        return "(no decomposition band in this run)"
    members = band["members"]
    family = [m for m in members if m.get("theta") is not None]
    sdp = [m for m in members if m.get("theta") is None]
    names = {f["key"]: f["paper"] for f in paper["damping_check"]["findings"]}

    def label(m):
        return f"θ = {m['theta']:g}" if m.get("theta") is not None else m["name"]

    lines = [f"The report's *decomposition band* reruns the same cases (the three altitudes "
             f"above; the findings table uses every altitude) with {len(members)} "
             f"admissible damping decompositions: {len(family)} on the segment from our optimum "
             "decomposition (θ = 0) to the exact tensors (θ = 1), θ = "
             + ", ".join(f"{m['theta']:g}" for m in family)
             + ("" if not sdp else ", and `sdp`, the decomposition criterion's own optimum over "
                "the whole admissible set (a semidefinite program solved by SCS: t* = "
                + f"{sdp[0]['solver']['optimum_t']:.2g})")
             + " (each checked: smallest scaled eigenvalue ≥ "
             + f"{min(m['min_eigenvalue_scaled'] for m in members):.1e}, K3 reproduced to "
             + f"{max(m['reproduction_error_K3'] for m in members):.1e} or better — our "
             "decomposition's own error: it is semidefinite only thanks to it, with the "
             "identified coefficients restored its smallest scaled eigenvalue is "
             + f"{band['decomposition_restored_min_eigenvalue']:.2g}; strictly admissible "
             "(K3 to 1e-6): "
             + ", ".join(label(m) for m in members if m["strict"]) + "):", ""]
    for key, verdict in band["findings"].items():
        per = ", ".join(f"{m['findings'][key]['verdict']} at {label(m)}" for m in members)
        lines.append(f"- {_cell(names.get(key, key))}: **{verdict}** ({per});")
    low = min(r["altitude_ft"] for r in band["band"])
    curve = {"0.0": "γ = 0 (NL stiff)", "1e-3 only": "γ = 1e-3 s only"}
    cells = [f"{curve.get(r['curve'], 'γ = ' + r['curve'] + ' s')} {r['min']:.2f}–{r['max']:.2f}"
             for r in band["band"] if r["altitude_ft"] == low]
    lines.append(f"- LCO amplitude band at {low:,.0f} ft (% of span): " + "; ".join(cells) + ".")
    return "\n".join(lines)


def block_deck(deck: dict[str, str]) -> str:
    return "\n".join([
        f"    $ torchrom flutter {DECK_NAME}",
        *(f"    {ln}" for ln in deck["plain"]),
        f"    $ torchrom flutter {DECK_NAME} --symxz 1 --length-unit in",
        *(f"    {ln}" for ln in deck["symmetric"])])


# -- the docs site's generated pages: verification (paper.json) and performance (benchmarks) ---
def _load(la: list[float] | None) -> str:
    return "?" if not la else f"{la[0]:.1f}"


def _machine(meta: dict[str, Any], load: str) -> str:
    """The machine and load line every timing carries."""
    threads = f", {meta['threads']} torch thread" if meta.get("threads") else ""
    return (f"Machine: {meta.get('cpus', '?')}-core {meta.get('machine', '?')}, torch "
            f"{meta.get('torch', '?')}{threads}; run {meta.get('date', '(date not recorded)')}; "
            f"1-minute load average {load}.")


def _count(x: float) -> str:
    return f"{x:,.0f}" if float(x).is_integer() else f"{x:,.1f}"


def _span(values: list[float]) -> str:
    lo, hi = min(values), max(values)
    return f"{lo:.1f}" if f"{lo:.1f}" == f"{hi:.1f}" else f"{lo:.1f}–{hi:.1f}"


def block_table2(paper: dict[str, Any]) -> str:
    rows = ["| mode | torchrom Hz | paper Hz | difference % | kind (ours) | kind (paper) |",
            "|---|---|---|---|---|---|"]
    for m in paper["flutter"]["table2"]:
        rows.append(f"| {m['mode']} | {m['frequency_hz']:.3f} | {m['paper_hz']:.3f} | "
                    f"{m['diff_pct']:+.2f} | {m['kind']} | {m['paper_kind'] or '–'} |")
    return "\n".join(rows)


def block_table3(paper: dict[str, Any]) -> str:
    sim = {r["altitude_ft"]: r for r in paper["linear"]["table3"]}
    rows = ["| altitude ft | state space Hz | p-k Hz | batched simulator Hz | paper Hz | "
            "state space vs paper % |", "|---|---|---|---|---|---|"]
    for r in paper["flutter"]["table3"]:
        s = sim.get(r["altitude_ft"], {})
        f_sim = f"{s['frequency_sim_hz']:.4f}" if s else "–"
        rows.append(f"| {_ft(r['altitude_ft'])} | {r['state_space_hz']:.4f} | {r['pk_hz']:.4f} | "
                    f"{f_sim} | {r['paper_hz']:.3f} | "
                    f"{100 * (r['state_space_hz'] / r['paper_hz'] - 1):+.2f} |")
    lin, fit = paper["linear"], paper["flutter"]["rfa_fit_error"]
    rows += ["", f"The batched simulator's linear growth rate changes sign at "
             f"{_ft(lin['flutter_altitude_sim_ft'], 1)} ft, the eigenvalue analysis's flutter "
             f"altitude is {_ft(lin['flutter_altitude_eig_ft'], 1)} ft (difference "
             f"{lin['difference_ft']:.2f} ft). The RFA reproduces the GAF table to "
             f"{fit['rms_relative']:.2%} RMS (largest weighted entry error "
             f"{fit['max_weighted']:.2%})."]
    return "\n".join(rows)


def block_branches(paper: dict[str, Any]) -> str:
    rows = ["| γ s | Hopf altitude ft | Hopf frequency Hz | stable from the Hopf point | folds | "
            "amplitude at the lowest altitude (% of span) |", "|---|---|---|---|---|---|"]
    for b in paper["hb"]["branches"]:
        rows.append(f"| {b['gamma']:g} | {_ft(b['hopf_altitude_ft'], 1)} | "
                    f"{b['hopf_frequency_hz']:.4f} | {'yes' if b['stable_from_hopf'] else 'no'} | "
                    f"{len(b['folds_ft']) or 'none'} | {b['amplitude_pct_span_there']:.2f} at "
                    f"{_ft(b['lowest_altitude_ft'])} ft |")
    return "\n".join(rows)


def block_perf_paper(bench: dict[str, Any]) -> str:
    rows = ["| run | method | processes | wall s | limit s | sweeps s (certificates s) | "
            "load at start |", "|---|---|---|---|---|---|---|"]
    for r in bench["runs"]:
        sweeps = (f"{r['sweep_solver_s']:.1f} ({r['sweep_certificate_s']:.1f})"
                  if "sweep_solver_s" in r else "–")
        rows.append(f"| {r['form']} | {r.get('method', 'newmark')} | {r.get('processes', 1)} | "
                    f"{r['wall_s']:.1f} | {r['limit_s']:.0f} | {sweeps} | "
                    f"{r['load_average_1min_start']:.1f} |")
    loads = [r["load_average_1min_start"] for r in bench["runs"]]
    runs = _bench_runs(bench)
    peer = []
    if "quick" in runs and "quick, one process" in runs:
        two, one = runs["quick"]["wall_s"], runs["quick, one process"]["wall_s"]
        peer = ["", f"The same quick study from nothing in one process (the peer, same script): "
                    f"{one:.1f} s against {two:.1f} s with the second process, "
                    f"{one / two:.2f}× the wall time."]
    return "\n".join([*rows, *peer, "", _machine(bench["meta"], _span(loads))])


def block_perf_goland(res: dict[str, Any]) -> str:
    meta = res["meta"]
    rows = [r for r in res["throughput"] if r.get("kind") == "throughput"]
    sizes = sorted({r["B"] for r in rows})
    table = {(r["setting"], r["dtype"], r["B"]): r["us_per_case_step"] for r in rows}
    keys = list(dict.fromkeys((r["setting"], r["dtype"]) for r in rows))
    out = ["| Newmark setting | dtype | " + " | ".join(f"B = {b}" for b in sizes) + " |",
           "|---|---|" + "---|" * len(sizes)]
    for setting, dtype in keys:
        opts = ", ".join(f"{k}={v}" for k, v in meta["settings"][setting].items())
        cells = [f"{table[(setting, dtype, b)]:.1f}" if (setting, dtype, b) in table else "–"
                 for b in sizes]
        out.append(f"| `{setting}` ({opts}) | {dtype} | " + " | ".join(cells) + " |")
    load = _span([r["load_average_1min"] for r in rows])
    return "\n".join([*out, "", _machine(meta, load) + f" Device: {meta.get('device', 'cpu')}."])


def block_perf_knee(res: dict[str, Any]) -> str:
    """Cost per case-step against the batch size on the paper's ROM (bench_batch_knee)."""
    meta = res["meta"]
    rows = [r for r in res["throughput"] if r.get("kind") == "throughput"]
    out = ["| B | µs per case-step (wall) | µs per case-step (CPU) | ms per step | load |",
           "|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['B']} | {r['us_per_case_step']:.1f} | "
                   f"{r['cpu_us_per_case_step']:.1f} | {r['ms_per_step']:.2f} | "
                   f"{r['load_average_1min']:.1f} |")
    cheapest = min(r["cpu_us_per_case_step"] for r in rows)
    small = [r["cpu_us_per_case_step"] for r in rows if 10 <= r["B"] <= 64]
    note = (f"The knee (the smallest B within {meta['knee_factor']:g}× of the cheapest cost): "
            f"B = {meta['knee_batch_cpu']} by CPU time, B = {meta['knee_batch']} by wall time; "
            f"B = 10–64 costs {min(small) / cheapest:.1f}–{max(small) / cheapest:.1f}× the "
            f"cheapest per case-step (CPU). {meta['steps']} steps per run, {meta['settings']}.")
    load = _span([r["load_average_1min"] for r in rows])
    return "\n".join([*out, "", note, _machine(meta, load)])


def _floor_sentence(floor: dict[str, float]) -> str:
    return (f"The certificate's evaluations alone (one shooting evaluation at h and one at 2h, "
            f"no finish, on the reference's start orbits) cost "
            f"{floor['evaluations_h_2h_cpu_s_per_lco']:.3f} CPU s per LCO "
            f"({floor['evaluation_h_cpu_s_per_lco']:.3f} at h alone): no certified method can "
            f"be more than {floor['largest_ratio_vs_reference_method']:.1f}× faster than "
            "`newmark-reference` with the shooting certificate, however it finds its orbits. "
            + (f"The Fourier certificate alone (harmonic-balance orbits, no time integration) "
               f"costs {floor['fourier_cpu_s_per_lco']:.3f} CPU s per LCO and certified "
               f"{floor['fourier_certified']} of the reference method's orbits. "
               if "fourier_cpu_s_per_lco" in floor else ""))


def block_perf_lco(res: dict[str, Any]) -> str:
    meta = res["meta"]
    out = ["| method | certified LCOs | CPU s per certified LCO (certificate included) | "
           "speed-up vs `newmark-reference` | amplitude / frequency error vs the continuous "
           "orbit % | largest orbit_error % | certificates bound the errors | stability "
           "unknown | Fourier-certified | certificate CPU s |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for m in res["methods"]:
        out.append(f"| `{m['method']}` | {m['certified']} of {m['lco_cases']} | "
                   f"{m['cpu_s_per_certified_lco']:.3f} | "
                   f"{m['cpu_ratio_vs_reference_method']:.1f}× | "
                   f"{m['max_amplitude_error_pct']:.3f} / {m['max_frequency_error_pct']:.3f} | "
                   f"{m['max_orbit_error_pct']:.3f} | "
                   f"{'yes' if m['certificates_bound_errors'] else 'no'} | "
                   f"{m['stability_unknown']} | {m.get('fourier_certified', 0)} | "
                   f"{m['certificate_cpu_s']:.2f} of {m['cpu_s']:.2f} |")
    return "\n".join([*out, "", f"{meta['cases']} cases, output {meta['output']}; reference: "
                       f"{meta['reference']}. An uncertified LCO counts as an infinite error. "
                       + (f"A certificate bounds a row's error when {meta['bound_check']}. "
                          if meta.get("bound_check") else "")
                       + (_floor_sentence(meta["certificate_floor"])
                          if meta.get("certificate_floor") else "")
                       + f"All methods in one run of {meta['wall_s']:.0f} s. "
                       + _machine(meta, _span(meta["load_average"]))])


def block_perf_integrator(res: dict[str, Any]) -> str:
    rows = res["throughput"]
    out = ["| mode | dtype | B | µs per case-step | load |", "|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['mode']} | {r['dtype']} | {r['B']} | {r['us_per_case_step']:.1f} | "
                   f"{r['load_average_1min']:.1f} |")
    for s in res.get("scipy", []):
        out += ["", f"SciPy Radau (analytic Jacobian) to the LCO of a flutter case at rtol "
                f"{s['scipy_rtol_matching']:g}, the loosest as accurate as torchrom (amplitude "
                f"error {s['torchrom_amplitude_error']:.1e}): {s['scipy_s_per_case']:.1f} s per "
                f"case against torchrom's {s['torchrom_s_per_case']:.2f} s batched, "
                f"{s['ratio_scipy_over_torchrom']:.1f}×."]
    return "\n".join([*out, "", _machine(res["meta"], _span([r["load_average_1min"]
                                                             for r in rows]))])


def block_perf_dask(res: dict[str, Any]) -> str:
    meta = res["meta"]
    out = ["| mode | wall s (best) | CPU s (best) | CPU ratio vs in-process (best; paired "
           "median) | wall ratio (paired median) | table identical |", "|---|---|---|---|---|---|"]
    loads = []
    for r in res["rows"]:
        loads += r.get("load_average_1min_runs", [])
        out.append(f"| {r['mode']} | {r['wall_s']:.1f} | {r['cpu_s']:.1f} | "
                   f"{r['cpu_ratio_vs_in_process']:.2f}; {r['cpu_ratio_paired_median']:.2f} | "
                   f"{r['wall_ratio_paired_median']:.2f} | "
                   f"{'yes' if r['identical_to_in_process'] else 'no'} |")
    return "\n".join([*out, "", f"{meta['cases']} cases, best of {meta['repeats']} runs each. "
                       + _machine(meta, _span(loads or meta["load_average"]))])


def block_perf_demo(res: dict[str, Any]) -> str:
    """The demo sweep against the baseline tree (``benchmarks/bench_demo.py``)."""
    meta, wall = res["meta"], res["wall"]
    labels = {"baseline": f"baseline ({meta['baseline']}), its demo (time marching)",
              "current": "now, the demo (`method = \"shooting\"`)",
              "current-newmark": "now, `--method newmark` (the baseline's transients, certified)"}
    out = ["| run | wall s (min; median) | solver s (min) | speed-up vs baseline (min; median) |",
           "|---|---|---|---|"]
    for label, w in wall.items():
        ratio = res["wall_ratio"].get(label)
        out.append(f"| {labels.get(label, label)} | {w['min_s']:.1f}; {w['median_s']:.1f} | "
                   f"{min(w['solver_s']):.1f} | "
                   + (f"{ratio['min']:.2f}×; {ratio['median']:.2f}×" if ratio else "1") + " |")
    st, sr = res["us_per_step"], res["step_ratio"]
    steps = "; ".join(f"B = {b[1:]}: {st['baseline'][b]:.0f} → {st['current'][b]:.0f} µs "
                      f"({sr[b]:.2f}×)" for b in st["current"])
    diff = res["tables_vs_baseline"]["current"]
    return "\n".join([*out, "", f"Whole `torchrom sweep` processes, {meta['repeats']} runs each, "
                       f"alternating. Time marching per batched step: {steps}. The shooting "
                       f"demo's {diff['lco_cases_compared']} LCO amplitudes differ from the "
                       f"baseline transients' by up to "
                       f"{100 * diff['max_relative_amplitude_difference']:.2f} % (the transients "
                       "stop at a per-cycle change of 1e-3). "
                       + _machine(meta, _span(meta["load_average"][:1]))])


def block_perf_uq(res: dict[str, Any]) -> str:
    """The Goland uncertainty study through the CLI (``benchmarks/bench_uq.py``)."""
    meta = res["meta"]
    out = ["| samples | workers | rows | certified LCOs | stability resolved | certificates | "
           "finished by shooting | wall s | CPU s (all processes) | CPU ms per case | "
           "load at start → end |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in res["runs"]:
        certs = ", ".join(f"{k} {v:,}" for k, v in r["certificates"].items())
        out.append(f"| {r['samples']:,} | {r['workers']} | {r['rows']:,} | {r['certified']:,} | "
                   f"{r['stability_resolved']:,} | {certs} | {r['finished']:,} | "
                   f"{r['wall_s']:.0f} | {r['cpu_s']:.0f} | {r['cpu_ms_per_case']:.1f} | "
                   f"{_load(r['load_before'])} → {_load(r['load_after'])} |")
    return "\n".join([*out, "", f"`{meta['command']}` on `{meta['config']}` (the same seed "
                       "and Latin hypercube at each sample count): the whole command as a user "
                       "runs it (start-up, model cache, Dask cluster, sweep, table and figures); "
                       "CPU seconds of the command and its worker processes. "
                       + _machine(meta, _span([r["load_before"][0] for r in res["runs"]]))])


def block_scale_cluster(res: dict[str, Any]) -> str:
    """A sweep in-process and on a cluster of separate scheduler and worker processes
    (``benchmarks/bench_dask_cluster.py``)."""
    meta = res["meta"]
    out = ["| run | chunks | command s (best) | sweep s (best) | CPU s (best) | sweep speed-up "
           "vs in-process (best; paired median) | table identical |",
           "|---|---|---|---|---|---|---|"]
    loads = []
    for r in res["throughput"]:
        loads += r["load_average_1min_runs"]
        speedup = ("1" if r["workers"] == 0 else f"{r['speedup_sweep_min']:.2f}×; "
                   f"{r['speedup_sweep_paired_median']:.2f}×")
        out.append(f"| {r['mode']} | {r['chunks']} | {r['wall_s']:.1f} | {r['sweep_s']:.1f} | "
                   f"{r['cpu_s']:.1f} | {speedup} | "
                   f"{'yes' if r['identical_to_in_process'] else 'no'} |")
    return "\n".join([*out, "", f"{meta['cases']} cases (two coupled Van der Pol–Duffing modes "
                       f"read from a ROM file), {meta['repeats']} alternating runs of whole "
                       "`torchrom sweep` processes each; command: start-up to figure; sweep: "
                       "its `time:` line; CPU: the command's and, on the cluster, its "
                       f"{meta['workers']} worker processes'. `{meta['command']}`. "
                       + _machine(meta, _span(loads))])


def block_config_keys() -> str:
    """The sections and keys a sweep configuration accepts, as ``torchrom.study.config`` checks
    them."""
    from torchrom.study import config as cfg

    keys = {**cfg.TABLE_KEYS, "aeroelastic": cfg.AEROELASTIC_KEYS,
            "hb": (*cfg._HB_OPTION_KEYS, *cfg._HB_METHOD_KEYS),
            "certificate": tuple(f.name for f in dataclasses.fields(cfg.Certificate))}
    rows = ["| section | keys |", "|---|---|"]
    for name in cfg.SECTIONS:
        if name in keys:
            rows.append(f"| `[{name}]` | " + ", ".join(f"`{k}`" for k in keys[name]) + " |")
    others = [f"`{n}`" for n in cfg.SECTIONS if n not in keys]
    return "\n".join([*rows, "", "Also at the top level: " + ", ".join(others)
                       + f"; `method` is one of {', '.join(cfg.SOLVERS)}."])


def bench_results() -> dict[str, Any]:
    """``benchmarks/results/*.json`` by file stem."""
    return {p.stem: json.loads(p.read_text()) for p in sorted(RESULTS.glob("*.json"))}


def render_blocks(paper: dict[str, Any], bench: dict[str, Any],
                  deck: dict[str, list[str]] | None = None,
                  results: dict[str, Any] | None = None) -> dict[str, str]:
    """Every generated block of the README and the docs pages (``deck``: the pt145 CLI lines,
    block left out if None; ``results``: :func:`bench_results`, read if None)."""
    results = bench_results() if results is None else results
    blocks = {"paper-commands": block_commands(bench), "paper-flutter": block_flutter(paper),
              "paper-findings": block_findings(paper),
              "paper-cause-check": block_cause_check(paper), "paper-band": block_band(paper),
              "verify-table2": block_table2(paper), "verify-table3": block_table3(paper),
              "verify-branches": block_branches(paper),
              "perf-paper": block_perf_paper(bench),
              "perf-goland": block_perf_goland(results["bench_goland"]),
              "perf-knee": block_perf_knee(results["bench_batch_knee"]),
              "perf-lco": block_perf_lco(results["bench_lco"]),
              "perf-integrator": block_perf_integrator(results["bench_integrator"]),
              "perf-dask": block_perf_dask(results["bench_dask"]),
              "perf-demo": block_perf_demo(results["bench_demo"]),
              "perf-uq": block_perf_uq(results["bench_uq"]),
              "scale-cluster": block_scale_cluster(results["bench_dask_cluster"]),
              "config-keys": block_config_keys()}
    if deck is not None:
        blocks["pt145-flutter"] = block_deck(deck)
    return blocks


def pages() -> list[Path]:
    """The Markdown files with generated blocks: the README and the docs site's pages."""
    return [README, *sorted(p for p in (ROOT / "docs").rglob("*.md") if p.parent != DOCS)]


def write_pages(blocks: dict[str, str]) -> None:
    """Rewrite each page's blocks; a block that no page holds is an error."""
    from torchrom.io import write_text_atomic

    placed: set[str] = set()
    for page in pages():
        text = page.read_text()
        mine = {k: v for k, v in blocks.items() if k in readme_blocks(text)}
        placed |= set(mine)
        if mine:
            write_text_atomic(page, replace_blocks(text, mine))
    if set(blocks) - placed:
        raise SystemExit(f"no page has a <!-- generated:{sorted(set(blocks) - placed)[0]} --> "
                         "block")


def readme_blocks(text: str) -> dict[str, str]:
    """The README's generated blocks (name: body without the trailing newline)."""
    return {m["name"]: m["body"].rstrip("\n") for m in BLOCK.finditer(text)}


def replace_blocks(text: str, blocks: dict[str, str]) -> str:
    """``text`` with the body of each named block replaced (a missing marker is an error)."""
    missing = set(blocks) - set(readme_blocks(text))
    if missing:
        raise SystemExit(f"README.md: no <!-- generated:{sorted(missing)[0]} --> block")

    def sub(m: re.Match) -> str:
        body = blocks.get(m["name"])
        return m.group(0) if body is None else f"{m.group(1)}{body}\n{m.group(4)}"

    return BLOCK.sub(sub, text)


# -- files ----------------------------------------------------------------------------------------
def docs_summary(paper: dict[str, Any]) -> dict[str, Any]:
    """paper.json without the fields that depend on the run rather than its results."""
    return {k: v for k, v in paper.items() if k not in VOLATILE}


def docs_report(report: str, bench: dict[str, Any]) -> str:
    """report.md with its "Run" section (this run's timings and cache hits) replaced by the
    benchmark's timings, and its figure links pointing beside it."""
    runs = _bench_runs(bench)
    run = ("## Run\n\nThe timings of a run depend on the machine, its load and the cache; the "
           "measured ones are in `benchmarks/results/bench_paper.json` (full "
           f"{runs['full']['wall_s']:.0f} s, quick {runs['quick']['wall_s']:.0f} s).\n\n")
    report = re.sub(r"## Run\n.*?(?=\n## )", run.rstrip("\n") + "\n", report, count=1, flags=re.S)
    return report.replace("](figures/", "](")  # docs/paper holds the figures beside the report


def deck_lines(cmd_extra: list[str]) -> list[str]:
    """The symmetry, units and flutter-point lines ``torchrom flutter`` prints on pt145."""
    out = subprocess.run([sys.executable, "-m", "torchrom", "flutter", str(DECK), *cmd_extra],
                         capture_output=True, text=True, check=True, cwd=ROOT,
                         env={**_env(), "PYTHONPATH": str(ROOT)}).stdout
    keep = ("symmetry:", "units:", "FLUTTER 30 (KE)")
    lines = [ln.strip() for ln in out.splitlines()]  # the crossings are listed indented
    return [ln for ln in lines if ln.startswith(keep) and "DLM" not in ln]


def _env() -> dict[str, str]:
    """The environment of the commands: one BLAS/torch thread, because the optimum damping
    decomposition's D̄2, D̄3 depend on the summation order
    (experiments/results/decomposition_spread.md)."""
    import os

    return {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--paper-dir", type=Path, default=ROOT / "paper",
                    help="output folder of the full `torchrom paper` run (default: paper/)")
    ap.add_argument("--no-run", action="store_true",
                    help="do not run `torchrom paper`; use the files already in --paper-dir")
    args = ap.parse_args(argv)
    sys.path.insert(0, str(ROOT))
    from torchrom.io import write_text_atomic

    if not args.no_run:
        subprocess.run([sys.executable, "-m", "torchrom", "paper", "--out", str(args.paper_dir)],
                       check=True, cwd=ROOT, env={**_env(), "PYTHONPATH": str(ROOT)})
    paper = json.loads((args.paper_dir / "paper.json").read_text())
    if paper.get("quick"):
        raise SystemExit(f"{args.paper_dir}: a --quick run; the docs need the full study")
    bench = json.loads(BENCH.read_text())
    DOCS.mkdir(parents=True, exist_ok=True)
    for png in sorted((args.paper_dir / "figures").glob("*.png")):
        shutil.copyfile(png, DOCS / png.name)
    summary = docs_summary(paper)
    write_text_atomic(DOCS / "paper.json", json.dumps(summary, indent=2) + "\n")
    report = (args.paper_dir / "report.md").read_text()
    write_text_atomic(DOCS / "report.md", docs_report(report, bench))
    deck = {"plain": deck_lines([]),
            "symmetric": deck_lines(["--symxz", "1", "--length-unit", "in"])}
    write_pages(render_blocks(summary, bench, deck))
    print(f"wrote {DOCS} and the generated blocks of the README and docs pages")
    return 0


if __name__ == "__main__":
    sys.exit(main())
