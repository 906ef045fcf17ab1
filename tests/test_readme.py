"""The README: its Python examples run as written, its generated numbers are those of the
committed ``docs/paper/paper.json`` and benchmark file, and the deck-flutter lines it quotes are
what ``torchrom flutter`` prints (``docs/regenerate.py`` writes all three)."""

import contextlib
import importlib.util
import io
import json
import re

import pytest

from .conftest import REPO

README = (REPO / "README.md").read_text()


def _regenerate():
    spec = importlib.util.spec_from_file_location("regenerate", REPO / "docs" / "regenerate.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, re.S)


@pytest.mark.parametrize("index", range(len(python_blocks(README))))
def test_python_example_runs_as_written(index, tmp_path, monkeypatch):
    """Each ```python block of the README runs in a fresh namespace (in an empty folder)."""
    monkeypatch.chdir(tmp_path)
    code = python_blocks(README)[index]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(code, f"README.md python block {index + 1}", "exec"), {"__name__": "readme"})
    if "print(" in code:
        assert out.getvalue().strip()


def test_simulation_example_gives_the_lco_averaging_predicts():
    """The README's batched example: α = 0 … 0.4 1/s self-excite mode 1 into an LCO whose
    amplitude falls as α grows; α = 0.8 1/s exceeds the negative linear damping (0.6 γ) and
    decays (first-order averaging: LCO for α < 0.6 γ)."""
    (code,) = [b for b in python_blocks(README) if "CaseSystem.build" in b]
    ns: dict = {"__name__": "readme"}
    with contextlib.redirect_stdout(io.StringIO()):
        exec(code, ns)
    res = ns["result"]
    assert list(res.status) == ["lco", "lco", "lco", "decay"]
    amp = res.amplitude[:3, 0]
    assert amp[0] > amp[1] > amp[2] > 0.1


def test_readme_blocks_are_what_paper_json_gives():
    regen = _regenerate()
    paper = json.loads((REPO / "docs" / "paper" / "paper.json").read_text())
    bench = json.loads((REPO / "benchmarks" / "results" / "bench_paper.json").read_text())
    blocks = regen.readme_blocks(README)
    expected = regen.render_blocks(paper, bench)
    assert set(expected) <= set(blocks), "README.md lacks a generated block"
    for name, body in expected.items():
        assert blocks[name] == body, f"README block {name} differs from docs/paper/paper.json; " \
                                     f"run docs/regenerate.py"
    # independently of the renderer: the flutter table's numbers are paper.json's
    ss = paper["flutter"]["state_space"]
    row = next(ln for ln in blocks["paper-flutter"].splitlines() if "state space" in ln)
    assert f"{ss['altitude']:,.0f}" in row and f"{ss['frequency_hz']:.3f}" in row
    for f in paper["findings"]:
        assert f["ours"].replace("|", "\\|") in blocks["paper-findings"]
    # docs/paper/paper.json holds results only (nothing of one run's timing or cache state)
    assert not set(regen.VOLATILE) & set(paper) and not paper["quick"]
    # the figures the README links exist
    for link in re.findall(r"\(docs/paper/([\w.]+)\)", README):
        assert (REPO / "docs" / "paper" / link).is_file(), link


def test_readme_quotes_what_torchrom_flutter_prints_on_pt145():
    regen = _regenerate()
    lines = {"plain": regen.deck_lines([]),
             "symmetric": regen.deck_lines(["--symxz", "1", "--length-unit", "in"])}
    assert regen.readme_blocks(README)["pt145-flutter"] == regen.block_deck(lines)
    # NASA test problem 10-2-1 (strip theory): 121 Hz; the README quotes what is printed
    freq = [float(m[1]) for ln in lines["symmetric"]
            if (m := re.search(r"in/s, frequency ([\d.]+) Hz", ln))]
    assert len(freq) == 1 and abs(freq[0] / 121.0 - 1) <= 0.03


def test_replace_blocks_is_idempotent_and_refuses_a_missing_marker():
    regen = _regenerate()
    text = "a\n<!-- generated:x -->\nold\n<!-- /generated:x -->\nb\n"
    once = regen.replace_blocks(text, {"x": "new"})
    assert once == "a\n<!-- generated:x -->\nnew\n<!-- /generated:x -->\nb\n"
    assert regen.replace_blocks(once, {"x": "new"}) == once
    with pytest.raises(SystemExit, match="generated:y"):
        regen.replace_blocks(text, {"y": "z"})


def _commands(text: str, prompt_only: bool) -> list[str]:
    """``torchrom …`` command lines of a Markdown text (``$ torchrom`` only when
    ``prompt_only``; never the commands' own output such as ``torchrom sweep: 4 cases …``)."""
    import shlex

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


@pytest.mark.parametrize("doc", ["README.md", "docs/quickstart.md"])
def test_documented_commands_parse(doc):
    """Every command line shown in the README and the quickstart is accepted by the CLI's
    argument parser (options and choices as they are today)."""
    from torchrom.cli import build_parser

    text = (REPO / doc).read_text()
    commands = _commands(text, prompt_only=doc != "README.md")
    assert len(commands) >= 7
    parser = build_parser()
    for words in commands:
        try:
            parser.parse_args(words[1:])
        except SystemExit:
            pytest.fail(f"{doc}: `{' '.join(words)}` is not a valid command line")


def test_ci_runs_exactly_the_readme_test_command():
    """`.ci/run` runs the README's test command verbatim (in a copy of the checkout's tracked
    files with nothing beside it), so the README's command is what CI proves."""
    (command,) = [ln for ln in README.splitlines()
                  if ln.startswith("python3 -m venv") and "[test]" in ln]
    ci = (REPO / ".ci" / "run").read_text()
    assert ci.rstrip("\n").splitlines()[-1] == command
    assert "ls-files" in ci and "mktemp -d" in ci
