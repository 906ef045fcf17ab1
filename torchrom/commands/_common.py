"""Helpers shared by the sub-commands: --json/--force options and result reporting."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from ..io import write_json_atomic


def add_json_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--json",
        metavar="FILE",
        type=Path,
        help="also write the results machine-readably to FILE (JSON; keys and units documented)",
    )


def add_force_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--force", action="store_true", help="overwrite outputs that already exist"
    )


def maybe_write_json(args: argparse.Namespace, obj: Any) -> None:
    path = getattr(args, "json", None)
    if path is not None:
        write_json_atomic(path, obj)
        print(f"wrote {path}")
