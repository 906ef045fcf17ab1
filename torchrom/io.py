"""Small file helpers shared by every writer: atomic writes and no silent overwrites.

A result file is written to a temporary name in the same directory and renamed into place, so a
crash or interrupt never leaves a half-written file under the final name; it gets the permissions
of any new file (0666 less the umask), not the temporary file's private 0600. The rename is
durable (:func:`replace_durably`): the file's data is flushed to the disk before it (else a power
loss after the rename can leave an empty file under the final name: the rename is journaled
before the data is written) and the folder after it (the rename itself).
"""

from __future__ import annotations

import contextlib
import errno
import glob
import json
import os
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from .errors import InputError

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover - Python 3.10
    import tomli as tomllib


@contextlib.contextmanager
def atomic_path(path: str | os.PathLike, suffix: str | None = None) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds
    (:func:`replace_durably`: flushed to the disk before and after the rename).

    The temporary file keeps the final suffix (some writers, e.g. ``numpy.savez``, append one when
    it is missing).
    """
    path = Path(path)
    suffix = path.suffix if suffix is None else suffix
    tmp_path = None
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_stale_parts(path)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.",
                                   suffix=f".part{suffix}", dir=path.parent)
        os.close(fd)
        tmp_path = Path(tmp)
        yield tmp_path
        # mkstemp creates the file 0600; a result file gets the mode any new file would get
        # (0666 less the umask, typically 0644) before it appears under its final name
        if tmp_path.is_file():
            os.chmod(tmp_path, 0o666 & ~current_umask())
        replace_durably(tmp_path, path)
    except OSError as exc:
        # a full disk, a folder that is a file, no permission: one line, and the previous file
        # (if any) is left as it was
        raise write_error(path, exc) from None
    finally:
        if tmp_path is not None and tmp_path.exists():
            tmp_path.unlink()


def replace_durably(source: str | os.PathLike, target: str | os.PathLike) -> None:
    """``os.replace(source, target)`` that survives a power loss: ``source``'s data is flushed
    (``fsync``) before the rename and the folder's entry after it, so that after a crash at
    any point ``target`` is either the old file or the complete new one, never empty."""
    if Path(source).is_file():
        _sync_file(source)
    os.replace(source, target)
    sync_folder(Path(target).parent)


def _sync_file(path: str | os.PathLike) -> None:
    # Windows flushes only a handle open for writing; POSIX any descriptor of the file
    fd = os.open(path, os.O_RDONLY if os.name == "posix" else os.O_RDWR)
    try:
        _full_fsync(fd)
    finally:
        os.close(fd)


def _full_fsync(fd: int) -> None:
    """``fsync``, or on macOS ``F_FULLFSYNC`` (its ``fsync`` leaves the data in the drive's
    cache)."""
    if sys.platform == "darwin":
        import fcntl

        with contextlib.suppress(OSError):
            fcntl.fcntl(fd, fcntl.F_FULLFSYNC)
            return
    os.fsync(fd)


def sync_folder(folder: str | os.PathLike) -> None:
    """Flush a folder's entries (a rename, a new or removed file) to the disk. POSIX only:
    Windows cannot open a folder as a file, and NTFS journals its renames itself; file systems
    that cannot sync a folder (EINVAL, ENOTSUP) are left to their own guarantees."""
    if os.name != "posix":
        return
    fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    try:
        os.fsync(fd)
    except OSError as exc:
        if exc.errno not in (errno.EINVAL, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EBADF):
            raise
    finally:
        os.close(fd)


#: a temporary file of a writer whose process id cannot be read is stale after this (s)
STALE_PART_AGE_S = 3600.0


def remove_stale_parts(path: Path) -> list[Path]:
    """Remove the temporary files (``.NAME.PID.*.partSUFFIX``) that a killed writer of ``path``
    left (SIGKILL, power loss: no ``finally`` ran): those of a process that no longer runs, and
    those without a process id older than :data:`STALE_PART_AGE_S`. A live writer's are kept."""
    import time

    removed = []
    for tmp in path.parent.glob(f".{glob.escape(path.name)}.*.part*"):
        pid_text = tmp.name[len(path.name) + 2:].split(".", 1)[0]
        try:
            stale = not process_alive(int(pid_text))
        except ValueError:
            stale = time.time() - tmp.stat().st_mtime > STALE_PART_AGE_S
        if stale and tmp.is_file() and not tmp.is_symlink():
            tmp.unlink(missing_ok=True)
            removed.append(tmp)
    return removed


def process_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this machine (it may belong to another user; a
    zombie, dead but not yet reaped, counts as dead). psutil, not ``os.kill(pid, 0)``: on
    Windows signal 0 is CTRL_C_EVENT, sent to the process instead of testing it."""
    import psutil

    if pid <= 0:
        return False
    try:
        return psutil.Process(pid).status() != psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return False
    except psutil.AccessDenied:  # another user's live process
        return True


def current_umask() -> int:
    """The process's file-creation mask (read by setting and restoring it)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def write_error(path, exc: OSError) -> InputError:
    """The one-line InputError of a failed write of ``path``."""
    return InputError(f"{path}: cannot write: {exc.strerror or exc}"
                      + (f" ({exc.filename})" if exc.filename and str(exc.filename) != str(path)
                         else ""))


