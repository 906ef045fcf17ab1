"""Where torchrom keeps the models it builds for configurations: the cache folder.

A configuration with ``[model] builtin = "goland"`` (``torchrom sweep``, ``calibrate``,
``bifurcation``, ``experiments/``) builds the heavy Goland FE model, its ROM, aerodynamics and
flutter point once (about two minutes) and keeps them, keyed by the hash of their inputs and the
package version (:mod:`torchrom.paper.cache`), in ``<root>/goland``. The root is, in this order:

1. ``--cache-dir DIR`` of the command (:func:`set_cache_root`);
2. the environment variable ``TORCHROM_CACHE``;
3. the platform's user cache folder (``platformdirs``): ``$XDG_CACHE_HOME/torchrom`` on Linux
   and the BSDs, else ``~/.cache/torchrom``; ``~/Library/Caches/torchrom`` on macOS;
   ``%LOCALAPPDATA%\\torchrom\\Cache`` on Windows.

The default used to be ``~/.cache/torchrom`` on every platform; it still is on Linux without
``XDG_CACHE_HOME``. Where the default now differs and that older folder holds model
folders, it is no longer read (the models are rebuilt once in the new place); ``torchrom cache
info`` names it (:func:`legacy_root`); ``torchrom cache clear --cache-dir ~/.cache/torchrom``
deletes it.

``[model] cache = "DIR"`` in a configuration names the Goland folder itself and bypasses the
root. ``torchrom cache info`` lists what is kept; ``torchrom cache clear`` deletes it (only
folders whose torchrom manifest, ``cache.json``, lists every file in them; ``--dry-run``).
A model folder is locked while it is built (:mod:`torchrom.locks`): a second process waits.
``torchrom paper`` keeps its own model files inside its output folder (``OUT/model``), not
here.
"""

from __future__ import annotations

import os
from pathlib import Path

ENV = "TORCHROM_CACHE"
APP = "torchrom"
_override: dict[str, Path | None] = {"root": None}


def set_cache_root(path: str | os.PathLike | None) -> None:
    """Use ``path`` as the cache root for this process (None: back to the default)."""
    _override["root"] = Path(path) if path is not None else None


def cache_root() -> Path:
    """The cache root (see the module docstring for the order)."""
    if _override["root"] is not None:
        return _override["root"]
    env = os.environ.get(ENV)
    return Path(env) if env else default_root()


def default_root() -> Path:
    """The platform's user cache folder of torchrom (platformdirs; read from the environment
    at each call, so that ``XDG_CACHE_HOME`` set in a running process counts)."""
    import platformdirs

    return Path(platformdirs.user_cache_dir(APP, appauthor=False))


def legacy_root() -> Path | None:
    """The former default root, ``~/.cache/torchrom``, where it differs from the root in use and
    still holds something (None otherwise): no longer read."""
    old = Path.home() / ".cache" / APP
    try:
        used = cache_root().resolve()
        if old.resolve() == used or not old.is_dir() or not any(old.iterdir()):
            return None
    except OSError:
        return None
    return old


def cache_folder(name: str) -> Path:
    """The folder of one cached model family, e.g. ``goland``."""
    return cache_root() / name
