"""The package as installed: its ``py.typed`` marker (PEP 561: the annotations are for type
checkers) is found by an import of the installed package and is in the wheel the build makes."""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile

from .conftest import REPO


def test_an_installed_import_finds_py_typed(tmp_path):
    """From another folder (so the import is the installed package's, editable or not, not the
    working directory's) the package's resources hold an empty ``py.typed``: an empty marker
    says the inline annotations are complete ("partial\\n" would say they are not)."""
    code = ("import importlib.resources, torchrom; "
            "marker = importlib.resources.files('torchrom').joinpath('py.typed'); "
            "print(marker.is_file(), repr(marker.read_text()), torchrom.__file__)")
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, timeout=120)
    assert run.returncode == 0, run.stderr
    found, text, where = run.stdout.split(" ", 2)
    assert (found, text) == ("True", "''"), run.stdout
    assert not where.startswith(str(tmp_path))


def test_the_wheel_ships_py_typed_and_the_package_data(tmp_path):
    """The wheel that pyproject.toml builds (setuptools, no network: a copy of the sources
    built in place) holds torchrom/py.typed beside the package data."""
    src = tmp_path / "src"
    src.mkdir()
    for name in ("pyproject.toml", "README.md"):
        shutil.copy(REPO / name, src / name)
    shutil.copytree(REPO / "torchrom", src / "torchrom",
                    ignore=shutil.ignore_patterns("__pycache__"))
    dist = tmp_path / "dist"
    dist.mkdir()
    code = f"from setuptools import build_meta; print(build_meta.build_wheel({str(dist)!r}))"
    run = subprocess.run([sys.executable, "-c", code], cwd=src, capture_output=True, text=True,
                         timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    wheel = dist / run.stdout.strip().splitlines()[-1]
    names = set(zipfile.ZipFile(wheel).namelist())
    assert "torchrom/py.typed" in names
    assert {f"torchrom/data/{p.name}" for p in (REPO / "torchrom" / "data").iterdir()} <= names
