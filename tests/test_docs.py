"""The docs site and the README: their generated blocks are what the committed result files give
(``docs/regenerate.py``), their Python examples run as written, the command lines they show parse,
and the quickstart's first commands print what it shows."""

import contextlib
import importlib.util
import io
import json
import os
import re
import shlex
import subprocess
import sys

import pytest

from torchrom.cli import main

from .conftest import REPO

PAGES = ["README.md", *sorted(str(p.relative_to(REPO)) for p in (REPO / "docs").rglob("*.md")
                              if p.parent.name != "paper")]


def _regenerate():
    spec = importlib.util.spec_from_file_location("regenerate", REPO / "docs" / "regenerate.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, re.S)


#: the mark of a page whose ```python blocks run in order in one namespace, as the cells of a
#: notebook (each block's printed output is the ```text block right after it, where it has one)
NOTEBOOK_MARK = "<!-- docs-test: notebook -->"
NOTEBOOK_PAGES = [page for page in PAGES if NOTEBOOK_MARK in (REPO / page).read_text()]

EXAMPLES = [(page, i) for page in PAGES if page not in NOTEBOOK_PAGES
            for i in range(len(python_blocks((REPO / page).read_text())))]


def test_the_pages_hold_python_examples():
    assert len(EXAMPLES) >= 1
    assert "docs/guide/notebook.md" in NOTEBOOK_PAGES


def notebook_cells(text: str) -> list[tuple[str, str | None]]:
    """(code, the output shown under it or None) of each ```python block of a page, in order."""
    return [(m.group(1), m.group(2)) for m in
            re.finditer(r"```python\n(.*?)```(?:\s*```text\n(.*?)```)?", text, re.S)]


#: runs the cells (a JSON list, argv[1]) in one namespace, each one's stdout into argv[2]
_CELLS = """
import contextlib, io, json, sys
namespace, printed = {"__name__": "__main__"}, []
for k, code in enumerate(json.load(open(sys.argv[1]))):
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, f"{sys.argv[3]} cell {k + 1}", "exec"), namespace)
    printed.append(out.getvalue())
json.dump(printed, open(sys.argv[2], "w"))
"""


@pytest.mark.parametrize("page", NOTEBOOK_PAGES)
def test_notebook_page_runs_in_order_and_prints_what_it_shows(page, tmp_path):
    """A notebook page's blocks run as a notebook runs its cells — in order, in one namespace,
    in a fresh interpreter (a subprocess) in an empty folder, figures off screen — and each
    prints the ```text block shown under it, line for line."""
    cells = notebook_cells((REPO / page).read_text())
    assert cells
    (tmp_path / "cells.json").write_text(json.dumps([code for code, _ in cells]))
    env = {**os.environ, "MPLBACKEND": "Agg", "TORCHROM_CACHE": str(tmp_path / "cache")}
    run = subprocess.run([sys.executable, "-c", _CELLS, "cells.json", "printed.json", page],
                         cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-4000:]
    printed = json.loads((tmp_path / "printed.json").read_text())
    assert len(printed) == len(cells)
    for k, ((code, shown), out) in enumerate(zip(cells, printed)):
        if shown is not None:
            assert out.rstrip().splitlines() == shown.rstrip().splitlines(), f"{page} cell {k + 1}"
        elif "print(" in code:
            assert out.strip(), f"{page} cell {k + 1} printed nothing"


@pytest.mark.parametrize(("page", "index"), EXAMPLES)
def test_python_example_runs_as_written(page, index, tmp_path, monkeypatch):
    """Each ```python block runs in a fresh namespace (in an empty folder) and prints."""
    monkeypatch.chdir(tmp_path)
    code = python_blocks((REPO / page).read_text())[index]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, f"{page} python block {index + 1}", "exec"), {"__name__": "docs"})
    if "print(" in code:
        assert out.getvalue().strip()


def test_simulation_example_gives_the_lco_averaging_predicts():
    """The guide's batched example: α = 0 … 0.4 1/s self-excite mode 1 into an LCO whose
    amplitude falls as α grows; α = 0.8 1/s exceeds the negative linear damping (0.6 γ) and
    decays (first-order averaging: LCO for α < 0.6 γ)."""
    (code,) = [b for b in python_blocks((REPO / "docs/guide/configs.md").read_text())
               if "CaseSystem.build" in b]
    ns: dict = {"__name__": "docs"}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(code, ns)
    res = ns["result"]
    assert list(res.status) == ["lco", "lco", "lco", "decay"]
    amp = res.amplitude[:3, 0]
    assert amp[0] > amp[1] > amp[2] > 0.1


