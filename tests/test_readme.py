"""The README: at most 200 lines, its generated numbers are those of the committed
``docs/paper/paper.json`` and benchmark file, the deck-flutter lines the Nastran guide quotes are
what ``torchrom flutter`` prints (``docs/regenerate.py`` writes both), and its test command is
what ``.ci/run`` runs. Examples and the docs pages' blocks: ``tests/test_docs.py``."""

import importlib.util
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


def test_readme_blocks_are_what_paper_json_gives():
    regen = _regenerate()
    paper = json.loads((REPO / "docs" / "paper" / "paper.json").read_text())
    bench = json.loads((REPO / "benchmarks" / "results" / "bench_paper.json").read_text())
    blocks = regen.readme_blocks(README)
    expected = regen.render_blocks(paper, bench)
    assert {"paper-commands", "paper-flutter", "paper-findings"} <= set(blocks)
    for name, body in blocks.items():
        assert expected[name] == body, f"README block {name} differs from docs/paper/paper.json; " \
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
    guide = (REPO / "docs" / "guide" / "nastran.md").read_text()
    assert regen.readme_blocks(guide)["pt145-flutter"] == regen.block_deck(lines)
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


def test_readme_is_short_and_links_what_exists():
    """The README stays a five-minute read; what it leaves out is on the docs site."""
    assert len(README.splitlines()) <= 200
    for link in re.findall(r"\]\(((?:docs/)[^)#]+)\)", README):
        assert (REPO / link).exists(), link


def test_ci_runs_exactly_the_readme_test_command():
    """`.ci/run` runs the README's test command verbatim (in a copy of the checkout's tracked
    files with nothing beside it), so the README's command is what CI proves."""
    (command,) = [ln for ln in README.splitlines()
                  if ln.startswith("python3 -m venv") and "[test]" in ln]
    ci = (REPO / ".ci" / "run").read_text()
    assert ci.rstrip("\n").splitlines()[-1] == command
    assert "ls-files" in ci and "mktemp -d" in ci and "mkdocs build --strict" in command
