"""A folder of intermediate files, each reused while the hash of its inputs is unchanged.

``cache.json`` in the folder (format :data:`CACHE_FORMAT`) maps each file name to the key (a
hash of its inputs, the package version and the package's source, :func:`source_fingerprint`)
it was made from.
:meth:`FileCache.get` returns the file when its recorded key equals the requested one, so any
change of an input (an option, an upstream file, the package version, the code that computes the
files) rebuilds the file and, through the keys, everything downstream of it. Files are written
atomically (:mod:`torchrom.io`); the manifest is rewritten after each file.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from functools import lru_cache
from pathlib import Path
from typing import Any

from .._version import __version__
from ..errors import InputError
from ..io import write_json_atomic
from ..study.grid import config_hash

MANIFEST = "cache.json"
#: the manifest's "format": what ``torchrom cache clear`` checks before deleting anything
CACHE_FORMAT = "torchrom-file-cache-1"
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


def _file_sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


#: inside :func:`probing`: a cache miss raises :class:`CacheMiss` instead of returning None
_PROBING: ContextVar[bool] = ContextVar("torchrom_cache_probing", default=False)


class CacheMiss(Exception):
    """A file that a :func:`probing` call would have to build (its name)."""


@contextmanager
def probing() -> Iterator[None]:
    """Within the block every :class:`FileCache` (the study's, a model folder's) raises
    :class:`CacheMiss` where it would miss or write: a call that returns was cached whole and
    wrote nothing (:mod:`.beside` runs such a stage in place instead of starting a worker)."""
    token = _PROBING.set(True)
    try:
        yield
    finally:
        _PROBING.reset(token)


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
        """The cached file ``name`` if it exists and was made from ``key``. A file whose
        content is not what this cache wrote (its SHA-256 differs from the manifest's: edited
        by hand) is an InputError, before any work: neither reused nor replaced without
        ``force``."""
        path = self.folder / name
        entry = self.entries.get(name)
        if self.force or entry is None or not path.is_file():
            return self._miss(name)
        if "sha256" in entry and _file_sha256(path) != entry["sha256"]:
            raise InputError(f"{path}: changed since torchrom wrote it (its SHA-256 differs "
                             f"from the one in {self.path}); pass --force to rebuild it")
        if entry.get("key") != key:
            return self._miss(name)
        self.hits.append(name)
        return path

    def _miss(self, name: str) -> None:
        if _PROBING.get():
            raise CacheMiss(name)
        return None

    def get_json(self, name: str, key: str) -> Any | None:
        """The parsed JSON file ``name`` if cached under ``key`` and readable. A file changed
        since it was written is refused as :meth:`get` refuses it (``force`` rebuilds it); one
        that no longer parses without a recorded hash (an older manifest) is a miss, rebuilt
        by the caller."""
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
        path = self._write(name, key, write)
        self._save()
        return path

    def _save(self) -> None:
        """Rewrite the manifest (``cache.json``) with the entries."""
        write_json_atomic(self.path, {"format": CACHE_FORMAT, "files": self.entries})

    def _write(self, name: str, key: str, write: Callable[[Path], Any]) -> Path:
        """Write the file ``name`` and its entry (the manifest file itself is not rewritten)."""
        self._miss(name)  # a probe writes nothing
        path = self.folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        write(path)
        self.entries[name] = {"key": key, "version": __version__, "sha256": _file_sha256(path)}
        self.built.append(name)
        return path

    def owns(self, name: str) -> bool:
        """Whether ``name`` was written through this cache (so it may be replaced)."""
        return name in self.entries

    def adopt(self, written: dict[str, dict[str, Any]], hits: list[str]) -> None:
        """Record the files another process wrote into this folder through a
        :class:`DeferredCache` (``written``: name -> manifest entry) and those it reused."""
        self.entries.update(written)
        self.built += list(written)
        self.hits += [h for h in hits if h not in written]
        if written:
            self._save()


class DeferredCache(FileCache):
    """A :class:`FileCache` of a second process on the same folder: it reads the manifest as
    it was when opened and writes its own files, but not the manifest — the study's process
    records them (:meth:`FileCache.adopt` with :meth:`written`), so ``cache.json`` has one
    writer (:mod:`.beside`)."""

    def put(self, name: str, key: str, write: Callable[[Path], Any]) -> Path:
        return self._write(name, key, write)

    def written(self) -> dict[str, dict[str, Any]]:
        """The manifest entries of the files this cache wrote."""
        return {name: self.entries[name] for name in self.built}


def owned_files(folder) -> tuple[list[Path] | None, str]:
    """Every file of ``folder`` if a :class:`FileCache` wrote them all — its manifest (checked:
    :data:`CACHE_FORMAT`, or the same layout of entries written before the format field), the
    files it lists, their leftover temporary files and the folder's lock — else (None, why
    not). What ``torchrom cache clear`` may delete; symbolic links are never followed (one
    anywhere in the folder makes it not provably torchrom's)."""
    import os
    import re

    from ..locks import LOCK_NAME

    folder = Path(folder)
    manifest = folder / MANIFEST
    if folder.is_symlink():
        return None, "a symbolic link, not followed"
    if not folder.is_dir():
        return None, "not a folder"
    if manifest.is_symlink() or not manifest.is_file():
        return None, f"no {MANIFEST}"
    try:
        data = json.loads(manifest.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError):
        return None, f"{MANIFEST} is not JSON"
    entries = data.get("files") if isinstance(data, dict) else None
    if (not isinstance(entries, dict) or not entries
            or data.get("format", CACHE_FORMAT) != CACHE_FORMAT
            or not all(isinstance(e, dict) and re.fullmatch(r"[0-9a-f]{16}", str(e.get("key")))
                       and isinstance(e.get("version"), str) for e in entries.values())):
        return None, f"{MANIFEST} is not a torchrom cache manifest"
    owned = []
    for dirpath, dirnames, filenames in os.walk(folder, followlinks=False):
        here = Path(dirpath)
        for name in [*dirnames, *filenames]:
            path = here / name
            rel = path.relative_to(folder).as_posix()
            if path.is_symlink():
                return None, f"holds a symbolic link, {rel}"
            if name in dirnames:
                continue
            # a temporary file of torchrom.io.atomic_path left by a kill: .<name>.<random>.part*
            temp = ".part" in name and any(
                (here / Path(e).name) == folder / e and name.startswith(f".{Path(e).name}.")
                for e in entries)
            if rel in (MANIFEST, LOCK_NAME) or rel in entries or temp:
                owned.append(path)
            else:
                return None, f"holds {rel}, which its {MANIFEST} does not list"
    return owned, ""
