"""``torchrom cache info|clear [--cache-dir DIR] [--dry-run]``: the models kept for built-in
configurations.

``info`` prints the cache root (``--cache-dir``, else ``$TORCHROM_CACHE``, else the platform's user
cache folder, ``$XDG_CACHE_HOME/torchrom`` or ``~/.cache/torchrom`` on Linux;
:mod:`torchrom.cache_dir`), and for each model folder in it the files, their sizes and the
package version that wrote them; and the former default ``~/.cache/torchrom`` where it is no
longer read but still holds files. ``clear`` deletes only the model folders it can
prove torchrom wrote (:func:`torchrom.paper.cache.owned_files`: a checked torchrom manifest that
lists every file in the folder), file by file, never following a symbolic link; it names each
folder before deleting it and says why it leaves anything else (``--dry-run``: only the list).
A folder that a running torchrom holds (:mod:`torchrom.locks`) is left.
JSON (--json, info): {"root", "folders": [{"name", "path", "bytes", "files": [{"name",
"bytes", "version"}]}]}.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

from ._common import (
    add_cache_option,
    add_force_option,
    add_json_option,
    apply_cache_dir,
    check_outputs,
    maybe_write_json,
)

NAME = "cache"
HELP = "show (info) or delete (clear) the models cached for built-in configurations"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("action", choices=("info", "clear"), help="info: list; clear: delete")
    add_cache_option(parser)
    parser.add_argument("--dry-run", action="store_true",
                        help="clear: list what would be deleted, delete nothing")
    add_json_option(parser)
    add_force_option(parser)


def cache_folders(root: Path) -> list[Path]:
    """Sub-folders of ``root`` (not symbolic links) holding a ``cache.json`` manifest."""
    from ..paper.cache import MANIFEST

    if not root.is_dir():
        return []
    return sorted(p for p in root.iterdir() if not p.is_symlink() and p.is_dir()
                  and (p / MANIFEST).is_file())


def _tree_bytes(folder: Path) -> int:
    total = 0
    for dirpath, _dirs, files in os.walk(folder, followlinks=False):
        for name in files:
            path = Path(dirpath) / name
            if not path.is_symlink():
                total += path.stat().st_size
    return total


def describe(folder: Path) -> dict:
    """Files of one cache folder with their sizes and the version recorded in the manifest."""
    import json

    from ..paper.cache import MANIFEST

    try:
        entries = json.loads((folder / MANIFEST).read_text()).get("files", {})
    except (json.JSONDecodeError, AttributeError, UnicodeDecodeError, OSError):
        entries = {}
    files = []
    for name, entry in sorted(entries.items() if isinstance(entries, dict) else ()):
        path = folder / name
        if path.is_file() and not path.is_symlink() and isinstance(entry, dict):
            files.append({"name": name, "bytes": path.stat().st_size,
                          "version": entry.get("version")})
    return {"name": folder.name, "path": str(folder), "bytes": _tree_bytes(folder),
            "files": files}


def _size(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if n < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000.0
    return f"{n:.1f} GB"


def remove_owned(folder: Path, files: list[Path]) -> None:
    """Delete ``files`` (the manifest last: an interrupted clear leaves a folder that is still
    provably torchrom's), then the folders they leave empty, under the folder's lock."""
    from ..locks import LOCK_NAME, folder_lock
    from ..paper.cache import MANIFEST

    with folder_lock(folder, "a cache clear"):
        for path in sorted(files, key=lambda p: p.name == MANIFEST):
            if path.name != LOCK_NAME or path.parent != folder:
                path.unlink(missing_ok=True)
    for dirpath, _dirs, _files in sorted(os.walk(folder, followlinks=False), reverse=True):
        try:
            os.rmdir(dirpath)
        except OSError:  # not empty: something appeared meanwhile; it stays
            pass


def run(args: argparse.Namespace) -> int:
    from ..cache_dir import ENV, cache_root, default_root, legacy_root
    from ..locks import FolderBusy
    from ..paper.cache import owned_files

    check_outputs(args, [])  # the --json file: not replaced without --force
    apply_cache_dir(args)
    root = cache_root()
    folders = cache_folders(root)
    if args.action == "info":
        info = {"root": str(root), "folders": [describe(f) for f in folders]}
        print(f"cache root: {root} (--cache-dir, ${ENV}, else {default_root()})")
        if not folders:
            print("  empty: nothing cached yet")
        old = legacy_root()
        if old is not None:
            print(f"  {old}: the former default cache root, no longer read; `torchrom cache "
                  f"clear --cache-dir {old}` deletes the models in it")
        for f in info["folders"]:
            print(f"  {f['name']}/: {_size(f['bytes'])} in {len(f['files'])} files")
            for e in f["files"]:
                print(f"    {e['name']:<16} {_size(e['bytes']):>9}  (torchrom {e['version']})")
        maybe_write_json(args, info)
        return 0
    entries = sorted(root.iterdir()) if root.is_dir() and not root.is_symlink() else []
    removed, left = 0, []
    verb = "would remove" if args.dry_run else "removing"
    for entry in entries:
        files, why = owned_files(entry)
        if files is None:
            left.append(f"{entry.name}{'/' if entry.is_dir() and not entry.is_symlink() else ''}"
                        + (f" ({why})" if entry.is_dir() or entry.is_symlink() else ""))
            continue
        print(f"{verb} {entry}/ ({len(files)} files, {_size(_tree_bytes(entry))}): "
              + ", ".join(sorted(p.relative_to(entry).as_posix() for p in files)))
        if args.dry_run:
            continue
        try:
            remove_owned(entry, files)
        except FolderBusy as exc:
            left.append(f"{entry.name}/ ({str(exc).split(': ', 1)[-1].split(';')[0]})")
            continue
        removed += 1
        print(f"removed {entry}")
    if not removed and not args.dry_run:
        print(f"nothing to remove in {root}")
    if left:
        print(f"left in {root} (not provably written by torchrom): {', '.join(left)}")
    return 0