def write_text_atomic(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` to ``path`` atomically and return the path."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
    return Path(path)


def write_json_atomic(path: str | os.PathLike, obj: Any) -> Path:
    """Write ``obj`` as indented JSON (NaN written as null) atomically."""
    return write_text_atomic(path, json.dumps(_json_safe(obj), indent=2) + "\n")


def _json_safe(obj: Any) -> Any:
    """Convert numpy scalars/arrays and non-finite floats to plain JSON values."""
    import math

    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _json_safe(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_json_safe(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_json_safe(v) for v in obj.tolist()]
    if isinstance(obj, np.generic):
        obj = obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    if isinstance(obj, Path):
        return str(obj)
    return obj


def check_can_write(path: str | os.PathLike, force: bool, what: str = "output") -> Path:
    """The output policy of every writer, checked before any work: refuse (InputError) to
    replace an existing file unless ``force``, a path that is a folder, a path below a file,
    and a folder that cannot be written."""
    path = Path(path)
    if path.is_dir():
        raise InputError(f"{what} {path} is a folder; expected a file name")
    if path.exists() and not force:
        raise InputError(f"{what} {path} already exists; pass --force to overwrite it")
    check_folder(path.parent, what)
    return path


def check_folder(folder: str | os.PathLike, what: str = "output") -> Path:
    """InputError unless ``folder`` is (or can be created as) a writable folder."""
    folder = Path(folder)
    probe = folder
    while not probe.exists():
        if probe.parent == probe:
            break
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise InputError(f"{what} folder {folder}: {probe} is a file, not a folder")
    if probe.exists() and not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(f"{what} folder {folder}: {probe} is not writable")
    return folder


def check_referenced_path(path: str | os.PathLike, referrer: str | os.PathLike,
                          what: str) -> Path:
    """A file named inside another (an INCLUDE of a deck, a targets file's reference deck, a
    configuration's model file), checked before it is read. Policy: it must be a regular file
    inside the referring file's folder or the current working directory (or below them), so
    that a deck or configuration from elsewhere cannot make torchrom read, and quote in an
    error, any file on the machine (/etc/passwd, /dev/zero)."""
    path = Path(path)
    base = Path(referrer).resolve().parent
    full = (path if path.is_absolute() else base / path).resolve()
    roots = (base, Path.cwd().resolve())
    if not any(full == r or r in full.parents for r in roots):
        raise InputError(f"{referrer}: {what} {path}: outside the folder of {Path(referrer).name} "
                         f"and the working directory; files it names are read only from there "
                         f"(copy the file beside it)")
    if not full.is_file():
        raise InputError(f"{referrer}: {what} {path}: no such file"
                         + (" (not a regular file)" if full.exists() else ""))
    return full


def check_figure_path(path: str | os.PathLike, what: str = "figure") -> Path:
    """InputError unless ``path`` ends in a format the plotting library writes (png, pdf,
    svg, ...): checked before any work, so that no run ends on a figure it cannot save."""
    from matplotlib.backend_bases import FigureCanvasBase

    path = Path(path)
    formats = sorted(FigureCanvasBase.get_supported_filetypes())
    if path.suffix.lower().lstrip(".") not in formats:
        raise InputError(f"{what} {path}: expected a file name ending in one of "
                         f"{', '.join('.' + f for f in formats)}")
    return path


def write_figure(draw, *args, **kwargs):
    """Draw a figure after the tables are safe: a failure of the plotting library (e.g. a value
    it cannot place) is a warning on stderr, not an exception, so that nothing computed is lost;
    the caller ends with a non-zero status. Returns the path, or None when the figure failed.
    Bad input (an :class:`InputError`, e.g. an existing file without --force) still raises."""
    import sys

    try:
        return draw(*args, **kwargs)
    except InputError:
        raise
    except Exception as exc:  # noqa: BLE001 - any plotting failure must not lose the tables
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        print(f"warning: figure not written ({type(exc).__name__}: {first[:200]}); the tables "
              f"are written", file=sys.stderr)
        return None


def read_toml(path, what: str = "configuration file") -> tuple[Path, dict[str, Any]]:
    """(path, table) of a TOML file; InputError naming the file when it is missing, not UTF-8
    text or not valid TOML."""
    from .checks import expect_text_file

    source = Path(path)
    if not source.is_file() and not source.is_dir():
        raise InputError(f"{source}: no such {what}")
    expect_text_file(source, f"a {what} (TOML)", "study.toml")
    try:
        return source, tomllib.loads(source.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{source}: invalid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise InputError(f"{source}: not a text (UTF-8) file") from None
