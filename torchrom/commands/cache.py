"""``torchrom cache info|clear [--cache-dir DIR]``: the models kept for built-in configurations.

``info`` prints the cache root (``--cache-dir``, else ``$TORCHROM_CACHE``, else
``~/.cache/torchrom``; :mod:`torchrom.cache_dir`), and for each model folder in it the files, their
sizes and the package version that wrote them. ``clear`` deletes the model folders (only those
holding a torchrom manifest, ``cache.json``; anything else under the root is left and named).
JSON (--json, info): {"root", "folders": [{"name", "path", "bytes", "files": [{"name",
"bytes", "version"}]}]}.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import add_cache_option, add_json_option, maybe_write_json

NAME = "cache"
HELP = "show (info) or delete (clear) the models cached for built-in configurations"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("info", "clear"), help="info: list; clear: delete")
    add_cache_option(parser)
    add_json_option(parser)


def cache_folders(root: Path) -> list[Path]:
    """Sub-folders of ``root`` written by torchrom (they hold a ``cache.json`` manifest)."""
    from ..paper.cache import MANIFEST

    if not root.is_dir():
        return []
    return sorted(p for p in root.iterdir() if p.is_dir() and (p / MANIFEST).is_file())


def describe(folder: Path) -> dict:
    """Files of one cache folder with their sizes and the version recorded in the manifest."""
    import json

    from ..paper.cache import MANIFEST

    try:
        entries = json.loads((folder / MANIFEST).read_text()).get("files", {})
    except (json.JSONDecodeError, AttributeError):
        entries = {}
    files = []
    for name, entry in sorted(entries.items()):
        path = folder / name
        if path.is_file():
            files.append({"name": name, "bytes": path.stat().st_size,
                          "version": entry.get("version")})
    total = sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())
    return {"name": folder.name, "path": str(folder), "bytes": total, "files": files}


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000.0
    return f"{n:.1f} GB"


def run(args: argparse.Namespace) -> int:
    import shutil

    from ..cache_dir import ENV, cache_root, set_cache_root

    if args.cache_dir is not None:
        set_cache_root(args.cache_dir)
    root = cache_root()
    folders = cache_folders(root)
    if args.action == "info":
        info = {"root": str(root), "folders": [describe(f) for f in folders]}
        print(f"cache root: {root} (--cache-dir, ${ENV}, else ~/.cache/torchrom)")
        if not folders:
            print("  empty: nothing cached yet")
        for f in info["folders"]:
            print(f"  {f['name']}/: {_size(f['bytes'])} in {len(f['files'])} files")
            for e in f["files"]:
                print(f"    {e['name']:<16} {_size(e['bytes']):>9}  (torchrom {e['version']})")
        maybe_write_json(args, info)
        return 0
    for f in folders:
        shutil.rmtree(f)
        print(f"removed {f}")
    if not folders:
        print(f"nothing to remove in {root}")
    left = sorted(p.name for p in root.iterdir()) if root.is_dir() else []
    if left:
        print(f"left in {root} (not written by torchrom): {', '.join(left)}")
    return 0
