"""Shared pytest configuration: the public pt145 deck, slow tests, torch threads."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import torch

REPO = Path(__file__).resolve().parents[1]


#: pyNastran's SOL 145 example (NASA test problem 10-2-1), with MSC Nastran's f06 beside it
PT145_DECK = REPO / "tests" / "decks" / "pynastran_pt145" / "pt145.bdf"


def pytest_addoption(parser):
    parser.addoption(
        "--runslow", action="store_true", default=False, help="also run tests marked slow"
    )


def pytest_configure(config):
    # CI has 2 cores; keep torch from oversubscribing when tests spawn workers.
    torch.set_num_threads(min(2, os.cpu_count() or 1))


def pytest_collection_modifyitems(config, items):
    if config.getoption("--runslow"):
        return
    skip_slow = pytest.mark.skip(reason="slow end-to-end test: run with --runslow")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip_slow)


@pytest.fixture(scope="session")
def pt145_deck() -> Path:
    """The pt145 deck in the repository (``tests/decks/pynastran_pt145/SOURCE.md``)."""
    return PT145_DECK


@pytest.fixture
def drawn(monkeypatch):
    """``drawn(module, fn, *args, **kw)``: calls the plotting function ``fn`` of ``module`` (its
    ``_save`` replaced) and returns the matplotlib figure it made, drawn and still open."""
    figs = []

    def keep(fig, path, *_):
        fig.canvas.draw()
        figs.append(fig)
        return path

    def draw(module, fn, *args, **kw):
        monkeypatch.setattr(module, "_save", keep)
        fn(*args, **kw)
        return figs[-1]

    yield draw
    import matplotlib.pyplot as plt

    for fig in figs:
        plt.close(fig)
