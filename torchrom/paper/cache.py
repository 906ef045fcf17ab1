"""A folder of intermediate files, each reused while the hash of its inputs is unchanged.

``cache.json`` in the folder maps each file name to the key (a hash of its inputs, the package
version and the package's source, :func:`source_fingerprint`) it was made from.
:meth:`FileCache.get` returns the file when its recorded key equals the requested one, so any
change of an input (an option, an upstream file, the package version, the code that computes the
files) rebuilds the file and, through the keys, everything downstream of it. Files are written
atomically (:mod:`torchrom.io`); the manifest is rewritten after each file. Hand-written.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from functools import lru_cache
from pathlib import Path
from typing import Any

from .._version import __version__
from ..errors import InputError
from ..io import write_json_atomic
from ..study.grid import config_hash

MANIFEST = "cache.json"
#: the package folder whose source files :func:`source_fingerprint` hashes
PACKAGE = Path(__file__).resolve().parents[1]


@lru_cache(maxsize=1)
def source_fingerprint() -> str:
    """SHA-256 of the package's source and data files (names and contents).

    Part of every key: the version number stays the same between commits, while a change of
    an element formulation or a solver changes the models and tables made from the same inputs
    (a cache keyed by the inputs alone would return the old ones)."""
    h = hashlib.sha256()
    for path in sorted(PACKAGE.rglob("*")):
        if path.suffix in (".py", ".toml", ".json") and "__pycache__" not in path.parts:
            h.update(path.relative_to(PACKAGE).as_posix().encode())
            h.update(path.read_bytes())
    return h.hexdigest()


class FileCache:
    """Intermediate files in ``folder`` keyed by the hash of their inputs.

    ``force``: ignore recorded keys (rebuild everything once in this session).
    """

    def __init__(self, folder, *, force: bool = False):
        self.folder = Path(folder)
        self.force = force
        self.path = self.folder / MANIFEST
        self.entries: dict[str, dict[str, Any]] = {}
        if self.path.is_file():
            try:
                entries = json.loads(self.path.read_text()).get("files", {})
                if not isinstance(entries, dict):
                    raise AttributeError("files")
                self.entries = entries
            except (json.JSONDecodeError, UnicodeDecodeError, AttributeError):
                # with --force every file is rebuilt and the manifest rewritten: a damaged one
                # is replaced, as the message below advises
                if not force:
                    raise InputError(f"{self.path}: not a torchrom cache manifest (it is left "
                                     f"as it is: delete it, choose another --cache-dir, or "
                                     f"rebuild the folder with torchrom paper --force)") from None
        self.hits: list[str] = []
        self.built: list[str] = []

    @staticmethod
    def key(inputs: dict[str, Any]) -> str:
        """The key of a file made from ``inputs`` by this package version and source."""
        return config_hash({"inputs": inputs, "version": __version__,
                            "source": source_fingerprint()})

    def get(self, name: str, key: str) -> Path | None:
        """The cached file ``name`` if it exists and was made from ``key``."""
        path = self.folder / name
        entry = self.entries.get(name)
        if self.force or entry is None or entry.get("key") != key or not path.exists():
            return None
        self.hits.append(name)
        return path

    def get_json(self, name: str, key: str) -> Any | None:
        """The parsed JSON file ``name`` if cached under ``key`` and readable; a damaged one
        (truncated, edited) is a miss, rebuilt by the caller."""
        path = self.get(name, key)
        if path is None:
            return None
        try:
            return json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError, OSError):
            self.hits.remove(name)
            self.entries.pop(name, None)
            return None

    def put(self, name: str, key: str, write: Callable[[Path], Any]) -> Path:
        """Write the file ``name`` with ``write(path)`` (which must write atomically) and record
        its key."""
        path = self.folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        write(path)
        self.entries[name] = {"key": key, "version": __version__}
        self.built.append(name)
        write_json_atomic(self.path, {"files": self.entries})
        return path

    def owns(self, name: str) -> bool:
        """Whether ``name`` was written through this cache (so it may be replaced)."""
        return name in self.entries