def test_generated_blocks_are_what_the_result_files_give():
    """Every generated block of the README and the docs pages equals what docs/regenerate.py
    makes of the committed docs/paper/paper.json and benchmarks/results/*.json; every block has
    a page (the pt145 block, which runs the CLI, is checked in test_readme.py)."""
    regen = _regenerate()
    paper = json.loads((REPO / "docs" / "paper" / "paper.json").read_text())
    bench = json.loads(regen.BENCH.read_text())
    expected = regen.render_blocks(paper, bench)
    placed = set()
    for page in regen.pages():
        for name, body in regen.readme_blocks(page.read_text()).items():
            placed.add(name)
            if name in expected:
                assert body == expected[name], (f"{page.name}: block {name} differs from the "
                                                 "result files; run docs/regenerate.py")
            else:
                assert name == "pt145-flutter", f"{page.name}: unknown generated block {name}"
    assert set(expected) <= placed


def test_performance_tables_carry_machine_and_load():
    """A timing says the machine and the load beside it (each benchmark block ends with them)."""
    regen = _regenerate()
    text = (REPO / "docs" / "performance.md").read_text()
    blocks = {k: v for k, v in regen.readme_blocks(text).items() if k.startswith("perf-")}
    assert len(blocks) == 8
    for name, body in blocks.items():
        assert re.search(r"Machine: \d+-core .*load average [\d.]+", body), name
    # the numbers are the file's: the Goland table's B = 512 paper setting
    res = json.loads((REPO / "benchmarks/results/bench_goland.json").read_text())
    (row,) = [r for r in res["throughput"]
              if (r["setting"], r["dtype"], r["B"]) == ("paper", "float64", 512)]
    assert f"{row['us_per_case_step']:.1f}" in blocks["perf-goland"]


def _commands(text: str, prompt_only: bool) -> list[list[str]]:
    """``torchrom …`` command lines of a Markdown text (``$ torchrom`` only when
    ``prompt_only``; never the commands' own output such as ``torchrom sweep: 4 cases …``)."""
    out = []
    for line in text.splitlines():
        s = line.strip()
        if s.startswith("$ "):
            s = s[2:]
        elif prompt_only or not line.startswith("    "):
            continue
        if not s.startswith("torchrom "):
            continue
        words = shlex.split(s.split("  #")[0])
        if len(words) > 1 and not words[1].endswith(":"):
            out.append(words)
    return out


@pytest.mark.parametrize("page", PAGES)
def test_documented_commands_parse(page):
    """Every command line shown in the README and the docs is accepted by the CLI's argument
    parser (options and choices as they are today)."""
    from torchrom.cli import build_parser

    parser = build_parser()
    for words in _commands((REPO / page).read_text(), prompt_only=page == "docs/quickstart.md"):
        try:
            parser.parse_args(words[1:])
        except SystemExit:
            pytest.fail(f"{page}: `{' '.join(words)}` is not a valid command line")


#: lines whose content is a time, a progress update (the quickstart shortens those) or a
#: rounding-level residual (its digits depend on the summation order)
_VOLATILE = re.compile(r"elapsed|ETA|^\s*time:|done in|us per case-step|^\s*…$|"
                       r"rounding level")


def quickstart_steps() -> list[tuple[list[str], list[str]]]:
    """(command words, the output lines shown) of each ``$ torchrom`` line of the quickstart."""
    steps = []
    for block in re.findall(r"```console\n(.*?)```", (REPO / "docs/quickstart.md").read_text(),
                            re.S):
        for line in block.splitlines():
            if line.startswith("$ torchrom "):
                steps.append((shlex.split(line[2:])[1:], []))
            elif steps and not _VOLATILE.search(line):
                steps[-1][1].append(line.rstrip())
    return steps


def _run_quickstart(tmp_path, monkeypatch, capsys, n_steps):
    monkeypatch.chdir(tmp_path)
    toml = re.search(r"`lco.toml`:\n\n```toml\n(.*?)```",
                     (REPO / "docs/quickstart.md").read_text(), re.S)
    (tmp_path / "lco.toml").write_text(toml.group(1))
    steps = quickstart_steps()
    assert len(steps) >= n_steps
    for words, shown in steps[:n_steps]:
        assert main(words) == 0, words
        cap = capsys.readouterr()
        printed = [ln.rstrip() for ln in (cap.out + cap.err).splitlines()
                   if not _VOLATILE.search(ln)]
        assert sorted(printed) == sorted(shown), f"torchrom {' '.join(words)}"


def test_quickstart_first_commands_print_what_it_shows(tmp_path, monkeypatch, capsys):
    """Steps 1–2 (the Goland deck and its modes) print the lines the quickstart shows, times and
    progress aside; the whole chain runs with --runslow."""
    _run_quickstart(tmp_path, monkeypatch, capsys, 2)


@pytest.mark.slow
def test_quickstart_prints_what_it_shows(tmp_path, monkeypatch, capsys):
    _run_quickstart(tmp_path, monkeypatch, capsys, len(quickstart_steps()))
