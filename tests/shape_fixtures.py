"""A small Goland chain for the shape tests (issue 47): the deck, a 6L8D ROM (the quickstart's),
its DLM aerodynamics on 6 modes at Mach 0.7 and a one-case harmonic-balance LCO sweep at
6,000 ft, run through the real command line in-process (about a minute)."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

from torchrom.cli import main

#: the shipped configuration of docs/guide/viewers.md
LCO_TOML = (Path(__file__).parents[1] / "configs" / "goland_lco_motion.toml").read_text()


def cli(folder: Path, *argv) -> int:
    """``torchrom ARGV -q`` in ``folder`` (its output swallowed)."""
    import os

    here = os.getcwd()
    os.chdir(folder)
    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            return main([*map(str, argv), "-q"])
    finally:
        os.chdir(here)


def goland_chain(folder: Path) -> Path:
    """Build the chain in ``folder`` (module docstring); returns it."""
    steps = [("goland", "--out", "run"),
             ("identify", "run/goland.bdf", "--linear", "6", "--dual", "8", "--combinations",
              "bending-torsion", "--out", "run/rom.npz"),
             ("aero", "run/goland.bdf", "--planform", "goland", "--mach", "0.7", "--modes", "6",
              "--out", "run/aero.npz")]
    (folder / "lco.toml").write_text(LCO_TOML)
    steps.append(("sweep", "lco.toml", "--out", "lco"))
    for argv in steps:
        assert cli(folder, *argv) == 0, argv
    return folder
