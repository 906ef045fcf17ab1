"""One torchrom run per folder at a time: a lock file held for the run.

Every command that writes into a folder it keeps state in (``sweep --out``, ``paper --out``, a
cached model folder such as ``~/.cache/torchrom/goland``) holds :func:`folder_lock` on it for
the whole run. The lock is ``<folder>/.torchrom.lock``, locked with ``flock`` (Linux, macOS) and
holding the holder's PID, host and command. A second run on the same folder either refuses at
once (:class:`FolderBusy`, an :class:`~torchrom.errors.InputError`: exit 2, one line naming the
holder's PID) or, with ``wait=True`` (cache entries: the second run reuses what the first one
builds), waits for it. The kernel drops an ``flock`` when its process dies, so the lock of a
killed run is stale by construction: the next run takes it and says so. The file is removed
when the lock is released; a run that finds it replaced while it waited locks the new one.
Re-entrant within a process (a command that locks its folder may call an API that does too).
Where ``flock`` is not supported (some network file systems), the PID in the file decides: a
live process holds the folder, a dead one left a stale lock. Hand-written.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import socket
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

from .errors import InputError
from .io import check_folder, write_error

LOCK_NAME = ".torchrom.lock"

#: locks this process holds: resolved folder -> [file descriptor, depth]
_held: dict[str, list[int]] = {}
_guard = threading.Lock()


class FolderBusy(InputError):
    """Another live torchrom process holds the folder's lock."""


def lock_path(folder: str | os.PathLike) -> Path:
    return Path(folder) / LOCK_NAME


def read_holder(path: Path) -> dict[str, str]:
    """The holder recorded in a lock file ({} when unreadable): pid, host, command, since."""
    try:
        text = path.read_text(errors="replace")
    except OSError:
        return {}
    fields = dict(line.split("=", 1) for line in text.splitlines() if "=" in line)
    return {k: v.strip() for k, v in fields.items()}


def describe_holder(holder: dict[str, str]) -> str:
    """"PID 123 on host, `torchrom sweep ...` since 12:00:00" (what is known of it)."""
    if not holder.get("pid"):
        return "a process that has not written its PID yet"
    text = f"PID {holder['pid']}"
    if holder.get("host") and holder["host"] != socket.gethostname():
        text += f" on {holder['host']}"
    if holder.get("command"):
        text += f", `{holder['command'][:80]}`"
    if holder.get("since"):
        text += f", since {holder['since']}"
    return text


def _alive(pid: str) -> bool:
    try:
        os.kill(int(pid), 0)
    except (ValueError, ProcessLookupError):
        return False
    except PermissionError:  # another user's live process
        return True
    return True


def _try_flock(fd: int) -> bool | None:
    """True: locked; False: held by another process; None: flock not supported here."""
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        return True
    except BlockingIOError:
        return False
    except OSError as exc:
        if exc.errno in (errno.ENOLCK, errno.EOPNOTSUPP, errno.EINVAL):
            return None
        raise


def _same_file(fd: int, path: Path) -> bool:
    """Whether ``path`` still names the file open as ``fd`` (not removed by a releasing run)."""
    try:
        st = os.stat(path)
    except FileNotFoundError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def _acquire(folder: Path, what: str, wait: bool, log: Callable[[str], None]) -> int:
    path = lock_path(folder)
    announced = False
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            got = _try_flock(fd)
            holder = read_holder(path)
            if got is None:  # no flock here: the recorded PID decides
                got = not (holder.get("pid") and holder["pid"] != str(os.getpid())
                           and _alive(holder["pid"]))
            if not got:
                holder = _recorded_holder(path, holder)
                if not wait:
                    raise FolderBusy(
                        f"{folder}: in use by another torchrom run ({describe_holder(holder)});"
                        f" wait for it to finish, stop it, or choose another folder")
                if not announced:
                    log(f"{folder}: waiting for another torchrom run ({describe_holder(holder)})"
                        f" to finish {what}")
                    announced = True
                fcntl.flock(fd, fcntl.LOCK_EX)  # blocks; Ctrl-C interrupts it
            if not _same_file(fd, path):
                os.close(fd)  # the holder released and removed it meanwhile: lock the new one
                continue
            if holder.get("pid") and holder["pid"] != str(os.getpid()) and not announced:
                log(f"{folder}: recovered a stale lock of {describe_holder(holder)} "
                    f"(no longer running)")
            _write_holder(fd, what)
            return fd
        except BaseException:
            os.close(fd)
            raise


def _recorded_holder(path: Path, holder: dict[str, str]) -> dict[str, str]:
    """The holder, once it has written its PID: it locks the file first, then writes (up to a
    second later on a loaded machine)."""
    deadline = time.monotonic() + 2.0
    while not holder.get("pid") and time.monotonic() < deadline:
        time.sleep(0.02)
        holder = read_holder(path)
    return holder


def _write_holder(fd: int, what: str) -> None:
    argv = list(sys.argv) or [what]
    cli = argv[0].endswith(("torchrom", os.path.join("torchrom", "__main__.py")))
    command = " ".join(["torchrom" if cli else os.path.basename(argv[0]), *argv[1:]])
    text = (f"pid={os.getpid()}\nhost={socket.gethostname()}\n"
            f"command={command.replace(chr(10), ' ')}\nwhat={what}\n"
            f"since={time.strftime('%Y-%m-%d %H:%M:%S')}\n")
    os.ftruncate(fd, 0)
    os.pwrite(fd, text.encode(), 0)


def _release(folder: Path, fd: int) -> None:
    # remove before unlocking: a run that waited on this file sees it gone and locks a new one
    with contextlib.suppress(OSError):
        if _same_file(fd, lock_path(folder)):
            os.unlink(lock_path(folder))
    os.close(fd)


@contextlib.contextmanager
def folder_lock(folder: str | os.PathLike, what: str = "its run", *, wait: bool = False,
                log: Callable[[str], None] | None = None) -> Iterator[Path]:
    """Hold the lock of ``folder`` (created if missing) for the block; see the module
    docstring. ``what``: the work the lock protects, for messages; ``wait``: wait for a live
    holder instead of refusing (:class:`FolderBusy`)."""
    folder = Path(folder)
    log = log or (lambda msg: print(msg, file=sys.stderr))
    check_folder(folder, "output")
    created = not folder.exists()  # removed again if the run leaves it empty (refused input)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise write_error(folder, exc) from None
    key = str(folder.resolve())
    with _guard:
        entry = _held.get(key)
        if entry is not None:  # this process holds it already
            entry[1] += 1
    if entry is None:
        try:
            entry = [_acquire(folder, what, wait, log), 1]
        except OSError as exc:
            raise write_error(lock_path(folder), exc) from None
        with _guard:
            _held[key] = entry
    try:
        yield folder
    finally:
        with _guard:
            entry[1] -= 1
            last = entry[1] == 0
            if last:
                del _held[key]
        if last:
            _release(folder, entry[0])
            if created:
                with contextlib.suppress(OSError):
                    folder.rmdir()
