"""Shared pytest configuration: the ``../shared`` folder, slow tests, torch threads."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import torch

REPO = Path(__file__).resolve().parents[1]


def shared_dir() -> Path:
    """The project's shared folder: $TORCHROM_SHARED, else ``../shared`` beside the checkout."""
    env = os.environ.get("TORCHROM_SHARED")
    return Path(env) if env else REPO.parent / "shared"


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
def shared() -> Path:
    path = shared_dir()
    if not path.is_dir():
        pytest.fail(f"shared folder not found at {path}; set TORCHROM_SHARED")
    return path


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
